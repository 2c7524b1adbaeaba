#include "mlspaces/datagen/config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

const fs::path kExampleDir = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";
const fs::path kExample = kExampleDir / "datagen.yaml";
const fs::path kTestdata = MLSPACES_TESTDATA_DIR;

class ConfigTest : public ::testing::Test {
 protected:
  /// Loads `text` written to cfg.yaml in a temp folder.
  ExperimentConfig Load(const std::string& text) {
    WriteText(yaml_, text);
    return LoadConfigFile(yaml_, registry_);
  }

  /// The Error of loading `text`, checking it names the file; returns (what, field).
  std::pair<std::string, std::string> LoadError(const std::string& text) {
    WriteText(yaml_, text);
    try {
      LoadConfigFile(yaml_, registry_);
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), yaml_.string());
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      return {e.what(), e.field()};
    }
    return {"<no error>", ""};
  }

  /// The UsageError message of applying `assignment` to the defaults.
  std::string SetError(const std::string& assignment) {
    ExperimentConfig config;
    try {
      ApplyOverride(config, assignment, tmp_.path());
    } catch (const UsageError& e) {
      return e.what();
    } catch (const Error& e) {
      return std::string("<not a UsageError> ") + e.what();
    }
    return "<no error>";
  }

  TempDir tmp_;
  fs::path yaml_ = tmp_ / "cfg.yaml";
  ConfigRegistry registry_ = ConfigRegistry::WithBuiltins();
};

// ---------------------------------------------------------------------------------------
// The example and the defaults.

TEST_F(ConfigTest, ExampleLoadsWithTheTutorialValues) {
  const ExperimentConfig c = LoadConfigFile(kExample, registry_);
  Validate(c, kExample);
  EXPECT_EQ(c.scene_dataset, SceneDataset::kUser);
  EXPECT_EQ(c.num_workers, 1);
  EXPECT_EQ(c.tag, "tutorial_franka_pick_custom_assets");
  EXPECT_EQ(c.output_dir, kExampleDir / "experiment_output");
  EXPECT_FALSE(c.robot_config.base_size.has_value());
  EXPECT_EQ(c.robot_config.name, "franka_droid");
  const TaskSamplerConfig& s = c.task_sampler_config;
  EXPECT_EQ(s.task_sampler_class, "block_pickup");
  EXPECT_EQ(s.dataset_name, SceneDataset::kUser);
  EXPECT_THAT(s.scene_xml_paths, ElementsAre(kExampleDir / "scene.xml"));
  EXPECT_TRUE(fs::is_regular_file(s.scene_xml_paths[0]));
  EXPECT_FALSE(s.house_inds.has_value());
  EXPECT_EQ(s.samples_per_house, 2);
  EXPECT_EQ(s.house_variant, "base");
  EXPECT_EQ(s.robot_base_noise.x, 0.1);
  EXPECT_EQ(s.robot_base_noise.yaw_deg, 30.0);
  EXPECT_EQ(s.object_noise.y, 0.05);
  EXPECT_EQ(s.object_noise.yaw_deg, 45.0);
  EXPECT_EQ(s.goal_offset_z, 0.05);
  ASSERT_EQ(c.libraries.asset_libraries.size(), 1u);
  EXPECT_EQ(c.libraries.asset_libraries[0].name, "custom_assets");
  EXPECT_EQ(c.libraries.asset_libraries[0].dir, kExampleDir / "asset_library");
  EXPECT_EQ(c.libraries.asset_libraries[0].origin_file, kExample);
  EXPECT_EQ(c.libraries.asset_libraries[0].origin_line, "line 11");
  ASSERT_EQ(c.libraries.grasp_libraries.size(), 1u);
  EXPECT_EQ(c.libraries.grasp_libraries[0].name, "custom_grasps");
  EXPECT_EQ(c.libraries.grasp_libraries[0].asset_library, "custom_assets");
  EXPECT_TRUE(fs::is_directory(c.libraries.grasp_libraries[0].dir));
  ASSERT_EQ(c.camera_config.cameras.size(), 2u);
  EXPECT_EQ(c.camera_config.cameras[1].type, CameraType::kRobotMounted);
}

