// The grasp-generation job (graspgen/generate.h) and `mlspaces generate-grasps`: files, index,
// resume, determinism whatever the thread count, per-object failures with reasons.
#include "mlspaces/graspgen/generate.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "assets.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/graspgen/grasp_sim.h"
#include "mlspaces/library/grasp_index.h"
#include "test_util.h"

namespace mlspaces::graspgen {
namespace {

namespace fs = std::filesystem;
using mlspaces::testing::RunCli;
using mlspaces::testing::Slurp;
using mlspaces::testing::TempDir;
using mlspaces::testing::WriteText;
using ::testing::HasSubstr;

// A library of graspable and ungraspable objects, each <uid>/<uid>.xml + <uid>.json.
fs::path WriteLibrary(const fs::path& dir) {
  fs::path lib = dir / "lib";
  // A 4 x 5 x 7 cm box at a turned pose (grasps are in its body frame).
  WriteText(lib / "box" / "box.xml", R"(<mujoco model="box"><worldbody>
  <body name="box" pos="0.3 -0.2 0.5" quat="0.9 0.1 0.2 0.3"><freejoint/>
    <geom type="box" size="0.02 0.025 0.035" density="500"/></body>
</worldbody></mujoco>
)");
  testing::WriteLBracketAsset(lib);
  WriteText(lib / "big" / "big.xml", R"(<mujoco model="big"><worldbody>
  <body name="big"><freejoint/><geom type="box" size="0.1 0.12 0.15"/></body>
</worldbody></mujoco>
)");
  WriteText(lib / "ghost" / "ghost.xml", R"(<mujoco model="ghost"><worldbody>
  <body name="ghost"><freejoint/><geom type="box" size="0.02 0.02 0.02" contype="0" conaffinity="0"/></body>
</worldbody></mujoco>
)");
  for (const char* uid : {"box", "bracket", "big", "ghost"}) {
    WriteText(lib / uid / (std::string(uid) + ".json"), mlspaces::testing::MinimalMetadata(uid));
  }
  return lib;
}

GenerateOptions Small(const fs::path& lib) {
  GenerateOptions o;
  o.library_dir = lib;
  o.max_grasps = 4;
  o.seed = 7;
  o.threads = 1;
  o.progress = false;
  return o;
}

const ObjectReport& Find(const GenerateReport& report, const std::string& uid) {
  for (const auto& o : report.objects) {
    if (o.uid == uid) return o;
  }
  throw std::runtime_error("no report for " + uid);
}

TEST(GraspgenGenerateTest, WritesFloat16GraspsIndexAndReasons) {
  TempDir tmp;
  fs::path lib = WriteLibrary(tmp.path());
  GenerateOptions o = Small(lib);
  o.uids = {"box", "big", "ghost"};
  o.give_up_after = 100;
  std::vector<std::string> seen;
  GenerateReport report = GenerateGrasps(o, [&](const ObjectReport& r) { seen.push_back(r.uid); });
  EXPECT_EQ(seen, (std::vector<std::string>{"box", "big", "ghost"}));

  const ObjectReport& box = Find(report, "box");
  ASSERT_EQ(box.status, ObjectReport::Status::kDone) << box.reason;
  EXPECT_EQ(box.accepted, 4u);
  EXPECT_GE(box.tested, box.accepted);
  EXPECT_GE(box.candidates, box.tested);
  EXPECT_GT(box.steps, 0);
  EXPECT_EQ(box.output, lib / "box" / "droid" / "grasps.npz");
  NpzReader npz(box.output);
  EXPECT_EQ(npz.keys(), std::vector<std::string>{"transforms"});
  NpyArray t = npz.Read("transforms");
  EXPECT_EQ(t.dtype, DType::kF2);
  EXPECT_EQ(t.shape, (std::vector<size_t>{4, 4, 4}));
  for (size_t g = 0; g < 4; ++g) {
    // Homogeneous rows, a rotation near orthonormal (float16), the TCP on the 4x5x7 cm box.
    EXPECT_EQ(t.AsDouble(g * 16 + 15), 1.0);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(t.AsDouble(g * 16 + 12 + c), 0.0);
    for (int c = 0; c < 3; ++c) {
      double norm = 0;
      for (int r = 0; r < 3; ++r) norm += std::pow(t.AsDouble(g * 16 + r * 4 + c), 2);
      EXPECT_NEAR(norm, 1.0, 5e-3);
    }
    for (int r = 0; r < 3; ++r) EXPECT_LT(std::abs(t.AsDouble(g * 16 + r * 4 + 3)), 0.06);
  }

  const ObjectReport& big = Find(report, "big");
  EXPECT_EQ(big.status, ObjectReport::Status::kFailed);
  EXPECT_THAT(big.reason, HasSubstr("too big for the gripper"));
  EXPECT_THAT(big.reason, HasSubstr("200 mm"));
  EXPECT_FALSE(fs::exists(lib / "big" / "droid"));
  const ObjectReport& ghost = Find(report, "ghost");
  EXPECT_EQ(ghost.status, ObjectReport::Status::kFailed);
  EXPECT_THAT(ghost.reason, HasSubstr("ghost.xml"));
  EXPECT_THAT(ghost.reason, HasSubstr("no collision geometry"));
  EXPECT_EQ(report.done(), 1u);
  EXPECT_EQ(report.failed(), 2u);

  // The index lists what exists, as index-grasps writes it.
  EXPECT_EQ(report.index, lib / "grasps_index.json");
  GraspIndex index = GraspIndex::Load(report.index);
  EXPECT_EQ(index.grasp_paths.at("droid").at("box"), "box/droid/grasps.npz");
  EXPECT_EQ(index.grasp_paths.at("droid").size(), 1u);
  IndexReport ignored;
  EXPECT_EQ(Slurp(report.index), BuildGraspIndex(lib, &ignored).Serialize());

  // --overwrite of an object that now gives no grasps removes its old file (the index would
  // still list it); without --overwrite the file is skipped, never touched.
  fs::create_directories(lib / "big" / "droid");
  fs::copy_file(box.output, lib / "big" / "droid" / "grasps.npz");
  o.uids = {"big"};
  GenerateReport kept = GenerateGrasps(o);
  EXPECT_EQ(kept.objects.at(0).status, ObjectReport::Status::kSkipped);
  EXPECT_TRUE(fs::exists(lib / "big" / "droid" / "grasps.npz"));
  o.overwrite = true;
  GenerateReport again = GenerateGrasps(o);
  EXPECT_EQ(again.objects.at(0).status, ObjectReport::Status::kFailed);
  EXPECT_THAT(again.objects.at(0).reason, HasSubstr("(removed the old grasps.npz)"));
  EXPECT_FALSE(fs::exists(lib / "big" / "droid" / "grasps.npz"));
  EXPECT_EQ(GraspIndex::Load(again.index).grasp_paths.at("droid").count("big"), 0u);
}

TEST(GraspgenGenerateTest, KeepsGraspsThatClearTheSupport) {
  // The L-bracket lies flat: many of its grasps reach under it. Asking for all kept grasps
  // to clear its support makes every written pose one a table allows; without the support
  // test the covering order keeps some that do not.
  TempDir tmp;
  fs::path lib = WriteLibrary(tmp.path());
  const robots::RobotSpec robot = robots::LoadRobotSpec("franka_droid");
  const fs::path asset = lib / "bracket" / "bracket.xml";
  const GraspScene scene(asset, robot, GraspScene::Mode::kRigid, SimParams{});
  auto clearing = [&](const fs::path& npz) {
    NpyArray t = NpzReader(npz).Read("transforms");
    size_t n = 0;
    for (size_t g = 0; g < t.shape[0]; ++g) {
      Mat4 pose;
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) pose(r, c) = t.AsDouble(g * 16 + r * 4 + c);
      }
      n += scene.SupportClear(pose);
    }
    return std::pair{n, t.shape[0]};
  };
  GenerateOptions o = Small(lib);
  o.uids = {"bracket"};
  o.max_grasps = 8;
  o.float64 = true;
  o.output_dir = tmp.path() / "all";
  o.min_support_fraction = 1.0;
  GenerateReport all = GenerateGrasps(o);
  ASSERT_EQ(all.done(), 1u) << all.objects.at(0).reason;
  const auto [clear_all, kept_all] = clearing(all.objects.at(0).output);
  EXPECT_EQ(kept_all, 8u);
  EXPECT_EQ(clear_all, 8u);

