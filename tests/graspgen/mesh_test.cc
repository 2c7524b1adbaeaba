// Collision geometry of assets and surface sampling (src/graspgen/mesh.cc), on real MuJoCo
// models the test writes.
#include "mlspaces/graspgen/mesh.h"

#include <cmath>
#include <functional>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "graspgen/assets.h"
#include "mlspaces/core/error.h"

namespace mlspaces::graspgen {
namespace {

using ::testing::HasSubstr;
using testing::SignedVolume;
using ::testing::StartsWith;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(GraspgenMeshTest, BoxIsInItsBodyFrameWithoutVisualGeoms) {
  mlspaces::testing::TempDir dir;
  const TriMesh m = AssetCollisionMesh(testing::WriteBoxAsset(dir.path()));
  EXPECT_EQ(m.faces.size(), 12u);
  EXPECT_NEAR(m.Area(), 8 * (0.02 * 0.025 + 0.02 * 0.04 + 0.025 * 0.04), 1e-12);
  EXPECT_NEAR(SignedVolume(m), 8 * 0.02 * 0.025 * 0.04, 1e-12);  // faces wind outward
  for (const Vec3& v : m.vertices) {                             // the body pose is factored out
    EXPECT_NEAR(std::abs(v[0]), 0.02, 1e-9);
    EXPECT_NEAR(std::abs(v[1]), 0.025, 1e-9);
    EXPECT_NEAR(std::abs(v[2]), 0.04, 1e-9);
  }
}

TEST(GraspgenMeshTest, CylinderInAChildBodyIsPlacedAndTessellated) {
  mlspaces::testing::TempDir dir;
  const TriMesh m = AssetCollisionMesh(testing::WriteCylinderAsset(dir.path()));
  const double r = 0.025, h = 0.05;
  const double area = 2 * std::numbers::pi * r * 2 * h + 2 * std::numbers::pi * r * r;
  EXPECT_NEAR(m.Area(), area, 0.02 * area);  // a 24-gon
  EXPECT_GT(SignedVolume(m), 0.95 * std::numbers::pi * r * r * 2 * h);
  // Child body at z 0.01, turned 90 deg about x: the axis is the body's y.
  for (const Vec3& v : m.vertices) {
    EXPECT_LE(std::abs(v[1]), h + 1e-9);
    EXPECT_LE(std::hypot(v[0], v[2] - 0.01), r + 1e-9);
  }
}

TEST(GraspgenMeshTest, ObjMeshKeepsItsCoordinates) {
  mlspaces::testing::TempDir dir;
  const TriMesh m = AssetCollisionMesh(testing::WriteLBracketAsset(dir.path()));
  EXPECT_EQ(m.faces.size(), 20u);
  EXPECT_NEAR(m.Area(), 2 * 0.001575 + 0.24 * 0.04, 1e-9);
  EXPECT_NEAR(SignedVolume(m), 0.001575 * 0.04, 1e-9);
  double lo = 1, hi = -1;
  for (const Vec3& v : m.vertices) lo = std::min(lo, v[2]), hi = std::max(hi, v[2]);
  EXPECT_NEAR(lo, 0, 1e-6);  // MuJoCo re-centres mesh vertices; the geom pose undoes it
  EXPECT_NEAR(hi, 0.06, 1e-6);
}

TEST(GraspgenMeshTest, SpheresCapsulesAndEllipsoidsAreClosedAndOutward) {
  mlspaces::testing::TempDir dir;
  const auto path = dir / "prims.xml";
  mlspaces::testing::WriteText(path, R"(<mujoco><worldbody><body name="p">
    <geom type="sphere" size="0.03" pos="0.2 0 0"/>
    <geom type="capsule" size="0.01 0.04" pos="0 0.2 0"/>
    <geom type="ellipsoid" size="0.01 0.02 0.03" pos="0 0 0.2"/>
  </body></worldbody></mujoco>)");
  const TriMesh m = AssetCollisionMesh(path);
  const double pi = std::numbers::pi;
  const double volume =
      4.0 / 3 * pi * (0.03 * 0.03 * 0.03 + 0.01 * 0.01 * 0.01 + 0.01 * 0.02 * 0.03) +
      pi * 0.01 * 0.01 * 0.08;
  EXPECT_NEAR(SignedVolume(m), volume, 0.06 * volume);
}

TEST(GraspgenMeshTest, NoCollisionGeometryIsAOneLineErrorNamingTheFile) {
  mlspaces::testing::TempDir dir;
  const auto path = dir / "ghost.xml";
  mlspaces::testing::WriteText(path, R"(<mujoco><worldbody><body name="ghost">
    <geom type="box" size="0.02 0.02 0.02" contype="0" conaffinity="0"/>
  </body></worldbody></mujoco>)");
  const std::string what = ErrorOf([&] { AssetCollisionMesh(path); });
  EXPECT_EQ(what, path.string() +
                      ": body ghost has no collision geometry (no geom with contype or "
                      "conaffinity set)");
}

TEST(GraspgenMeshTest, NanVertexIsAOneLineErrorNamingTheFile) {
  mlspaces::testing::TempDir dir;
  const auto path = testing::WriteLBracketAsset(dir.path(), "nan 0 0");
  const std::string what = ErrorOf([&] { AssetCollisionMesh(path); });
  EXPECT_THAT(what, StartsWith(path.string() + ": "));
  EXPECT_THAT(what, HasSubstr("not finite"));
  EXPECT_THAT(what, HasSubstr("element <mesh>: vertex coordinate 12 is not finite"));
  EXPECT_EQ(what.find('\n'), std::string::npos) << what;
}

TEST(GraspgenMeshTest, ValidatedMeshRejectsBadMeshesAndDropsDegenerateFaces) {
  TriMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}};
  m.faces = {{0, 1, 2}, {0, 1, 3}};  // the second repeats a vertex: zero area
  EXPECT_EQ(ValidatedMesh(m, "a.obj").faces.size(), 1u);
  TriMesh nan = m;
  nan.vertices[2][1] = std::nan("");
  EXPECT_EQ(ErrorOf([&] { ValidatedMesh(nan, "a.obj"); }),
            "a.obj: collision mesh vertex 2 is not finite");
  TriMesh flat = m;
  flat.faces = {{0, 1, 3}};
  EXPECT_EQ(ErrorOf([&] { ValidatedMesh(flat, "a.obj"); }),
            "a.obj: collision mesh has only degenerate (zero-area) triangles");
  TriMesh out_of_range = m;
  out_of_range.faces = {{0, 1, 7}};
  EXPECT_EQ(ErrorOf([&] { ValidatedMesh(out_of_range, "a.obj"); }),
            "a.obj: collision mesh face 0 has vertex index 7 out of range");
  EXPECT_EQ(ErrorOf([&] { ValidatedMesh(TriMesh{}, "a.obj"); }),
            "a.obj: collision mesh has no triangles");
}