TEST_F(ConfigTest, ExampleEqualsTheRegisteredTutorialConfig) {
  ExperimentConfig registered = registry_.Make("CustomAssetsDataGenConfig");
  ResolvePaths(registered, kExampleDir);
  const ExperimentConfig loaded = LoadConfigFile(kExample, registry_);
  EXPECT_EQ(DumpConfig(loaded), DumpConfig(registered));
  EXPECT_EQ(ConfigHash(loaded), ConfigHash(registered));
}

TEST_F(ConfigTest, EveryDefaultAsInTheSpec) {
  // The golden file lists every field with its default (reviewed against the spec, 1.1-1.6).
  const ExperimentConfig c;
  EXPECT_EQ(DumpConfig(c), Slurp(kTestdata / "config_defaults.yaml"));
  // A few by hand, so a wrong golden file cannot hide them.
  EXPECT_EQ(c.num_envs, 1);
  EXPECT_EQ(c.policy_dt_ms, 66.0);
  EXPECT_EQ(c.ctrl_dt_ms, 2.0);
  EXPECT_EQ(c.task_horizon, 500);
  EXPECT_FALSE(c.seed.has_value());
  EXPECT_FALSE(c.end_on_success);
  EXPECT_TRUE(c.filter_for_successful_trajectories);
  EXPECT_NEAR(c.fps(), 15.1515, 1e-4);
  EXPECT_EQ(c.task_config.succ_pos_threshold, 0.01);
  EXPECT_EQ(c.task_config.action_dtype, ActionDtype::kFloat32);
  EXPECT_EQ(c.task_sampler_config.episodes_per_batch, 4);
  EXPECT_EQ(c.task_sampler_config.max_total_attempts_multiplier, 6);
  EXPECT_EQ(c.task_sampler_config.max_allowed_sequential_irrecoverable_failures, 5);
  EXPECT_FALSE(c.task_sampler_config.max_tasks.has_value());
  EXPECT_EQ(c.robot_config.robot_namespace, "robot_0/");
  EXPECT_EQ(c.robot_config.base_size, (std::array<double, 3>{0.5, 0.5, 0.58}));
  // Empty: the robot's own home pose and noise (robot.yaml), see RobotSpecFromConfig.
  EXPECT_TRUE(c.robot_config.init_qpos.arm.empty());
  EXPECT_TRUE(c.robot_config.init_qpos_noise_range.arm.empty());
  EXPECT_TRUE(c.robot_config.action_noise_config.enabled);
  EXPECT_EQ(c.camera_config.img_resolution, (std::array<int64_t, 2>{640, 368}));
  EXPECT_EQ(c.camera_config.cameras[0].mjcf_name, "gripper/wrist_camera");
  EXPECT_EQ(c.camera_config.cameras[0].fov, 56.74);
  EXPECT_EQ(c.policy_config.pregrasp_z_offset, 0.04);
  EXPECT_EQ(c.policy_config.postgrasp_z_offset, 0.08);
  EXPECT_EQ(c.policy_config.speed_slow, 0.08);
  EXPECT_EQ(c.policy_config.grasp_cost_weights.com_dist, 8.0);
  EXPECT_EQ(c.policy_config.grasp_collision_max_grasps, 512);
}

TEST_F(ConfigTest, EmptyFileGivesTheDefaults) {
  EXPECT_EQ(DumpConfig(Load("")), DumpConfig(ExperimentConfig{}));
  EXPECT_EQ(DumpConfig(Load("# only a comment\n")), DumpConfig(ExperimentConfig{}));
}

TEST_F(ConfigTest, KeysMergeIntoTheDefaults) {
  const ExperimentConfig c = Load(
      "task_sampler_config:\n  robot_base_noise: {yaw_deg: 10}\n"
      "policy_config:\n  grasp_libraries: [custom_grasps/droid]\n"
      "task_config:\n  added_objects: {mug: objs/mug.xml}\n");
  EXPECT_EQ(c.task_sampler_config.robot_base_noise.x, 0.1);  // kept
  EXPECT_EQ(c.task_sampler_config.robot_base_noise.yaw_deg, 10.0);
  EXPECT_EQ(c.task_sampler_config.samples_per_house, 1);
  EXPECT_THAT(*c.policy_config.grasp_libraries, ElementsAre("custom_grasps/droid"));
  EXPECT_EQ(c.task_config.added_objects.at("mug"), tmp_ / "objs/mug.xml");
}

