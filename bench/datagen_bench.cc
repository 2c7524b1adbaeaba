// Datagen throughput on the custom-asset tutorial (examples/custom_assets/datagen.yaml), no
// rendering. Issue targets: episodes per hour per core, and physics steps per second inside
// datagen within 25% of bare mj_step on the same model (overhead_pct of BM_DatagenOverhead,
// both rates measured in the same run). Everything is single-threaded, so rates are per core;
// they are taken over wall time (UseRealTime).
//
// Datagen's physics per policy step: policy_dt / sim_dt (33) x {mj_step1, arm gravity
// compensation, mj_step2} and one mj_fwdPosition, plus the planner (IK), the action noise and the
// observation (success check, and recording when on). "steps" below are physics steps
// (EpisodeResult::physics_steps), the same unit as one bare mj_step. overhead_pct compares
// with bare steps from the reset pose; the episode's states (gripper closing on and lifting
// the block) have more contacts, so read it with physics_stage_steps_per_s (datagen's own
// stepping) and bare_grasp_steps_per_s (bare steps from the grasped final state).
//
//   datagen_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_runner.h"
#include "mlspaces/datagen/recorder.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/robots/robot_view.h"
#include "mlspaces/sim/scene.h"

namespace {

namespace fs = std::filesystem;
namespace dg = mlspaces::datagen;
using Clock = std::chrono::steady_clock;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";
constexpr uint64_t kSeed = 1;
// Episodes per benchmark run: every repetition runs episodes 0..kEpisodes-1, the same work.
constexpr int64_t kEpisodes = 8;
// Bare mj_step: the state goes back to the reset pose every this many steps.
constexpr int64_t kResetEvery = 1000;
// BM_DatagenOverhead: bare steps timed per episode (66 policy steps x 33, about one tutorial
// episode's physics).
constexpr int64_t kBareSteps = 2178;

double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

dg::ExperimentConfig TutorialConfig() {
  dg::ExperimentConfig config =
      dg::LoadConfigFile(kExample / "datagen.yaml", dg::ConfigRegistry::WithBuiltins());
  if (!config.seed) config.seed = kSeed;
  return config;
}

// The tutorial's env, registry, sampler and runner, built as `mlspaces datagen` builds them.
// Not movable: the runner holds references to the others.
struct Datagen {
  dg::ExperimentConfig config;
  mlspaces::Registry registry;
  dg::Env env;
  std::unique_ptr<dg::TaskSampler> sampler;
  std::optional<dg::EpisodeRunner> runner;

