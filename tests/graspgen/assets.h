// Small assets the graspgen tests write: a box, a cylinder and an L-bracket OBJ mesh, as MJCF.
#pragma once

#include <array>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "mlspaces/graspgen/mesh.h"
#include "test_util.h"

namespace mlspaces::graspgen::testing {

/// A box body (half sizes 0.02 0.025 0.04) at a non-trivial pose with a visual-only geom.
inline std::filesystem::path WriteBoxAsset(const std::filesystem::path& dir) {
  const auto path = dir / "box" / "box.xml";
  mlspaces::testing::WriteText(path, R"(<mujoco model="box">
  <worldbody>
    <body name="box" pos="0.3 -0.2 0.5" quat="0.9 0.1 0.2 0.3">
      <freejoint/>
      <geom name="box_collision" type="box" size="0.02 0.025 0.04"/>
      <geom name="box_visual" type="sphere" size="0.2" contype="0" conaffinity="0" group="2"/>
    </body>
  </worldbody>
</mujoco>
)");
  return path;
}

/// A cylinder (radius 0.025, half height 0.05) in a child body turned 90 deg about x.
inline std::filesystem::path WriteCylinderAsset(const std::filesystem::path& dir) {
  const auto path = dir / "cyl" / "cyl.xml";
  mlspaces::testing::WriteText(path, R"(<mujoco model="cyl">
  <worldbody>
    <body name="cyl" pos="1 2 3">
      <freejoint/>
      <body name="part" pos="0 0 0.01" euler="90 0 0">
        <geom name="cyl_collision" type="cylinder" size="0.025 0.05"/>
      </body>
    </body>
  </worldbody>
</mujoco>
)");
  return path;
}

/// OBJ text of a prism: a counter-clockwise profile in x-z (triangulated by `caps`, indices
/// into the profile) extruded +-0.02 m along y; `bad_vertex` adds a face on an extra vertex.
inline std::string PrismObj(const std::vector<std::array<double, 2>>& profile,
                            const std::vector<std::array<int, 3>>& caps,
                            const std::string& bad_vertex = {}) {
  const int n = static_cast<int>(profile.size());
  std::ostringstream obj;
  for (double y : {-0.02, 0.02}) {
    for (const auto& [x, z] : profile) obj << "v " << x << " " << y << " " << z << "\n";
  }
  if (!bad_vertex.empty()) obj << "v " << bad_vertex << "\n";
  // OBJ indices from 1: profile vertex i at y=-w is i+1, at y=+w is i+n+1.
  for (const auto& c : caps) {
    obj << "f " << c[0] + 1 << " " << c[1] + 1 << " " << c[2] + 1 << "\n";  // faces -y
    obj << "f " << c[0] + n + 1 << " " << c[2] + n + 1 << " " << c[1] + n + 1 << "\n";
  }
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    obj << "f " << i + 1 << " " << j + n + 1 << " " << j + 1 << "\n";
    obj << "f " << i + 1 << " " << i + n + 1 << " " << j + n + 1 << "\n";
  }
  if (!bad_vertex.empty()) obj << "f 1 2 " << 2 * n + 1 << "\n";
  return obj.str();
}

/// An L-bracket: legs 0.06 m long and 0.015 m thick (area 0.01275 m^2).
inline std::string LBracketObj(const std::string& bad_vertex = {}) {
  return PrismObj({{0, 0}, {0.06, 0}, {0.06, 0.015}, {0.015, 0.015}, {0.015, 0.06}, {0, 0.06}},
                  {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}}, bad_vertex);
}

/// A U-channel 0.08 m wide and 0.05 m high, walls and floor 0.015 m thick: the inner wall
/// faces are 0.05 m apart.
inline std::string UChannelObj() {
  return PrismObj({{0, 0},
                   {0.08, 0},
                   {0.08, 0.05},
                   {0.065, 0.05},
                   {0.065, 0.015},
                   {0.015, 0.015},
                   {0.015, 0.05},
                   {0, 0.05}},
                  {{1, 2, 3}, {1, 3, 4}, {0, 1, 4}, {0, 4, 5}, {0, 5, 6}, {0, 6, 7}});
}

/// An asset "<name>/<name>.xml" whose collision geometry is the OBJ text `obj`.
inline std::filesystem::path WriteObjAsset(const std::filesystem::path& dir,
                                           const std::string& name, const std::string& obj) {
  const auto path = dir / name / (name + ".xml");
  mlspaces::testing::WriteText(dir / name / (name + ".obj"), obj);
  mlspaces::testing::WriteText(path, "<mujoco model=\"" + name + "\">\n  <asset><mesh name=\"" +
                                         name + "\" file=\"" + name +
                                         ".obj\"/></asset>\n  <worldbody>\n    <body name=\"" +
                                         name + "\"><freejoint/><geom type=\"mesh\" mesh=\"" +
                                         name + "\"/></body>\n  </worldbody>\n</mujoco>\n");
  return path;
}

/// The L-bracket asset (`bad_vertex`: an extra vertex, e.g. "nan 0 0").
inline std::filesystem::path WriteLBracketAsset(const std::filesystem::path& dir,
                                                const std::string& bad_vertex = {}) {
  return WriteObjAsset(dir, "bracket", LBracketObj(bad_vertex));
}

/// Signed volume (positive for a closed mesh with outward faces).
inline double SignedVolume(const TriMesh& m) {
  double v = 0;
  for (const auto& f : m.faces) {
    const Vec3 &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
    v += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
          a[2] * (b[0] * c[1] - b[1] * c[0])) /
         6;
  }
  return v;
}

}  // namespace mlspaces::graspgen::testing
