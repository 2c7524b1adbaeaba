// Pick-and-place tasks (docs/tasks.md): the success rule on real MuJoCo states, config
// errors, and real runs of the examples (examples/pick_and_place): episodes succeed, validate,
// record the receptacle, and are the same bytes with 1 or 2 workers, shards and after a resume.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "datagen/tasks/task_run_checks.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/dataset_validate.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/datagen/tasks/pick_and_place/sampler.h"
#include "mlspaces/datagen/tasks/pick_and_place/success.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "pick_and_place";

ExperimentConfig Example(const std::string& yaml, const fs::path& output, int64_t episodes,
                         uint64_t seed) {
  ExperimentConfig c = LoadConfigFile(kExample / yaml, ConfigRegistry::WithBuiltins());
  c.output_dir = output;
  c.seed = seed;
  c.task_sampler_config.samples_per_house = episodes;
  c.task_config.enable_rendering = false;
  return c;
}

// A tray on the floor and a block: resting in it (supported), lifted away (not), a tray
// knocked over (tilted: not), the robot stand-in touching the block (not).
TEST(PickAndPlaceSuccessTest, SupportTiltAndRobotContact) {
  const std::string xml = R"(<mujoco><worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="tray" pos="0 0 0"><freejoint/>
      <geom type="box" size="0.15 0.11 0.002" pos="0 0 0.002" mass="0.4"/>
    </body>
    <body name="block" pos="0 0 0.03"><freejoint/>
      <geom type="box" size="0.025 0.025 0.025" mass="0.1"/>
    </body>
    <body name="robot_0/finger" mocap="true" pos="0.5 0 0.1"><geom type="box" size="0.01 0.01 0.01"/></body>
  </worldbody></mujoco>)";
  char error[1000] = "";
  mjSpec* spec = mj_parseXMLString(xml.c_str(), nullptr, error, sizeof error);
  ASSERT_NE(spec, nullptr) << error;
  mjModel* m = mj_compile(spec, nullptr);
  ASSERT_NE(m, nullptr);
  mjData* d = mj_makeData(m);
  const int tray = mj_name2id(m, mjOBJ_BODY, "tray"), block = mj_name2id(m, mjOBJ_BODY, "block");
  for (int i = 0; i < 300; ++i) mj_step(m, d);  // settle
  TaskConfig cfg;
  PlaceJudge judge(m, block, tray, Pose{}, TaskType::kPickAndPlace, cfg, "robot_0/");
  PlaceVerdict v = judge.Evaluate(d);
  EXPECT_TRUE(v.supported_by_receptacle);
  EXPECT_FALSE(v.robot_contact);
  EXPECT_TRUE(v.success);
  EXPECT_GT(v.reward, std::exp(-0.05));
  EXPECT_EQ(v.Info(TaskType::kPickAndPlace, 3)["episode_step"], 3);

  // Lifted 20 cm: no support (the carry-forward memory holds the pose in the tray, not this).
  const int bq = m->jnt_qposadr[m->body_jntadr[block]];
  d->qpos[bq + 2] += 0.2;
  mj_forward(m, d);
  v = judge.Evaluate(d);
  EXPECT_FALSE(v.supported_by_receptacle);
  EXPECT_FALSE(v.success);
  d->qpos[bq + 2] -= 0.2;

  // The robot touching the block.
  d->mocap_pos[0] = 0;  // the robot stand-in (a mocap body) onto the block's top face
  d->mocap_pos[2] = 0.06;
  mj_forward(m, d);
  v = judge.Evaluate(d);
  EXPECT_TRUE(v.robot_contact);
  EXPECT_FALSE(v.success);
  d->mocap_pos[0] = 0.5;
  d->mocap_pos[2] = 0.1;

  // The tray tilted 60 degrees about x: knocked over.
  const int tq = m->jnt_qposadr[m->body_jntadr[tray]];
  d->qpos[tq + 3] = std::cos(M_PI / 6);
  d->qpos[tq + 4] = std::sin(M_PI / 6);
  mj_forward(m, d);
  v = judge.Evaluate(d);
  EXPECT_NEAR(v.receptacle_tilt_displacement, M_PI / 3, 1e-9);
  EXPECT_FALSE(v.success);
  mj_deleteData(d);
  mj_deleteModel(m);
  mj_deleteSpec(spec);

  EXPECT_EQ(PlaceDescription(TaskType::kPickAndPlace, "block", "tray", ""),
            "Pick up the block and place it in or on the tray");
  EXPECT_EQ(PlaceDescription(TaskType::kPickAndPlaceNextTo, "block", "bowl", ""),
            "Pick up the block and place it next to the bowl");
  EXPECT_EQ(PlaceDescription(TaskType::kPickAndPlaceColor, "block", "bowl", "light_blue"),
            "Pick up the block and place it in or on the light blue bowl");
  EXPECT_EQ(PlaceColors().size(), 13u);
}