  explicit Datagen(bool with_runner, bool record = true)
      : config(TutorialConfig()),
        registry(mlspaces::Registry::Options{config.libraries.assets_dir}),
        env(dg::Env::Create(mlspaces::sim::Scene::Load(kExample / "scene.xml"),
                            dg::RobotSpecFromConfig(config.robot_config), "house_0")) {
    env.Reset();
    if (!with_runner) return;
    config.libraries.ApplyTo(registry);
    sampler = dg::TaskSamplerRegistry::WithBuiltins().Create(config, *config.seed);
    dg::EpisodeRunnerOptions options;
    options.scene_name = "house_0";
    options.record = record;
    runner.emplace(env, *sampler, registry, config, options);
  }
  Datagen(const Datagen&) = delete;
  Datagen& operator=(const Datagen&) = delete;
};

// Builds the setup or marks the benchmark skipped.
std::unique_ptr<Datagen> MakeDatagen(benchmark::State& state, bool with_runner,
                                     bool record = true) {
  try {
    return std::make_unique<Datagen>(with_runner, record);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return nullptr;
  }
}

// Bare mj_step on the datagen model from the reset state (arm at home, servo targets at home,
// gripper open); the reset every kResetEvery steps is not timed.
void BM_BareMjStep(benchmark::State& state) {
  auto dgn = MakeDatagen(state, /*with_runner=*/false);
  if (!dgn) return;
  const mjModel* m = dgn->env.model();
  mjData* d = dgn->env.data();
  int64_t since_reset = 0;
  for (auto _ : state) {
    mj_step(m, d);
    if (++since_reset == kResetEvery) {
      state.PauseTiming();
      dgn->env.Reset();
      since_reset = 0;
      state.ResumeTiming();
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BareMjStep)->UseRealTime();

// One episode per iteration (episodes 0, 1, ...): sample, grasps, plan, roll out, judge, and
// record in memory when state.range(0) is 1. With range(0) == 2 the record is also written
// to HDF5 (Recorder::Write, fsync included) as `mlspaces datagen` does for kept episodes.
void BM_DatagenEpisode(benchmark::State& state) {
  const int64_t mode = state.range(0);
  auto dgn = MakeDatagen(state, /*with_runner=*/true, /*record=*/mode >= 1);
  if (!dgn) return;
  std::optional<dg::Recorder> recorder;
  fs::path out;
  if (mode == 2) {
    out = fs::temp_directory_path() / ("mlspaces_datagen_bench_" + std::to_string(::getpid()));
    dg::RecorderOptions options;
    options.dir = out / "house_0";
    recorder.emplace(options);
  }
  int64_t episode = 0, physics_steps = 0, policy_steps = 0, successes = 0, written = 0;
  const auto t0 = Clock::now();
  try {
    for (auto _ : state) {
      dg::EpisodeResult result = dgn->runner->Run(episode++);
      physics_steps += result.physics_steps;
      policy_steps += result.policy_steps;
      successes += result.success ? 1 : 0;
      const bool keep = result.success || !dgn->config.filter_for_successful_trajectories;
      if (recorder && keep && result.record) {
        recorder->Write(*result.record);
        ++written;
      }
    }
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
  }
  const double wall_s = Since(t0);
  const double episodes = static_cast<double>(state.iterations());
  state.counters["episodes_per_hour"] = wall_s > 0 ? 3600.0 * episodes / wall_s : 0;
  state.counters["steps_per_s"] =
      benchmark::Counter(static_cast<double>(physics_steps), benchmark::Counter::kIsRate);
  state.counters["policy_steps_per_ep"] = static_cast<double>(policy_steps) / episodes;
  state.counters["success_pct"] = 100.0 * static_cast<double>(successes) / episodes;
  if (recorder) state.counters["written"] = static_cast<double>(written);
  recorder.reset();
  if (!out.empty()) {
    std::error_code ec;
    fs::remove_all(out, ec);
  }
}
BENCHMARK(BM_DatagenEpisode)
    ->ArgName("record")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Iterations(kEpisodes)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The overhead ratio in one run, on one model and one mjData. Per iteration (episode i):
//   1. reset, kBareSteps bare mj_steps                      -> bare_steps_per_s
//   2. reset, the same number of steps as datagen's physics loop, no policy (33 x {mj_step1,
//      gravity compensation, mj_step2} + mj_fwdPosition per policy step) -> loop_steps_per_s
//   3. one datagen episode, record = range(0)               -> datagen_steps_per_s
//      (physics steps / episode wall time), and physics_stage_steps_per_s (the same steps
//      over the episode's own "physics" timing: its stepping and mj_fwdPosition only)
//   4. kBareSteps bare mj_steps from the episode's final state (object grasped and lifted,
//      more contacts than the reset pose)                   -> bare_grasp_steps_per_s
//   5. the episode's own states: at every policy step of step 3 the state (qpos, qvel, act,
//      ctrl, mocap, warm start, time) was saved; each is restored and followed by the same
//      number of bare mj_steps                              -> bare_same_states_steps_per_s
// overhead_same_states_pct = (bare_same_states / datagen - 1) * 100 compares datagen with
// bare stepping through exactly the states it simulated.
// overhead_pct = (bare / datagen - 1) * 100, the figure (target < 25);
// overhead_grasp_pct the same against the grasped-state bare rate.
void BM_DatagenOverhead(benchmark::State& state) {
  auto dgn = MakeDatagen(state, /*with_runner=*/true, /*record=*/state.range(0) != 0);
  if (!dgn) return;
  const mjModel* m = dgn->env.model();
  mjData* d = dgn->env.data();
  const int substeps = dgn->runner->substeps();
  const int64_t loop_policy_steps = kBareSteps / substeps;
  int64_t episode = 0, bare_steps = 0, loop_steps = 0, datagen_steps = 0;
  double bare_s = 0, bare_grasp_s = 0, loop_s = 0, datagen_s = 0, physics_stage_s = 0;
  // Step 5: the states datagen stepped from.
  struct Snapshot {
    std::vector<mjtNum> qpos, qvel, act, ctrl, mocap_pos, mocap_quat, warmstart;
    mjtNum time = 0;
  };
  std::vector<Snapshot> snapshots;
  auto grab = [](const mjtNum* p, int n) { return std::vector<mjtNum>(p, p + n); };
  dgn->runner.reset();
  dg::EpisodeRunnerOptions hooked;
  hooked.record = state.range(0) != 0;
  hooked.on_step = [&](const mjModel* mm, const mjData* dd, int64_t) {
    snapshots.push_back({grab(dd->qpos, mm->nq), grab(dd->qvel, mm->nv), grab(dd->act, mm->na),
                         grab(dd->ctrl, mm->nu), grab(dd->mocap_pos, 3 * mm->nmocap),
                         grab(dd->mocap_quat, 4 * mm->nmocap), grab(dd->qacc_warmstart, mm->nv),
                         dd->time});
  };
  dgn->runner.emplace(dgn->env, *dgn->sampler, dgn->registry, dgn->config, hooked);
  int64_t same_steps = 0;
  double same_s = 0;
  const mlspaces::robots::RobotView& robot = dgn->runner->robot();
  try {
    for (auto _ : state) {
      dgn->env.Reset();
      auto t0 = Clock::now();
      for (int64_t i = 0; i < kBareSteps; ++i) mj_step(m, d);
      bare_s += Since(t0);
      bare_steps += kBareSteps;

      dgn->env.Reset();
      t0 = Clock::now();
      for (int64_t i = 0; i < loop_policy_steps; ++i) {
        robot.Step(d, substeps);
        mj_fwdPosition(m, d);
      }
      loop_s += Since(t0);
      loop_steps += loop_policy_steps * substeps;

      t0 = Clock::now();
      dg::EpisodeResult result = dgn->runner->Run(episode++);
      datagen_s += Since(t0);
      datagen_steps += result.physics_steps;
      for (const auto& [stage, seconds] : result.attempt.timings) {
        if (stage == "physics") physics_stage_s += seconds;
      }
      benchmark::DoNotOptimize(result);

      t0 = Clock::now();
      for (int64_t i = 0; i < kBareSteps; ++i) mj_step(m, d);
      bare_grasp_s += Since(t0);

      for (const Snapshot& snap : snapshots) {
        std::copy(snap.qpos.begin(), snap.qpos.end(), d->qpos);
        std::copy(snap.qvel.begin(), snap.qvel.end(), d->qvel);
        std::copy(snap.act.begin(), snap.act.end(), d->act);
        std::copy(snap.ctrl.begin(), snap.ctrl.end(), d->ctrl);
        std::copy(snap.mocap_pos.begin(), snap.mocap_pos.end(), d->mocap_pos);
        std::copy(snap.mocap_quat.begin(), snap.mocap_quat.end(), d->mocap_quat);
        std::copy(snap.warmstart.begin(), snap.warmstart.end(), d->qacc_warmstart);
        d->time = snap.time;
        t0 = Clock::now();
        for (int i = 0; i < substeps; ++i) mj_step(m, d);
        same_s += Since(t0);
        same_steps += substeps;
      }
      snapshots.clear();
    }
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  auto rate = [](double steps, double seconds) { return seconds > 0 ? steps / seconds : 0.0; };
  const double bare = rate(static_cast<double>(bare_steps), bare_s);
  const double bare_grasp = rate(static_cast<double>(bare_steps), bare_grasp_s);
  const double datagen = rate(static_cast<double>(datagen_steps), datagen_s);
  state.counters["bare_steps_per_s"] = bare;
  state.counters["bare_grasp_steps_per_s"] = bare_grasp;
  state.counters["loop_steps_per_s"] = rate(static_cast<double>(loop_steps), loop_s);
  state.counters["datagen_steps_per_s"] = datagen;
  state.counters["physics_stage_steps_per_s"] =
      rate(static_cast<double>(datagen_steps), physics_stage_s);
  state.counters["overhead_pct"] = datagen > 0 ? (bare / datagen - 1.0) * 100.0 : 0;
  state.counters["overhead_grasp_pct"] = datagen > 0 ? (bare_grasp / datagen - 1.0) * 100.0 : 0;
  const double bare_same = rate(static_cast<double>(same_steps), same_s);
  state.counters["bare_same_states_steps_per_s"] = bare_same;
  state.counters["overhead_same_states_pct"] =
      datagen > 0 ? (bare_same / datagen - 1.0) * 100.0 : 0;
}
BENCHMARK(BM_DatagenOverhead)
    ->ArgName("record")
    ->Arg(0)
    ->Arg(1)
    ->Iterations(kEpisodes)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
