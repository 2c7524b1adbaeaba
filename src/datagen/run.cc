#include "mlspaces/datagen/run.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <random>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/core/registry.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_runner.h"
#include "mlspaces/datagen/recorder.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

// Python's round(): halves to even.
int64_t RoundHalfEven(double x) {
  const double f = std::floor(x);
  const double diff = x - f;
  if (diff > 0.5) return static_cast<int64_t>(f) + 1;
  if (diff < 0.5) return static_cast<int64_t>(f);
  const auto i = static_cast<int64_t>(f);
  return i % 2 == 0 ? i : i + 1;
}

uint64_t DrawSeed() {
  std::random_device device;
  return (static_cast<uint64_t>(device()) << 32) ^ device();
}

// The config to run: the stored one's seed when ours is null, checked against a stored run.
ExperimentConfig SettleRunConfig(const ExperimentConfig& config, const fs::path& file) {
  ExperimentConfig run = config;
  if (!fs::exists(file)) {
    if (!run.seed) run.seed = DrawSeed();
    return run;
  }
  const ExperimentConfig stored = LoadConfigFile(file, ConfigRegistry::WithBuiltins());
  if (!run.seed) run.seed = stored.seed;
  if (DataConfigHashHex(stored) != DataConfigHashHex(run)) {
    throw Error("the folder holds a run of another config (data hash " +
                    DataConfigHashHex(stored) + ", this one " + DataConfigHashHex(run) +
                    "): choose another output folder, or remove this one to start over",
                file.string());
  }
  return run;
}

}  // namespace

std::vector<WorkItem> PlanWorkItems(const ExperimentConfig& config) {
  const TaskSamplerConfig& s = config.task_sampler_config;
  std::vector<int64_t> houses;
  if (s.house_inds) {
    houses = *s.house_inds;
  } else {
    for (size_t i = 0; i < s.scene_xml_paths.size(); ++i) houses.push_back(static_cast<int64_t>(i));
  }
  std::vector<WorkItem> items;
  for (const int64_t house : houses) {
    if (house < 0 || house >= static_cast<int64_t>(s.scene_xml_paths.size())) {
      throw Error("house index " + std::to_string(house) + " is out of range (" +
                      std::to_string(s.scene_xml_paths.size()) + " scene_xml_paths)",
                  "", "task_sampler_config.house_inds");
    }
    const int64_t n = s.samples_per_house;
    const int64_t batches = std::max<int64_t>(
        1, RoundHalfEven(static_cast<double>(n) / static_cast<double>(s.episodes_per_batch)));
    int64_t first = 0;
    for (int64_t b = 0; b < batches; ++b) {
      WorkItem item;
      item.house = house;
      item.scene_xml = s.scene_xml_paths[house];
      item.batch = static_cast<int>(b + 1);
      item.num_batches = static_cast<int>(batches);
      item.episodes = n / batches + (b < n % batches ? 1 : 0);
      item.max_attempts = item.episodes * s.max_total_attempts_multiplier;
      item.first_episode = first;
      first += item.max_attempts;
      if (item.episodes > 0) items.push_back(item);
    }
  }
  return items;
}

fs::path RunFolder(const ExperimentConfig& config) {
  if (config.output_dir) return *config.output_dir;
  return fs::current_path() / "experiment_output" / config.tag;
}