TEST(PickAndPlaceConfigTest, BadFieldsGetOneLineNamingFileAndField) {
  testing::TempDir dir;
  std::string base = testing::Slurp(kExample / "datagen.yaml");
  for (const auto& [rel, abs] :
       {std::pair<std::string, fs::path>{"[scene.xml]", kExample / "scene.xml"},
        {"path: ../objects", kExample / "../objects"},
        {"path: ../custom_assets/asset_library", kExample / "../custom_assets/asset_library"}}) {
    for (size_t at = base.find(rel); at != std::string::npos; at = base.find(rel, at + 1)) {
      const std::string to = rel[0] == '[' ? "[" + abs.string() + "]" : "path: " + abs.string();
      base.replace(at, rel.size(), to);
    }
  }
  auto load = [&](const std::string& text) {
    testing::WriteText(dir / "bad.yaml", text);
    ExperimentConfig c = LoadConfigFile(dir / "bad.yaml", ConfigRegistry::WithBuiltins());
    Validate(c, dir / "bad.yaml");
    return c;
  };
  EXPECT_NO_THROW(load(base));
  auto with = [&](const std::string& from, const std::string& to) {
    std::string text = base;
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    return text;
  };
  const std::string file = (dir / "bad.yaml").string();
  testing::ExpectError(
      [&] {
        load(with("task_sampler_class: PickAndPlaceTaskSampler",
                  "task_sampler_class: block_pickup"));
      },
      {file, "task_sampler_config.task_sampler_class", "PickAndPlaceTaskSampler"});
  testing::ExpectError(
      [&] {
        load(
            with("receptacle_supported_weight_frac: 0.5", "receptacle_supported_weight_frac: 1.5"));
      },
      {file, "task_config.receptacle_supported_weight_frac"});
  testing::ExpectError(
      [&] {
        load(with("max_object_to_receptacle_dist: 0.5", "max_object_to_receptacle_dist: 0.1"));
      },
      {file, "task_sampler_config.max_object_to_receptacle_dist"});
  testing::ExpectError([&] { load(with("task_type: pick_and_place", "task_type: pick_and_plac")); },
                       {file, "task_type"});
}

// An episode of each variant, seed fixed: it succeeds, validates, and records the target.
TEST(PickAndPlaceRunTest, EpisodesOfEachVariantSucceedAndValidate) {
  testing::TempDir dir;
  for (const std::string yaml : {"datagen.yaml", "datagen_next_to.yaml", "datagen_color.yaml"}) {
    const RunReport r =
        RunDatagen(Example(yaml, dir / yaml, 1, 1), TaskSamplerRegistry::WithBuiltins());
    EXPECT_EQ(r.episodes_kept, 1) << yaml;
    EXPECT_EQ(r.summary.count(Outcome::kSuccess), 1) << yaml;
    const DatasetReport v = ValidateDataset(dir / yaml);
    EXPECT_TRUE(v.ok()) << yaml;
    const std::string journal = testing::Slurp(dir / yaml / "journal.jsonl");
    EXPECT_THAT(journal, HasSubstr("\"place_receptacle\"")) << yaml;
  }
}