// ---------------------------------------------------------------------------------------
// Strictness.

TEST_F(ConfigTest, UnknownKeyNamesFileLineAndKeyPath) {
  const fs::path file = kTestdata / "config_unknown_key.yaml";
  try {
    LoadConfigFile(file, registry_);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), file.string());
    EXPECT_EQ(e.field(), "line 6");
    EXPECT_THAT(e.what(), HasSubstr("task_sampler_config.robot_base_noise.yawdeg: unknown key"));
    EXPECT_THAT(e.what(), HasSubstr("did you mean 'yaw_deg'?"));
    EXPECT_THAT(e.what(), HasSubstr("valid keys: x, y, yaw_deg"));
  }
  auto [what, field] = LoadError("num_workers: 1\nnum_wrkers: 2\n");
  EXPECT_EQ(field, "line 2");
  EXPECT_THAT(what, HasSubstr("num_wrkers: unknown key (did you mean 'num_workers'?"));
  std::tie(what, field) = LoadError("camera_config:\n  cameras:\n    - name: a\n      fvo: 3\n");
  EXPECT_EQ(field, "line 4");
  EXPECT_THAT(what, HasSubstr("camera_config.cameras[0].fvo: unknown key"));
  std::tie(what, field) = LoadError("libraries:\n  asset_libraries:\n    - {name: a, dir: b}\n");
  EXPECT_EQ(field, "line 3");
  EXPECT_THAT(what, HasSubstr("libraries.asset_libraries[0].dir: unknown key"));
}

TEST_F(ConfigTest, WrongTypesNameLineAndKey) {
  struct Case {
    std::string yaml, line, part;
  };
  const Case cases[] = {
      {"num_workers: 1\ntask_sampler_config:\n  samples_per_house: two\n", "line 3",
       "task_sampler_config.samples_per_house: expected an integer, got 'two'"},
      {"task_horizon: 2.5\n", "line 1", "task_horizon: expected an integer, got '2.5'"},
      {"task_horizon: \"500\"\n", "line 1", "task_horizon: expected an integer"},
      {"seed: -1\n", "line 1", "seed: expected a whole number >= 0, got '-1'"},
      {"end_on_success: yes\n", "line 1", "end_on_success: expected true or false, got 'yes'"},
      {"policy_dt_ms: fast\n", "line 1", "policy_dt_ms: expected a number, got 'fast'"},
      {"tag: [a, b]\n", "line 1", "tag: expected a string, got a list"},
      {"tag:\n", "line 1", "tag: expected a string, got null"},
      {"output_dir: {a: 1}\n", "line 1", "output_dir: expected a path, got a mapping"},
      {"task_sampler_config:\n  scene_xml_paths: scene.xml\n", "line 2",
       "task_sampler_config.scene_xml_paths: expected a list, got 'scene.xml'"},
      {"robot_config:\n  init_qpos:\n    arm: [0, x]\n", "line 3",
       "robot_config.init_qpos.arm[1]: expected a number, got 'x'"},
      {"robot_config:\n  base_size: [1, 1, x]\n", "line 2",
       "robot_config.base_size[2]: expected a number, got 'x'"},
      {"task_config: 3\n", "line 1", "task_config: expected a mapping, got '3'"},
      {"log_level: verbose\n", "line 1",
       "log_level: expected one of debug, info, warning, error, got 'verbose'"},
      {"task_config:\n  action_dtype: float16\n", "line 2",
       "expected one of float32, float64, got 'float16' (did you mean 'float32' or 'float64'?)"},
      {"scene_dataset: procthor-10k\n", "line 1", "scene_dataset: expected one of user"},
      {"camera_config:\n  cameras:\n    - {name: a, type: mjfc}\n", "line 3",
       "camera_config.cameras[0].type: expected one of mjcf, robot_mounted, got 'mjfc' "
       "(did you mean 'mjcf'?)"},
      {"num_workers: 1\nnum_workers: 2\n", "line 2", "num_workers: duplicate key"},
      {"libraries:\n  grasp_libraries:\n    - {name: g, path: p}\n", "line 3",
       "libraries.grasp_libraries[0]: missing 'asset_library'"},
      {"libraries:\n  asset_libraries:\n    - {name: a/b, path: p}\n", "line 3",
       "must not contain slashes"},
      {"- 1\n- 2\n", "line 1", "top level: expected a mapping, got a list"},
      {"num_workers: [1\n", "line 2", "invalid YAML"},
  };
  for (const Case& c : cases) {
    auto [what, field] = LoadError(c.yaml);
    EXPECT_EQ(field, c.line) << c.yaml << "\n" << what;
    EXPECT_THAT(what, HasSubstr(c.part)) << c.yaml;
  }
}

