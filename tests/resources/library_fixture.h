// A generated asset + grasp library for the pack and install tests: N assets in the
// tutorial layout (<uid>/<uid>.xml + .json, <uid>/droid/grasps.npz), some with joint grasps,
// NPZ metadata arrays and a mesh file, indexed with the library functions.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/core/npz.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/library/grasp_index.h"
#include "test_util.h"

namespace mlspaces::testing {

inline std::string FixtureUid(size_t i) { return "obj_" + std::to_string(1000 + i); }

/// Writes the library into `dir` and indexes it. Asset i has 3 + i % 5 pickup grasps; every
/// third asset also has joint grasps for "hinge" and NPZ metadata; every fourth a second robot.
inline void MakeFixtureLibrary(const std::filesystem::path& dir, size_t n) {
  namespace fs = std::filesystem;
  for (size_t i = 0; i < n; ++i) {
    const std::string uid = FixtureUid(i);
    const fs::path a = dir / uid;
    WriteText(a / (uid + ".xml"), "<mujoco model=\"" + uid +
                                      "\"><asset><mesh name=\"m\" file=\"meshes/part.obj\"/>"
                                      "</asset><worldbody><body name=\"" +
                                      uid +
                                      "\"><freejoint/><geom type=\"box\" "
                                      "size=\"0.02 0.02 0.02\"/></body></worldbody></mujoco>\n");
    WriteText(a / "meshes" / "part.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n# " + uid + "\n");
    WriteText(a / (uid + ".json"), "{\n    \"assetId\": \"" + uid + "\",\n    \"category\": \"" +
                                       std::string(i % 2 == 0 ? "mug" : "block") +
                                       "\",\n    \"tags\": [\"t" + std::to_string(i % 3) +
                                       "\", \"all\"],\n    \"mass\": " +
                                       std::to_string(0.1 + 0.01 * static_cast<double>(i)) + "\n}");
    Rng rng(i);
    auto poses = [&](size_t k) {
      std::vector<double> v;
      for (size_t g = 0; g < k; ++g) {
        const double yaw = rng.Uniform(0, 6.28);
        const double m[16] = {std::cos(yaw),
                              -std::sin(yaw),
                              0,
                              rng.Uniform(-0.1, 0.1),
                              std::sin(yaw),
                              std::cos(yaw),
                              0,
                              rng.Uniform(-0.1, 0.1),
                              0,
                              0,
                              1,
                              rng.Uniform(0, 0.2),
                              0,
                              0,
                              0,
                              1};
        v.insert(v.end(), m, m + 16);
      }
      return NpyArray::FromDoubles({k, 4, 4}, v);
    };
    WriteNpz(a / "droid" / "grasps.npz", {{"transforms", poses(3 + i % 5)}});
    if (i % 3 == 0) {
      WriteNpz(a / "droid" / "joint_grasps_hinge.npz", {{"transforms", poses(4)}});
      const std::vector<double> img = {1, 2, 3, 4, 5, 6}, counts = {1, 2, 3};
      WriteNpz(a / (uid + ".npz"), {{"clip/img", NpyArray::FromDoubles(DType::kF2, {2, 3}, img)},
                                    {"counts", NpyArray::FromDoubles(DType::kI8, {3}, counts)}});
    }
    if (i % 4 == 0) WriteNpz(a / "rum" / "grasps.npz", {{"transforms", poses(2)}});
  }
  IndexReport report;
  WriteAssetIndex(dir, AssetIndexOptions{});
  GraspIndexOptions gopts;
  WriteGraspIndex(dir, gopts);
}

}  // namespace mlspaces::testing