// episodes_per_receptacle (the original's rotation): the same receptacle for that many
// episodes in a row, then the next, wrapping; from the episode number, so 2 workers agree.
TEST(PickAndPlaceRunTest, EpisodesPerReceptacleRotatesTheReceptacle) {
  testing::TempDir dir;
  for (const int64_t per : {2, 1}) {
    for (const int workers : {1, 2}) {
      const std::string name = "per" + std::to_string(per) + "_w" + std::to_string(workers);
      ExperimentConfig c = Example("datagen.yaml", dir / name, 5, 1);
      c.task_sampler_config.episodes_per_receptacle = per;
      c.task_horizon = 2;  // the receptacle is chosen at sampling: no need to run the plan
      c.filter_for_successful_trajectories = false;
      RunOptions options;
      options.workers = workers;
      RunDatagen(c, TaskSamplerRegistry::WithBuiltins(), options);
      const std::string prefix = "place_receptacle/";
      std::map<int64_t, std::string> by_episode;  // episode -> the receptacle's uid stem
      std::istringstream lines(testing::Slurp(dir / name / "journal.jsonl"));
      for (std::string line; std::getline(lines, line);) {
        const Json j = ParseJson(line, "journal.jsonl");
        const std::string r = j.at("extra").at("place_receptacle").get<std::string>();
        by_episode[j.at("episode").get<int64_t>()] = r.substr(0, r.find('_', prefix.size()));
      }
      ASSERT_EQ(by_episode.size(), 5u) << name;
      // Two receptacle assets (tray, bowl): stems place_receptacle/0 and place_receptacle/1.
      for (int64_t e = 0; e < 5; ++e) {
        EXPECT_EQ(by_episode[e], by_episode[e % (2 * per)]) << name << " episode " << e;
        if (e + per < 5) {
          EXPECT_NE(by_episode[e], by_episode[e + per]) << name << " episode " << e;
        }
        if (per == 2 && e % 2 == 1) {
          EXPECT_EQ(by_episode[e], by_episode[e - 1]) << name;
        }
      }
    }
  }
}

// The unused receptacles are parked 35 m up, as the original parks them, but the scene keeps
// its own scale: the original's parking made mjModel::stat.extent 35 m, and its cameras'
// near plane (vis.map.znear x extent) 0.35 m, which cut the gripper out of the wrist camera.
TEST(PickAndPlaceSceneTest, ParkedReceptaclesLeaveTheScenesScale) {
  testing::TempDir dir;
  const ExperimentConfig c = Example("datagen.yaml", dir / "out", 1, 1);
  const std::unique_ptr<TaskSampler> sampler = TaskSamplerRegistry::WithBuiltins().Create(c, 1);
  Env env = CreateSceneEnv(c, *sampler, c.task_sampler_config.scene_xml_paths.at(0), "house_0");
  const mjModel* m = env.model();
  mj_forward(m, env.data());
  int parked = 0;
  for (int b = 1; b < m->nbody; ++b) {
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    if (name != nullptr && std::string(name).starts_with("place_receptacle/") &&
        env.data()->xpos[3 * b + 2] > 34) {
      ++parked;
    }
  }
  EXPECT_GE(parked, 2) << "the staging floor and the receptacles";
  std::printf("stat.extent %.3f m, the cameras' near plane %.4f m\n", m->stat.extent,
              m->vis.map.znear * m->stat.extent);
  EXPECT_LT(m->stat.extent, 4);
  EXPECT_LT(m->stat.center[2], 2);
  EXPECT_LT(m->vis.map.znear * m->stat.extent, 0.04);
}

TEST(PickAndPlaceRunTest, WorkersShardsAndResumeGiveTheSameBytes) {
  testing::TempDir dir;
  auto config = [&](const std::string& name) {
    ExperimentConfig c = Example("datagen.yaml", dir / name, 2, 4);
    c.task_sampler_config.episodes_per_batch = 1;
    return c;
  };
  testing::ExpectWorkersShardsAndResumeGiveTheSameBytes(config, dir.path(), 2);
}

}  // namespace
}  // namespace mlspaces::datagen