TEST_F(ConfigTest, AcceptedScalarForms) {
  const ExperimentConfig c = Load(
      "seed: 18446744073709551615\nend_on_success: True\npolicy_dt_ms: 66\n"
      "ctrl_dt_ms: 2e0\ntag: \"null\"\ndata_split: '123'\n"
      "task_sampler_config: {max_tasks: +7}\n");
  EXPECT_EQ(c.seed, 18446744073709551615ULL);
  EXPECT_TRUE(c.end_on_success);
  EXPECT_EQ(c.policy_dt_ms, 66.0);
  EXPECT_EQ(c.ctrl_dt_ms, 2.0);
  EXPECT_EQ(c.tag, "null");  // quoted: a string, not null
  EXPECT_EQ(c.data_split, "123");
  EXPECT_EQ(c.task_sampler_config.max_tasks, 7);
  EXPECT_EQ(
      LoadError("seed: 18446744073709551616\n").first.find("out of range") == std::string::npos,
      false);
}

TEST_F(ConfigTest, MissingFile) {
  ExpectError([&] { LoadConfigFile(tmp_ / "nope.yaml", registry_); },
              {"nope.yaml", "cannot open the config file"});
}

// ---------------------------------------------------------------------------------------
// base: and libraries files.

TEST_F(ConfigTest, BaseStartsFromARegisteredConfig) {
  const fs::path file = kTestdata / "config_with_base.yaml";
  const ExperimentConfig c = LoadConfigFile(file, registry_);
  EXPECT_EQ(c.tag, "tutorial_franka_pick_custom_assets");
  EXPECT_EQ(c.task_sampler_config.samples_per_house, 8);
  EXPECT_EQ(c.task_sampler_config.object_noise.yaw_deg, 10.0);
  EXPECT_EQ(c.task_sampler_config.object_noise.x, 0.05);
  EXPECT_EQ(c.policy_config.grasp_cost_weights.com_dist, 4.0);
  EXPECT_EQ(c.policy_config.grasp_cost_weights.vertical, 2.0);
  // The base's relative paths resolve against the file's folder.
  EXPECT_THAT(c.task_sampler_config.scene_xml_paths, ElementsAre(kTestdata / "scene.xml"));
  EXPECT_EQ(c.libraries.asset_libraries.at(0).dir, kTestdata / "asset_library");

  auto [what, field] = LoadError("num_workers: 2\nbase: CustomAssetDataGenConfig\n");
  EXPECT_EQ(field, "line 2");
  EXPECT_THAT(what, HasSubstr("base: unknown config 'CustomAssetDataGenConfig' (did you mean "
                              "'CustomAssetsDataGenConfig'? registered: PickBaseConfig, "
                              "CustomAssetsDataGenConfig)"));
  std::tie(what, field) = LoadError("base: [a]\n");
  EXPECT_THAT(what, HasSubstr("base: expected a config name, got a list"));
}

TEST_F(ConfigTest, BaseUsesUserRegisteredConfigs) {
  registry_.RegisterConfig("MyPick", [] {
    ExperimentConfig c = CustomAssetsDataGenConfig();
    c.task_horizon = 42;
    return c;
  });
  const ExperimentConfig c = Load("base: mypick\nnum_workers: 3\n");
  EXPECT_EQ(c.task_horizon, 42);
  EXPECT_EQ(c.num_workers, 3);
}

