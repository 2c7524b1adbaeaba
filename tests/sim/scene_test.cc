// Run-time composition: the tutorial scene + a robot + objects from a user library.
#include "mlspaces/sim/scene.h"

#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/library/asset_index.h"
#include "test_util.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
const fs::path kData = MLSPACES_TESTDATA_DIR;

TEST(Scene, InsertsRobotAndUserLibraryAssetsWithMetadata) {
  const mlspaces::testing::TempDir tmp;
  const fs::path lib = tmp / "library";
  fs::copy(kData / "library", lib, fs::copy_options::recursive);
  WriteFileAtomic(lib / "assets_index.json",
                  BuildAssetIndex(lib, AssetIndexOptions{}, nullptr).Serialize());
  Registry registry;
  registry.RegisterAssetLibrary("custom_assets", lib);

  Scene scene = Scene::Load(kData / "custom_assets/scene.xml");
  ASSERT_TRUE(scene.metadata()["objects"].contains("red_block"));
  Pose base;
  base.pos = {-0.5, 0, 0};
  auto robot = scene.InsertRobot(kData / "two_link_arm.xml", "robot_0/", base);
  ASSERT_EQ(robot.size(), 1u);
  Pose p;
  p.pos = {0.1, 0.2, 0.3};
  std::string body = scene.InsertAsset(registry, "neg_tet", p);
  EXPECT_EQ(body, "neg_tet_0/neg_tet");
  std::string body2 = scene.InsertAsset(registry, "given", p, "red_block", "second/");
  EXPECT_EQ(body2, "second/given");

  const Json& entry = scene.metadata()["objects"][body];
  EXPECT_EQ(entry["asset_id"], "neg_tet");
  EXPECT_EQ(entry["category"], "tetrahedron");
  EXPECT_EQ(entry["object_enum"], "temp_object");
  EXPECT_EQ(entry["is_static"], false);
  EXPECT_EQ(entry["asset_library"], "custom_assets");

  ModelPtr m = scene.Compile();
  EXPECT_EQ(m->nbody, 2 + 4 + 2);
  DataPtr d = MakeData(m.get());
  mj_kinematics(m.get(), d.get());
  int b = mj_name2id(m.get(), mjOBJ_BODY, "second/given");
  ASSERT_GE(b, 0);
  EXPECT_NEAR(d->xpos[3 * b + 0], 0.5, 1e-12);  // block (0.4, 0, 0.025) + (0.1, 0.2, 0.3)
  EXPECT_NEAR(d->xpos[3 * b + 2], 0.325, 1e-12);
  EXPECT_THROW(scene.InsertAsset(registry, "no_such_uid", p), Error);
  // The inserted asset keeps its own mesh and material, and the composed scene's keyframe-free
  // model compiles again after more insertions (Compile leaves the scene unchanged).
  EXPECT_EQ(m->nmesh, 1);
  EXPECT_EQ(scene.Compile()->nbody, m->nbody);
}

TEST(Scene, BadInsertionsAreErrorsAndLeaveTheSceneAsItWas) {
  const mlspaces::testing::TempDir tmp;
  const fs::path lib = tmp / "library";
  fs::copy(kData / "library", lib, fs::copy_options::recursive);
  // "twin": an asset with metadata but two top-level bodies.
  fs::create_directories(lib / "twin");
  fs::copy_file(lib / "multi/multi.xml", lib / "twin/twin.xml");
  WriteFileAtomic(lib / "twin/twin.json", R"({"assetId": "twin", "category": "pair"})");
  WriteFileAtomic(lib / "assets_index.json",
                  BuildAssetIndex(lib, AssetIndexOptions{}, nullptr).Serialize());
  Registry registry;
  registry.RegisterAssetLibrary("custom_assets", lib);
  Scene scene = Scene::Load(kData / "custom_assets/scene.xml");
  const size_t objects = scene.metadata()["objects"].size();
  try {
    scene.InsertAsset(registry, "given", Pose{}, "no_such_body");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), ::testing::HasSubstr("no_such_body"));
  }
  EXPECT_EQ(scene.metadata()["objects"].size(), objects);
  EXPECT_FALSE(scene.composer().HasBody("given_0/given"));
  EXPECT_EQ(scene.Compile()->nbody, 2);
  // An inserted object must have one top-level body.
  try {
    scene.InsertAsset(registry, "twin", Pose{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), ::testing::HasSubstr("exactly one top-level body"));
    EXPECT_EQ(fs::path(e.path()).filename(), "twin.xml");
  }
  EXPECT_FALSE(scene.composer().HasBody("twin_0/a"));
  EXPECT_EQ(scene.Compile()->nbody, 2);
  EXPECT_EQ(scene.metadata()["objects"].size(), objects);
}

// Bodies parked 35 m up (with a child, a joint and a site) leave the statistic, and with it the
// cameras' near plane, as the scene has it; a centre the scene sets stays.
TEST(Scene, BodiesLeftOutOfTheStatisticLeaveItAsTheSceneHasIt) {
  constexpr const char* kParked = R"(<mujoco><worldbody>
    <body name="shelf"><geom type="box" size="1 1 0.5"/></body>
    <body name="box" pos="0 0 0.6"><freejoint/><geom type="box" size="0.1 0.1 0.1"/>
      <site name="tip" pos="0 0 0.2"/>
      <body name="lid" pos="0 0 0.15"><joint type="hinge"/><geom type="sphere" size="0.05"/></body>
    </body></worldbody></mujoco>)";
  const Pose far{{5, 5, 35}, {1, 0, 0, 0}};
  auto load = [&](bool parked, bool left_out) {
    Scene scene = Scene::Load(kData / "custom_assets/scene.xml");
    scene.InsertRobot(kData / "two_link_arm.xml", "robot_0/", Pose{{-0.5, 0, 0}, {1, 0, 0, 0}});
    if (parked) scene.InsertRobotString(kParked, kData / "parked.xml", "parked/", far);
    if (left_out) scene.ExcludeFromStatistic("parked/");
    return scene.Compile();
  };
  const ModelPtr plain = load(false, false);
  const ModelPtr stretched = load(true, false);
  const ModelPtr kept = load(true, true);
  EXPECT_GT(stretched->stat.extent, 30);
  EXPECT_EQ(kept->nbody, stretched->nbody);
  ASSERT_GT(plain->stat.extent, 2 * kept->stat.meansize);  // the box, not the bodies' size
  EXPECT_NEAR(kept->stat.extent, plain->stat.extent, 1e-12);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(kept->stat.center[k], plain->stat.center[k], 1e-12);
  EXPECT_LT(kept->vis.map.znear * kept->stat.extent, 0.05) << "the near plane";

  // A centre the scene sets is kept; the extent is still the scene's.
  const mlspaces::testing::TempDir tmp;
  WriteFileAtomic(tmp / "set.xml", R"(<mujoco><statistic center="1 2 3"/><worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/></body></worldbody></mujoco>)");
  Scene set = Scene::Load(tmp / "set.xml");
  const ModelPtr alone = set.Compile();
  set.InsertRobotString(kParked, tmp / "parked.xml", "parked/", far);
  set.ExcludeFromStatistic("parked/");
  const ModelPtr with = set.Compile();
  EXPECT_EQ(with->stat.center[0], 1);
  EXPECT_EQ(with->stat.center[2], 3);
  EXPECT_NEAR(with->stat.extent, alone->stat.extent, 1e-12);
}

}  // namespace
}  // namespace mlspaces::sim