  o.output_dir = tmp.path() / "plain";
  o.sim.support_test = false;
  GenerateReport plain = GenerateGrasps(o);
  ASSERT_EQ(plain.done(), 1u) << plain.objects.at(0).reason;
  const auto [clear_plain, kept_plain] = clearing(plain.objects.at(0).output);
  EXPECT_EQ(kept_plain, 8u);
  EXPECT_LT(clear_plain, 8u);
  EXPECT_GT(all.objects.at(0).tested, plain.objects.at(0).tested);
}

TEST(GraspgenGenerateTest, SameBytesWhateverThreadsAndResume) {
  TempDir tmp;
  fs::path lib = WriteLibrary(tmp.path());
  GenerateOptions o = Small(lib);
  o.uids = {"bracket"};
  o.output_dir = tmp / "one";
  GenerateReport one = GenerateGrasps(o);
  ASSERT_EQ(one.done(), 1u) << one.objects[0].reason;
  o.threads = 2;
  o.output_dir = tmp / "two";
  GenerateGrasps(o);
  std::string bytes = Slurp(tmp / "one" / "bracket" / "droid" / "grasps.npz");
  EXPECT_EQ(bytes, Slurp(tmp / "two" / "bracket" / "droid" / "grasps.npz"));

  // Resume: the existing file is kept; --overwrite regenerates the same bytes; f8 on request.
  GenerateReport again = GenerateGrasps(o);
  EXPECT_EQ(again.skipped(), 1u);
  EXPECT_EQ(again.objects[0].reason, "exists");
  o.overwrite = true;
  o.float64 = true;
  GenerateReport f8 = GenerateGrasps(o);
  EXPECT_EQ(f8.done(), 1u);
  NpyArray a = NpzReader(tmp / "one" / "bracket" / "droid" / "grasps.npz").Read("transforms");
  NpyArray b = NpzReader(tmp / "two" / "bracket" / "droid" / "grasps.npz").Read("transforms");
  EXPECT_EQ(b.dtype, DType::kF8);
  ASSERT_EQ(a.num_elements(), b.num_elements());
  for (size_t i = 0; i < a.num_elements(); ++i) {
    EXPECT_EQ(a.AsDouble(i), HalfToDouble(DoubleToHalf(b.AsDouble(i)))) << i;
  }
  // Another seed, other grasps.
  o.seed = 8;
  o.float64 = false;
  GenerateGrasps(o);
  EXPECT_NE(bytes, Slurp(tmp / "two" / "bracket" / "droid" / "grasps.npz"));
}