TEST_F(ConfigTest, LibrariesFromALibrariesFile) {
  WriteText(tmp_ / "sub/libs.yaml",
            "asset_libraries:\n  - {name: a, path: lib}\n"
            "grasp_libraries:\n  - {name: g, path: lib, asset_library: a}\n");
  const ExperimentConfig c = Load("libraries: sub/libs.yaml\n");
  ASSERT_EQ(c.libraries.asset_libraries.size(), 1u);
  EXPECT_EQ(c.libraries.asset_libraries[0].dir, tmp_ / "sub/lib");
  EXPECT_EQ(c.libraries.grasp_libraries[0].asset_library, "a");

  // An error inside the libraries file names that file and its line.
  WriteText(tmp_ / "sub/libs.yaml", "asset_libraries:\n  - {name: a, pth: lib}\n");
  ExpectError([&] { Load("libraries: sub/libs.yaml\n"); },
              {"libs.yaml", "line 2", "asset_libraries[0].pth: unknown key"});
  // A missing libraries file names the config's line.
  auto [what, field] = LoadError("num_workers: 1\nlibraries: missing.yaml\n");
  EXPECT_EQ(field, "line 2");
  EXPECT_THAT(what, HasSubstr("libraries: "));
  EXPECT_THAT(what, HasSubstr("cannot open"));
}

// ---------------------------------------------------------------------------------------
// --set.

TEST_F(ConfigTest, SetOverridesNestedValuesSequencesAndNull) {
  ExperimentConfig c = CustomAssetsDataGenConfig();
  ApplyOverride(c, "task_sampler_config.samples_per_house=4", tmp_.path());
  ApplyOverride(c, "task_sampler_config.robot_base_noise.yaw_deg=12.5", tmp_.path());
  ApplyOverride(c, "task_sampler_config.scene_xml_paths=[a.xml, /abs/b.xml]", tmp_.path());
  ApplyOverride(c, "task_sampler_config.house_inds=[1]", tmp_.path());
  ApplyOverride(c, "robot_config.base_size=[0.4, 0.4, 0.5]", tmp_.path());
  ApplyOverride(c, "output_dir=", tmp_.path());  // empty value = null
  ApplyOverride(c, "seed=3", tmp_.path());
  ApplyOverride(c, "camera_config.cameras.1.fov=60", tmp_.path());
  ApplyOverride(c, "task_config.added_objects.mug=mug.xml", tmp_.path());
  ApplyOverride(c, "policy_config.grasp_cost_weights={rot: 0.02}", tmp_.path());
  ApplyOverride(c, "tag=my run", tmp_.path());
  EXPECT_EQ(c.task_sampler_config.samples_per_house, 4);
  EXPECT_EQ(c.task_sampler_config.robot_base_noise.yaw_deg, 12.5);
  EXPECT_EQ(c.task_sampler_config.robot_base_noise.x, 0.1);
  EXPECT_THAT(c.task_sampler_config.scene_xml_paths,
              ElementsAre(tmp_ / "a.xml", fs::path("/abs/b.xml")));
  EXPECT_THAT(*c.task_sampler_config.house_inds, ElementsAre(1));
  EXPECT_EQ(c.robot_config.base_size, (std::array<double, 3>{0.4, 0.4, 0.5}));
  EXPECT_FALSE(c.output_dir.has_value());
  EXPECT_EQ(c.seed, 3u);
  EXPECT_EQ(c.camera_config.cameras[1].fov, 60.0);
  EXPECT_EQ(c.camera_config.cameras[0].fov, 56.74);
  EXPECT_EQ(c.task_config.added_objects.at("mug"), tmp_ / "mug.xml");
  EXPECT_EQ(c.policy_config.grasp_cost_weights.rot, 0.02);
  EXPECT_EQ(c.policy_config.grasp_cost_weights.com_dist, 8.0);
  EXPECT_EQ(c.tag, "my run");
  Validate(c);
}