TEST(GraspgenMeshTest, SurfaceSamplesAreOnTheSurfaceByAreaAndSeeded) {
  mlspaces::testing::TempDir dir;
  const TriMesh m = AssetCollisionMesh(testing::WriteBoxAsset(dir.path()));
  const double density = 2.5e-5;
  const SurfaceSamples s = SampleSurface(m, density, 7);
  ASSERT_EQ(s.points.size(), static_cast<size_t>(std::ceil(m.Area() / density)));  // 736
  const double half[3] = {0.02, 0.025, 0.04};
  double on_z_faces = 0;
  for (size_t i = 0; i < s.points.size(); ++i) {
    const Vec3 &p = s.points[i], &n = s.normals[i];
    int axis = -1;  // the face the point is on: the normal's axis, at +-half there
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(std::abs(p[k]), half[k] + 1e-12);
      if (std::abs(n[k]) > 0.5) axis = k;
    }
    ASSERT_GE(axis, 0);
    EXPECT_NEAR(p[axis], n[axis] * half[axis], 1e-12);
    on_z_faces += axis == 2;
  }
  // The two z faces hold 0.02*0.025*8 / area = 21.7% of the area.
  EXPECT_NEAR(on_z_faces / s.points.size(), 0.004 / m.Area(), 0.05);
  const SurfaceSamples again = SampleSurface(m, density, 7);
  EXPECT_EQ(again.points, s.points);
  EXPECT_NE(SampleSurface(m, density, 8).points, s.points);
}

}  // namespace
}  // namespace mlspaces::graspgen