TEST(GraspgenGenerateTest, BadOptionsAndUnknownUid) {
  TempDir tmp;
  fs::path lib = WriteLibrary(tmp.path());
  GenerateOptions o = Small(lib);
  o.uids = {"box", "nope"};
  mlspaces::testing::ExpectError([&] { GenerateGrasps(o); }, {"nope", "unknown UID"});
  EXPECT_FALSE(fs::exists(lib / "box" / "droid"));  // checked before any work
  o.uids = {};
  o.robot = "ur5";
  EXPECT_THROW(GenerateGrasps(o), UsageError);
  try {
    RobotForGraspLibrary("ur5");
  } catch (const UsageError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no robot 'ur5'"));
    EXPECT_THAT(e.what(), HasSubstr("droid (franka_droid), xarm7"));
  }
  o.robot = "droid";
  o.library_dir = tmp / "missing";
  mlspaces::testing::ExpectError([&] { GenerateGrasps(o); }, {"missing", "not found"});
}

TEST(GraspgenGenerateTest, JointGraspsForTheCabinet) {
  TempDir tmp;
  fs::path lib = tmp / "objects";
  fs::copy(fs::path(MLSPACES_EXAMPLES_DIR) / "objects", lib, fs::copy_options::recursive);
  for (const auto& entry : fs::recursive_directory_iterator(lib)) {
    if (entry.path().filename() == "grasps_index.json" ||
        entry.path().filename().string().starts_with("joint_grasps_")) {
      fs::remove(entry.path());
    }
  }
  testing::WriteBoxAsset(lib);
  WriteText(lib / "box" / "box.json", mlspaces::testing::MinimalMetadata("box"));
  fs::remove(lib / "assets_index.json");  // scan the folder instead
  GenerateOptions o = Small(lib);
  o.joints = true;
  o.max_grasps = 2;
  GenerateReport report = GenerateGrasps(o);
  size_t joints = 0;
  for (const auto& r : report.objects) {
    if (r.uid == "box" || r.uid == "tray" || r.uid == "bowl") {  // tray, bowl: receptacles
      EXPECT_EQ(r.status, ObjectReport::Status::kSkipped);
      EXPECT_EQ(r.reason, "no hinge or slide joint");
      continue;
    }
    ++joints;
    ASSERT_EQ(r.status, ObjectReport::Status::kDone) << r.joint << ": " << r.reason;
    EXPECT_EQ(r.output.filename(), "joint_grasps_" + r.joint + ".npz");
    EXPECT_EQ(NpzReader(r.output).ReadHeader("transforms").shape, (std::vector<size_t>{2, 4, 4}));
  }
  EXPECT_EQ(joints, 2u);  // the drawer and the door
  GraspIndex index = GraspIndex::Load(report.index);
  ASSERT_EQ(index.articulated_grasp_paths.at("droid").size(), 1u);
  EXPECT_EQ(index.articulated_grasp_paths.at("droid").begin()->second.size(), 2u);
}

