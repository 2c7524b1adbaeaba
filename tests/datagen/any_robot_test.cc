// Datagen with robots other than franka_droid (docs/robots.md): the tutorial config with only
// the robot changed, through workers, resume, shards and merge, cameras and validate-dataset;
// the robot in each episode's provenance; the three base kinds; bad robot descriptions.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/datagen/config.h"
#include "mlspaces/robots/robot_spec.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kYaml = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "datagen.yaml";
const fs::path kFranka = fs::path(MLSPACES_SOURCE_DIR) / "assets/robots/franka_droid";

// The tutorial with only the robot changed; cheap cameras (64 x 48, no shadows/reflections).
std::vector<std::string> Tutorial(const std::string& robot, const fs::path& out,
                                  std::vector<std::string> extra = {}) {
  std::vector<std::string> args = {"datagen",
                                   kYaml.string(),
                                   "-q",
                                   "--seed",
                                   "3",
                                   "--episodes",
                                   "2",
                                   "--output",
                                   out.string(),
                                   "--set",
                                   "robot_config.name=" + robot,
                                   "--set",
                                   "task_sampler_config.episodes_per_batch=1",
                                   "--set",
                                   "camera_config.img_resolution=[64, 48]",
                                   "--set",
                                   "camera_config.shadows=false",
                                   "--set",
                                   "camera_config.reflections=false"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

// Every trajectory's provenance robot as "name hash" lines, and the articulation groups.
std::string RobotsOf(const fs::path& dir, const fs::path& run) {
  std::string out;
  testing::RunPython(dir, R"(
import glob, json, sys, h5py
for f in sorted(glob.glob(sys.argv[1] + "/**/*.h5", recursive=True)):
    with h5py.File(f) as h:
        for k in sorted(h):
            if k.startswith("traj_"):
                r = json.loads(h[k].attrs["provenance"])["robot"]
                print(r["name"], r["description_hash"], *sorted(h[k]["env_states/articulations"]))
)",
                     testing::ShellQuote(run.string()), &out);
  return out;
}

TEST(AnyRobotTest, TheTutorialWithTheXarm7ThroughWorkersResumeShardsAndCameras) {
  testing::TempDir dir;
  const std::string hash = robots::LoadRobotDescription(robots::FindRobot("xarm7")).hash;
  const fs::path run = dir / "run";
  testing::CliResult r = testing::RunCli(Tutorial("xarm7", run, {"--workers", "2"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(RobotsOf(dir.path(), run), "xarm7 " + hash + " xarm7\nxarm7 " + hash + " xarm7\n");
  size_t videos = 0;
  for (const auto& e : fs::recursive_directory_iterator(run))
    videos += e.path().extension() == ".mp4";
  EXPECT_EQ(videos, 4u);  // wrist and exo camera per episode
  r = testing::RunCli({"validate-dataset", run.string()});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  // Resuming a finished run redoes nothing and keeps the bytes.
  const std::string before = testing::Slurp(run / "journal.jsonl");
  r = testing::RunCli(Tutorial("xarm7", run, {"--resume"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(testing::Slurp(run / "journal.jsonl"), before);
  // Shards and merge.
  for (const char* shard : {"0/2", "1/2"}) {
    r = testing::RunCli(Tutorial("xarm7", dir / (std::string("s") + shard[0]), {"--shard", shard}));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  r = testing::RunCli(
      {"merge", (dir / "m").string(), (dir / "s0").string(), (dir / "s1").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = testing::RunCli({"validate-dataset", (dir / "m").string()});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(RobotsOf(dir.path(), dir / "m"), HasSubstr("xarm7 " + hash));
}

// franka_droid became a robot.yaml without a change to what its episodes record: the tutorial's
// first episode (seed 0) digests to the value the engine before robots-as-data (commit 270ba44)
// wrote. Every dataset of traj_0 but the scene JSON (it holds the config hash, which the new
// robot_config keys change) and the camera datasets (off here) goes in, name, dtype, shape and
// bytes. A deliberate change to the planner or the physics changes this value: update it then.
TEST(AnyRobotTest, FrankaDroidAsDataRecordsTheBytesOfTheEngineBefore) {
  testing::TempDir dir;
  const fs::path run = dir / "run";
  const testing::CliResult r =
      testing::RunCli({"datagen", kYaml.string(), "-q", "--seed", "0", "--episodes", "1",
                       "--output", run.string(), "--set", "task_config.enable_rendering=false"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string digest;
  testing::RunPython(dir.path(), R"(
import hashlib, sys, h5py, numpy as np
h = hashlib.sha256()
with h5py.File(sys.argv[1] + "/house_0/trajectories_batch_1_of_1.h5") as f:
    t = f["traj_0"]
    names = []
    t.visit(lambda n: names.append(n) if isinstance(t[n], h5py.Dataset)
            and not n.startswith(("obs_scene", "obs/sensor")) else None)
    for n in sorted(names):
        a = np.asarray(t[n][()])
        h.update(n.encode() + str(a.dtype).encode() + str(a.shape).encode() + a.tobytes())
print(h.hexdigest(), len(names))
)",
                     testing::ShellQuote(run.string()), &digest);
  EXPECT_EQ(digest, "8e8f6d89b94e06c55cdff584099ed6b82ff2004bd11f7905c4b790f1601df487 23\n");
}

// franka_droid's folder copied to `dir` with robot.yaml's base section replaced.
fs::path FrankaWithBase(const fs::path& dir, const std::string& base) {
  fs::create_directories(dir);
  fs::copy_file(kFranka / "franka_droid.xml", dir / "franka_droid.xml");
  std::string text = testing::Slurp(kFranka / "robot.yaml");
  const std::string old = "  kind: mocap\n  body: base";
  text.replace(text.find(old), old.size(), base);
  testing::WriteText(dir / "robot.yaml", text);
  return dir;
}

TEST(AnyRobotTest, TheDataHashFollowsTheRobotsFiles) {
  testing::TempDir dir;
  const fs::path robot = FrankaWithBase(dir / "robot", "  kind: mocap\n  body: base");
  ExperimentConfig config;
  config.robot_config.name = robot.string();
  const std::string before = DataConfigHashHex(config);
  EXPECT_EQ(DataConfigHashHex(config), before);
  std::ofstream(robot / "franka_droid.xml", std::ios::app) << "<!-- a changed model -->\n";
  EXPECT_NE(DataConfigHashHex(config), before);
  // A robot found by name counts by its files as well: another robot, another hash.
  config.robot_config.name = "xarm7";
  EXPECT_NE(DataConfigHashHex(config), before);
}

TEST(AnyRobotTest, BaseKindsAndBadDescriptionsByPath) {
  testing::TempDir dir;
  // A holonomic base: placed through its x / y / yaw joints.
  const fs::path holo = FrankaWithBase(dir / "holo", "  kind: holonomic");
  testing::CliResult r = testing::RunCli(Tutorial(
      holo.string(), dir / "holo_run",
      {"--set", "camera_config.cameras=[]", "--set", "task_config.enable_rendering=false"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(testing::Slurp(dir / "holo_run" / "summary.txt"), HasSubstr("success rate: 100.0%"));
  // A fixed base cannot be placed by the pick sampler: one line naming robot.yaml's base.kind.
  const fs::path fixed = FrankaWithBase(dir / "fixed", "  kind: fixed");
  r = testing::RunCli(Tutorial(fixed.string(), dir / "fixed_run"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr((fixed / "robot.yaml").string() + ": base.kind: the robot's base"));
  // A bad description: one line naming the file and the field, before any episode.
  const fs::path bad = FrankaWithBase(dir / "bad", "  kind: mocap\n  body: base_link");
  r = testing::RunCli(Tutorial(bad.string(), dir / "bad_run"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr((bad / "robot.yaml").string() +
                               ": base.body: body 'base_link' is not in franka_droid.xml"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  r = testing::RunCli(Tutorial("xarm8", dir / "unknown_run"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("robot_config.name: unknown robot 'xarm8'"));
  EXPECT_THAT(r.err, HasSubstr("did you mean 'xarm7'"));
}

}  // namespace
}  // namespace mlspaces::datagen