TEST_F(ConfigTest, SetErrorsNameTheKey) {
  EXPECT_THAT(SetError("task_sampler_config.samples_per_hous=4"),
              HasSubstr("--set task_sampler_config.samples_per_hous: unknown key (did you mean "
                        "'samples_per_house'?"));
  EXPECT_THAT(SetError("nope=1"), HasSubstr("--set nope: unknown key (valid keys: num_envs, "));
  EXPECT_THAT(SetError("task_sampler_config.samples_per_house=abc"),
              HasSubstr("--set task_sampler_config.samples_per_house: expected an integer, got "
                        "'abc'"));
  EXPECT_THAT(SetError("robot_config.init_qpos.arm=[1, x]"),
              HasSubstr("robot_config.init_qpos.arm[1]: expected a number"));
  EXPECT_THAT(SetError("log_level=loud"), HasSubstr("--set log_level: expected one of debug"));
  EXPECT_THAT(SetError("num_workers.x=1"),
              HasSubstr("--set num_workers: is a single value, it has no key 'x'"));
  EXPECT_THAT(SetError("camera_config.cameras.5.fov=1"),
              HasSubstr("'5' is not an index of this list (2 items)"));
  EXPECT_THAT(SetError("task_horizon"), HasSubstr("--set expects KEY=VALUE"));
  EXPECT_THAT(SetError("=3"), HasSubstr("--set expects KEY=VALUE"));
  EXPECT_THAT(SetError("a..b=3"), HasSubstr("empty key component"));
  EXPECT_THAT(SetError("tag=[unclosed"), HasSubstr("--set tag: invalid YAML value"));
  EXPECT_THAT(SetError("task_config={nope: 1}"), HasSubstr("--set task_config.nope: unknown key"));
  // Errors leave no line: they are about the command line.
  EXPECT_THAT(SetError("task_horizon=x"), Not(HasSubstr("line")));
}

// ---------------------------------------------------------------------------------------
// Validation.

TEST_F(ConfigTest, ValidateChecksAcrossFields) {
  const ExperimentConfig good = CustomAssetsDataGenConfig();
  Validate(good);
  auto expect = [&](const std::string& assignment, const std::string& part) {
    ExperimentConfig c = good;
    ApplyOverride(c, assignment, tmp_.path());
    ExpectError([&] { Validate(c, "job.yaml"); }, {"job.yaml", part});
  };
  expect("policy_dt_ms=65", "policy_dt_ms: policy_dt_ms / ctrl_dt_ms must be a whole number");
  expect("sim_dt_ms=0.3", "ctrl_dt_ms: ctrl_dt_ms / sim_dt_ms must be a whole number");
  expect("num_envs=2", "num_envs: only 1 environment");
  expect("num_workers=0", "num_workers: must be >= 1, got 0");
  expect("task_sampler_config.samples_per_house=0", "task_sampler_config.samples_per_house");
  expect("task_sampler_config.house_inds=[1]", "task_sampler_config.house_inds: index 1");
  expect("task_sampler_config.scene_xml_paths=[]", "task_sampler_config.scene_xml_paths");
  expect("task_sampler_config.house_variant=v1", "house_variant");
  expect("task_sampler_config.object_noise.x=-1", "task_sampler_config.object_noise.x");
  expect("task_config.robot_base_pose=[0, 0, 0, 2, 0, 0, 0]", "unit length");
  expect("camera_config.cameras.1.reference_body_names=[]",
         "camera_config.cameras[1].reference_body_names");
  expect("camera_config.cameras.1.name=wrist_camera", "duplicate camera name");
  expect("camera_config.cameras.0.type=robot_mounted", "camera_config.cameras[0]");
  expect("policy_config.speed_slow=0", "policy_config.speed_slow");
  expect("libraries.grasp_libraries.0.asset_library=\"\"",
         "libraries.grasp_libraries[0].asset_library");
}

// ---------------------------------------------------------------------------------------
// Dump and hash.

TEST_F(ConfigTest, DumpLoadRoundTripKeepsTheHash) {
  ExperimentConfig c = LoadConfigFile(kExample, registry_);
  ApplyOverride(c, "tag=\"a: b # c \\\"q\\\" \\n\"", tmp_.path());
  ApplyOverride(c, "task_config.pickup_obj_name=\"null\"", tmp_.path());
  ApplyOverride(c, "task_config.robot_base_pose=[0.1, -0.2, 0, 1, 0, 0, 0]", tmp_.path());
  ApplyOverride(c, "policy_config.speed_fast=0.30000000000000004", tmp_.path());
  ApplyOverride(c, "task_sampler_config.max_tasks=", tmp_.path());
  ApplyOverride(c, "task_sampler_config.pickup_types=[-block, \"\"]", tmp_.path());
  const std::string dump = DumpConfig(c);
  WriteText(tmp_ / "elsewhere/dump.yaml", dump);
  const ExperimentConfig again = LoadConfigFile(tmp_ / "elsewhere/dump.yaml", registry_);
  EXPECT_EQ(DumpConfig(again), dump);
  EXPECT_EQ(ConfigHash(again), ConfigHash(c));
  EXPECT_EQ(again.tag, "a: b # c \"q\" \n");
  EXPECT_EQ(again.task_config.pickup_obj_name, "null");
  EXPECT_EQ(again.policy_config.speed_fast, 0.30000000000000004);
  EXPECT_THAT(again.task_sampler_config.pickup_types, ElementsAre("-block", ""));
}

