// A custom task sampler, as in the MolmoSpaces custom-asset tutorial: its Python
// `BlockPickupTaskSampler(PickTaskSampler)` overrides `_sample_and_place_robot`; here a
// TaskSampler subclass overrides SampleAndPlaceRobot, is registered by name, and a datagen
// run uses it because the config names it in task_sampler_config.task_sampler_class.
//
//   custom_sampler_example CONFIG.yaml [OUTPUT_DIR] [EPISODES]
//   custom_sampler_example examples/custom_assets/datagen.yaml /tmp/my_run 2
//
// (The built-in "block_pickup" sampler does the same from config values; this file shows how
// to write one in code.)
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/datagen/task_sampler.h"

namespace {

namespace dg = mlspaces::datagen;

// The tutorial's sampler. SampleTask has already reset the scene, jittered the arm and picked
// the object (draft.pickup_obj_name); this hook places the robot and the object and fills the
// three poses. All randomness comes from `rng`, which is seeded per episode, so a run is
// reproducible. To skip an episode that cannot be placed, throw dg::TaskRejected.
class MyBlockPickupSampler : public dg::TaskSampler {
 public:
  using TaskSampler::TaskSampler;  // (config, run seed)

 protected:
  void SampleAndPlaceRobot(dg::Env& env, mlspaces::Rng& rng, dg::TaskDraft& draft) override {
    constexpr double kDeg = std::numbers::pi / 180.0;

    // Robot base: x, y in +-0.1 m and yaw in +-30 deg, composed in the base's own frame
    // (Python: `robot_base_pose @ random_pose`).
    const double rx = rng.Uniform(-0.1, 0.1);
    const double ry = rng.Uniform(-0.1, 0.1);
    const double ryaw = rng.Uniform(-30.0, 30.0) * kDeg;
    env.SetRobotBasePose(dg::ComposePlanar(env.GetRobotBasePose(), rx, ry, ryaw));
    env.ForwardPosition();
    draft.robot_base_pose = env.GetRobotBasePose();

    // The block: x, y in +-0.05 m and yaw in +-45 deg, in the block's frame.
    const std::string& block = *draft.pickup_obj_name;
    const double ox = rng.Uniform(-0.05, 0.05);
    const double oy = rng.Uniform(-0.05, 0.05);
    const double oyaw = rng.Uniform(-45.0, 45.0) * kDeg;
    env.SetBodyPose(block, dg::ComposePlanar(env.GetBodyPose(block), ox, oy, oyaw));
    env.ForwardPosition();
    draft.pickup_obj_start_pose = env.GetBodyPose(block);

    // Goal: lift it 5 cm (world z). Poses are a position and a quaternion qw, qx, qy, qz.
    mlspaces::Pose goal = *draft.pickup_obj_start_pose;
    goal.pos[2] += 0.05;
    draft.pickup_obj_goal_pose = goal;
  }
};

int64_t ParseEpisodes(const std::string& text) {
  size_t used = 0;
  int64_t n = 0;
  try {
    n = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || n <= 0) {
    throw mlspaces::Error("EPISODES must be a positive integer, got '" + text + "'");
  }
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: custom_sampler_example CONFIG.yaml [OUTPUT_DIR] [EPISODES]\n");
    return 2;
  }
  try {
    // 1. The config: a YAML file (relative paths resolve against its folder), then our changes.
    dg::ExperimentConfig config = dg::LoadConfigFile(argv[1], dg::ConfigRegistry::WithBuiltins());
    config.task_sampler_config.task_sampler_class = "my_block_pickup";
    if (argc > 2) config.output_dir = std::filesystem::absolute(argv[2]).lexically_normal();
    if (argc > 3) config.task_sampler_config.samples_per_house = ParseEpisodes(argv[3]);
    dg::Validate(config, argv[1]);

    // 2. The samplers the run may create: the built-ins plus ours, by name.
    dg::TaskSamplerRegistry samplers = dg::TaskSamplerRegistry::WithBuiltins();
    samplers.Register("my_block_pickup", [](const dg::ExperimentConfig& c, uint64_t seed) {
      return std::make_unique<MyBlockPickupSampler>(c, seed);
    });

    // 3. Run: the run creates config.task_sampler_config.task_sampler_class from `samplers`.
    dg::RunOptions options;
    options.log = [](dg::LogLevel, const std::string& line) {
      std::fprintf(stderr, "custom_sampler: %s\n", line.c_str());
    };
    const dg::RunReport report = dg::RunDatagen(config, samplers, options);
    std::printf("run folder: %s\nepisodes kept: %lld\n%s", report.folder.c_str(),
                static_cast<long long>(report.episodes_kept),
                dg::FormatSummary(report.summary).c_str());
    return 0;
  } catch (const mlspaces::Error& e) {
    std::fprintf(stderr, "custom_sampler: error: %s\n", e.what());
    return 1;
  }
}