RunReport RunDatagen(const ExperimentConfig& input, const TaskSamplerRegistry& samplers,
                     const RunOptions& options) {
  const auto t_start = Clock::now();
  auto log = [&](LogLevel level, const std::string& line) {
    if (options.log && level >= input.log_level) options.log(level, line);
  };
  RunReport report;
  report.folder = RunFolder(input);
  std::error_code ec;
  fs::create_directories(report.folder, ec);
  if (ec) throw Error("cannot create the run folder: " + ec.message(), report.folder.string());
  const fs::path config_file = report.folder / "config.yaml";
  const ExperimentConfig config = SettleRunConfig(input, config_file);
  report.seed = *config.seed;
  const std::string hash = DataConfigHashHex(config);
  if (!fs::exists(config_file)) {
    WriteFileAtomic(config_file, "# mlspaces datagen run; data hash " + hash + "\n" +
                                     DumpConfig(config));
  }
  const std::vector<WorkItem> items = PlanWorkItems(config);

  Registry registry(Registry::Options{config.libraries.assets_dir});
  config.libraries.ApplyTo(registry);
  std::unique_ptr<TaskSampler> sampler = samplers.Create(config, report.seed);

  const fs::path journal_file = report.folder / "journal.jsonl";
  Journal journal(journal_file);
  const std::vector<AttemptRecord> earlier = ReadJournal(journal_file).records;

  int64_t total_episodes = 0;
  for (const WorkItem& item : items) total_episodes += item.episodes;
  ProgressBar bar("datagen", static_cast<size_t>(total_episodes),
                  options.progress && isatty(STDERR_FILENO) != 0);
  int64_t done_episodes = 0;
  std::vector<AttemptRecord> attempts;

  // One env per scene, kept while consecutive items use it.
  std::optional<Env> env;
  std::unique_ptr<EpisodeRunner> runner;
  int64_t env_house = -1;

  for (const WorkItem& item : items) {
    const std::string scene = item.scene_name();
    RecorderOptions rec_options;
    rec_options.dir = report.folder / scene;
    rec_options.batch = item.batch;
    rec_options.num_batches = item.num_batches;
    Recorder recorder(rec_options);
    if (fs::exists(recorder.batch_file())) {
      ++report.items_skipped;
      done_episodes += item.episodes;
      bar.Update(static_cast<size_t>(done_episodes));
      log(LogLevel::kInfo, scene + " batch " + std::to_string(item.batch) + "/" +
                               std::to_string(item.num_batches) + ": already done, skipped");
      continue;
    }
    // Resume after the last journaled attempt of this item.
    int64_t next = 0;
    for (const AttemptRecord& r : earlier) {
      if (r.scene == scene && r.episode >= item.first_episode &&
          r.episode < item.first_episode + item.max_attempts) {
        next = std::max(next, r.episode - item.first_episode + 1);
      }
    }
    int64_t kept = recorder.next_index();
    done_episodes += std::min(kept, item.episodes);
    if (next > 0 || kept > 0) {
      log(LogLevel::kInfo, scene + " batch " + std::to_string(item.batch) + ": resuming at attempt " +
                               std::to_string(next) + " with " + std::to_string(kept) +
                               " episodes kept");
    }
    if (env_house != item.house) {
      runner.reset();
      env.reset();
      env.emplace(Env::Create(sim::Scene::Load(item.scene_xml),
                              RobotSpecFromConfig(config.robot_config), scene));
      EpisodeRunnerOptions runner_options;
      runner_options.scene_name = scene;
      runner = std::make_unique<EpisodeRunner>(*env, *sampler, registry, config, runner_options);
      env_house = item.house;
    }
    int64_t sequential_rejects = 0;
    for (int64_t a = next; kept < item.episodes && a < item.max_attempts; ++a) {
      const auto t0 = Clock::now();
      EpisodeResult result = runner->Run(item.first_episode + a);
      report.policy_steps += result.policy_steps;
      report.physics_steps += result.physics_steps;
      journal.Append(result.attempt);
      attempts.push_back(result.attempt);
      const bool keep = result.success || !config.filter_for_successful_trajectories;
      if (keep && result.record) {
        recorder.Write(*result.record);
        ++kept;
        ++done_episodes;
        bar.Update(static_cast<size_t>(done_episodes));
      }
      if (options.on_attempt) options.on_attempt(item, result.attempt);
      const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      std::string line = scene + " batch " + std::to_string(item.batch) + "/" +
                         std::to_string(item.num_batches) + " episode " +
                         std::to_string(item.first_episode + a) + ": " +
                         std::string(OutcomeName(result.attempt.outcome));
      if (!result.attempt.message.empty()) line += " (" + result.attempt.message + ")";
      char buf[64];
      std::snprintf(buf, sizeof buf, " in %.2f s, kept %lld/%lld", seconds,
                    static_cast<long long>(kept), static_cast<long long>(item.episodes));
      log(LogLevel::kDebug, line + buf);
      if (result.attempt.outcome == Outcome::kSamplerReject) {
        if (++sequential_rejects >=
            config.task_sampler_config.max_allowed_sequential_task_sampler_failures) {
          log(LogLevel::kWarning, scene + ": the task sampler rejected " +
                                      std::to_string(sequential_rejects) +
                                      " tasks in a row; giving up on this batch");
          break;
        }
      } else {
        sequential_rejects = 0;
      }
    }
    if (kept < item.episodes) {
      log(LogLevel::kWarning, scene + " batch " + std::to_string(item.batch) + ": kept " +
                                  std::to_string(kept) + " of " + std::to_string(item.episodes) +
                                  " episodes within " + std::to_string(item.max_attempts) +
                                  " attempts");
    }
    if (recorder.Finish()) {
      report.batch_files.push_back(recorder.batch_file());
      log(LogLevel::kInfo, "wrote " + recorder.batch_file().string() + " (" +
                               std::to_string(kept) + " episodes)");
    }
    report.episodes_kept += kept;
  }
  bar.Finish();
  report.summary = Summarize(attempts);
  // summary.txt covers the whole run, earlier invocations included.
  WriteFileAtomic(report.folder / "summary.txt",
                  "data hash " + hash + ", seed " + std::to_string(report.seed) + "\n" +
                      FormatSummary(Summarize(ReadJournal(journal_file).records)));
  report.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  return report;
}

}  // namespace mlspaces::datagen