TEST_F(ConfigTest, HashIsFnv1aOfTheDumpAndChangesWithAnyValue) {
  const ExperimentConfig c = CustomAssetsDataGenConfig();
  EXPECT_EQ(ConfigHash(c), HashString(DumpConfig(c)));
  const std::string hex = ConfigHashHex(c);
  EXPECT_EQ(hex.size(), 16u);
  EXPECT_EQ(hex.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_EQ(ConfigHash(CustomAssetsDataGenConfig()), ConfigHash(c));  // deterministic
  for (const char* assignment :
       {"seed=1", "task_sampler_config.object_noise.yaw_deg=45.000001", "log_level=debug",
        "camera_config.cameras.0.visibility_constraints={a: 0.5}",
        "robot_config.base_size=[0.5, 0.5, 0.58]", "policy_config.grasp_libraries=[]"}) {
    ExperimentConfig changed = c;
    ApplyOverride(changed, assignment, tmp_.path());
    EXPECT_NE(ConfigHash(changed), ConfigHash(c)) << assignment;
  }
}

// ---------------------------------------------------------------------------------------
// Registry.

TEST_F(ConfigTest, RegistryLookupIsCaseInsensitiveWithDidYouMean) {
  EXPECT_THAT(registry_.Names(), ElementsAre("PickBaseConfig", "CustomAssetsDataGenConfig"));
  EXPECT_TRUE(registry_.Contains("customassetsdatagenconfig"));
  EXPECT_FALSE(registry_.Contains("CustomAssets"));
  EXPECT_EQ(registry_.CanonicalName("PICKBASECONFIG"), "PickBaseConfig");
  EXPECT_EQ(registry_.Make("customAssetsDataGenConfig").tag, "tutorial_franka_pick_custom_assets");
  EXPECT_EQ(ConfigHash(registry_.Make("pickbaseconfig")), ConfigHash(ExperimentConfig{}));
  ExpectError([&] { registry_.Make("PickBase"); },
              {"unknown config 'PickBase' (did you mean 'PickBaseConfig'? registered: "
               "PickBaseConfig, CustomAssetsDataGenConfig)"});
  ExpectError([&] { registry_.Make("zzz"); }, {"unknown config 'zzz' (registered: "});
  ExpectError([&] { ConfigRegistry().Make("x"); }, {"registered: none"});
}

TEST_F(ConfigTest, RegisterConfigRejectsDuplicatesUnlessReplacing) {
  ConfigRegistry r;
  r.RegisterConfig("Mine", [] { return ExperimentConfig{}; });
  EXPECT_THROW(r.RegisterConfig("MINE", [] { return ExperimentConfig{}; }), UsageError);
  EXPECT_THROW(r.RegisterConfig("", [] { return ExperimentConfig{}; }), UsageError);
  EXPECT_THROW(r.RegisterConfig("a b", [] { return ExperimentConfig{}; }), UsageError);
  EXPECT_THROW(r.RegisterConfig("Empty", nullptr), UsageError);
  r.RegisterConfig(
      "MINE",
      [] {
        ExperimentConfig c;
        c.num_workers = 4;
        return c;
      },
      /*replace=*/true);
  EXPECT_THAT(r.Names(), ElementsAre("MINE"));
  EXPECT_EQ(r.Make("mine").num_workers, 4);
}

// ---------------------------------------------------------------------------------------
// The CLI.

TEST_F(ConfigTest, CliPrintsTheResolvedConfigAndHash) {
  const auto r = RunCli({"config", kExample.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const ExperimentConfig expected = LoadConfigFile(kExample, registry_);
  EXPECT_EQ(r.out, "# config hash: " + ConfigHashHex(expected) + "\n" + DumpConfig(expected));
  // The output is itself a config that loads back to the same hash.
  WriteText(tmp_ / "printed.yaml", r.out);
  EXPECT_EQ(ConfigHash(LoadConfigFile(tmp_ / "printed.yaml", registry_)), ConfigHash(expected));
}

TEST_F(ConfigTest, CliAppliesOverridesAndFlags) {
  const auto r =
      RunCli({"config", kExample.string(), "--set", "task_sampler_config.samples_per_house=4",
              "--set", "policy_config.max_retries=1", "--seed", "7", "--episodes", "5", "--output",
              "/tmp/mlspaces_out"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\n  samples_per_house: 5\n"));  // --episodes wins over --set
  EXPECT_THAT(r.out, HasSubstr("\n  max_retries: 1\n"));
  EXPECT_THAT(r.out, HasSubstr("\nseed: 7\n"));
  EXPECT_THAT(r.out, HasSubstr("\noutput_dir: /tmp/mlspaces_out\n"));
  ExperimentConfig expected = LoadConfigFile(kExample, registry_);
  ApplyOverride(expected, "task_sampler_config.samples_per_house=5", "/");
  ApplyOverride(expected, "policy_config.max_retries=1", "/");
  ApplyOverride(expected, "seed=7", "/");
  ApplyOverride(expected, "output_dir=/tmp/mlspaces_out", "/");
  EXPECT_THAT(r.out, StartsWith("# config hash: " + ConfigHashHex(expected) + "\n"));
}

TEST_F(ConfigTest, CliAcceptsARegisteredName) {
  const auto r = RunCli({"config", "customassetsdatagenconfig"},
                        "cd " + ::mlspaces::testing::ShellQuote(kExampleDir.string()) + " && ");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ExperimentConfig expected = CustomAssetsDataGenConfig();
  ResolvePaths(expected, kExampleDir);
  EXPECT_THAT(r.out, StartsWith("# config hash: " + ConfigHashHex(expected) + "\n"));
}

TEST_F(ConfigTest, CliExitCodes) {
  // Bad input: 1, one line naming file and line.
  auto r = RunCli({"config", (kTestdata / "config_unknown_key.yaml").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_THAT(r.err, HasSubstr("config_unknown_key.yaml: line 6: "
                               "task_sampler_config.robot_base_noise.yawdeg: unknown key"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  r = RunCli({"config", (tmp_ / "missing.yaml").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("cannot open the config file"));
  r = RunCli({"config", "CustomAssetDataGenConfig"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("did you mean 'CustomAssetsDataGenConfig'?"));
  r = RunCli({"config", kExample.string(), "--set", "policy_dt_ms=65"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("policy_dt_ms / ctrl_dt_ms must be a whole number"));
  // A value a --set gave is named by the --set (it was the file, which holds another value);
  // one in a list by the list's --set, with the element.
  r = RunCli({"config", kExample.string(), "--set", "task_config.succ_pos_threshold=0.1", "--set",
              "task_config.succ_pos_threshold=-1"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "mlspaces: error: --set task_config.succ_pos_threshold=-1: must be a finite number > "
            "0, got -1\n");
  r = RunCli({"config", kExample.string(), "--set", "camera_config.cameras=[{name: a, fov: -3}]"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("--set camera_config.cameras=[{name: a, fov: -3}]: "
                               "camera_config.cameras[0].fov: must be in (0, 180) degrees"));
  // The file's own bad value is still the file's.
  const fs::path bad = tmp_ / "bad_threshold.yaml";
  ::mlspaces::testing::WriteText(bad,
                                 "base: CustomAssetsDataGenConfig\ntask_config:\n  "
                                 "succ_pos_threshold: -1\n");
  r = RunCli({"config", bad.string(), "--set", "seed=3"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(bad.string() + ": task_config.succ_pos_threshold: must be"));
  // Bad usage: 2.
  r = RunCli({"config"});
  EXPECT_EQ(r.exit_code, 2);
  r = RunCli({"config", kExample.string(), "--set", "task_sampler_config.nope=1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--set task_sampler_config.nope: unknown key"));
  r = RunCli({"config", kExample.string(), "--set", "num_workers=many"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--set num_workers: expected an integer, got 'many'"));
  r = RunCli({"config", kExample.string(), "--set", "num_workers"});
  EXPECT_EQ(r.exit_code, 2);
  r = RunCli({"config", kExample.string(), "--episodes", "0"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("expected a whole number >= 1, got '0'"));
  r = RunCli({"config", kExample.string(), "--seed", "-3"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("expected a whole number >= 0, got '-3'"));
}

}  // namespace
}  // namespace mlspaces::datagen