TEST(GraspgenGenerateTest, CommandLine) {
  TempDir tmp;
  fs::path lib = WriteLibrary(tmp.path());
  auto r = RunCli({"generate-grasps", lib.string(), "--uid", "box", "ghost", "--max-grasps", "3",
                   "-j", "1", "--seed", "3", "-q"});
  EXPECT_EQ(r.exit_code, 1) << r.err;  // ghost failed, box done
  EXPECT_THAT(r.err, HasSubstr("ghost: failed: "));
  EXPECT_THAT(r.err, HasSubstr("no collision geometry"));
  EXPECT_THAT(r.out, HasSubstr("1 objects done, 0 skipped (existing), 1 failed"));
  EXPECT_THAT(r.out, HasSubstr("grasps_index.json"));
  EXPECT_TRUE(fs::exists(lib / "box" / "droid" / "grasps.npz"));

  r = RunCli({"generate-grasps", lib.string(), "--uid", "box", "--max-grasps", "3", "--seed", "3",
              "--dtype", "f8"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("box: skipped (exists)"));

  r = RunCli({"generate-grasps", lib.string(), "--max-grasps", "0"});
  EXPECT_EQ(r.exit_code, 2);
  r = RunCli({"generate-grasps", lib.string(), "--dtype", "f4"});
  EXPECT_EQ(r.exit_code, 2);
  r = RunCli({"generate-grasps", lib.string(), "--min-quality", "1.5"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("min_quality must be in [0, 1]"));
  r = RunCli({"generate-grasps", lib.string(), "--uid", "nope"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("nope"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// A user's robot on $MLSPACES_ROBOT_PATH (the xArm7's files under another name) gets grasps
// by its name, the same as the xArm7's for the same seed: the gripper is all that counts.
TEST(GraspgenGenerateTest, AUsersRobotGetsGraspsByName) {
  TempDir tmp;
  fs::path lib = WriteLibrary(tmp.path());
  const fs::path mine = tmp / "robots" / "my_arm";
  fs::create_directories(mine);
  const fs::path xarm7 = fs::path(MLSPACES_SOURCE_DIR) / "assets" / "robots" / "xarm7";
  fs::copy_file(xarm7 / "xarm7.xml", mine / "xarm7.xml");
  std::string yaml = Slurp(xarm7 / "robot.yaml");
  yaml.replace(yaml.find("name: xarm7"), 11, "name: my_arm");
  WriteText(mine / "robot.yaml", yaml);
  ::setenv("MLSPACES_ROBOT_PATH", (tmp / "robots").c_str(), 1);
  GenerateOptions o = Small(lib);
  o.uids = {"box"};
  o.robot = "my_arm";
  const GenerateReport mine_report = GenerateGrasps(o);
  o.robot = "xarm7";
  const GenerateReport xarm7_report = GenerateGrasps(o);
  ::unsetenv("MLSPACES_ROBOT_PATH");
  ASSERT_EQ(mine_report.objects.at(0).status, ObjectReport::Status::kDone)
      << mine_report.objects.at(0).reason;
  EXPECT_EQ(mine_report.objects.at(0).output, lib / "box" / "my_arm" / "grasps.npz");
  EXPECT_EQ(Slurp(mine_report.objects.at(0).output), Slurp(xarm7_report.objects.at(0).output));
  EXPECT_THROW(RobotForGraspLibrary("my_arm"), UsageError);  // off the path again
}

// Grasps for another robot's gripper: --robot xarm7 tests the xArm7's own gripper and writes
// the xarm7 folder; the xArm7 then picks the tutorial's block with them (and only them).
TEST(GraspgenGenerateTest, Xarm7GraspsDriveXarm7Episodes) {
  TempDir tmp;
  const fs::path examples(MLSPACES_EXAMPLES_DIR);
  EXPECT_EQ(RobotForGraspLibrary("droid"), "franka_droid");
  EXPECT_EQ(RobotForGraspLibrary("xarm7"), "xarm7");
  const fs::path grasps = tmp / "xarm7_grasps";
  auto r = RunCli({"generate-grasps", (examples / "custom_assets" / "asset_library").string(),
                   "--robot", "xarm7", "--max-grasps", "20", "-j", "1", "--seed", "1", "-q",
                   "--output", grasps.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path file = grasps / "red_block" / "xarm7" / "grasps.npz";
  ASSERT_TRUE(fs::exists(file));
  EXPECT_EQ(NpzReader(file).Read("transforms").shape, (std::vector<size_t>{20, 4, 4}));
  EXPECT_EQ(GraspIndex::Load(grasps / "grasps_index.json").grasp_paths.at("xarm7").at("red_block"),
            "red_block/xarm7/grasps.npz");

  // The tutorial with the xArm7 and only the new library (its paths made absolute).
  std::string config = Slurp(examples / "custom_assets" / "datagen.yaml");
  const auto replace = [&](const std::string& from, const std::string& to) {
    ASSERT_NE(config.find(from), std::string::npos) << from;
    config.replace(config.find(from), from.size(), to);
  };
  const fs::path tutorial = examples / "custom_assets";
  replace("{name: custom_grasps, path: asset_library, asset_library: custom_assets}",
          "{name: xarm7_grasps, path: " + grasps.string() + ", asset_library: custom_assets}");
  replace("path: asset_library}", "path: " + (tutorial / "asset_library").string() + "}");
  replace("[scene.xml]", "[" + (tutorial / "scene.xml").string() + "]");
  const fs::path yaml = tmp / "datagen.yaml";
  WriteText(yaml, config);
  r = RunCli({"datagen", yaml.string(), "-q", "--seed", "2", "--episodes", "3", "--output",
              (tmp / "run").string(), "--set", "robot_config.name=xarm7", "--set",
              "task_config.enable_rendering=false"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("100.0% of episodes (3/3)"));
  EXPECT_THAT(Slurp(tmp / "run" / "journal.jsonl"), HasSubstr("\"num_grasps\":20,"));  // ours
}

}  // namespace
}  // namespace mlspaces::graspgen
