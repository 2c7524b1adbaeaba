// mlspaces datagen CONFIG [--set KEY=VALUE]... [--seed S] [--episodes N] [--output DIR]
//   [--resume] [--workers N] [--shard I/N] [--license-policy P] [-q]: generates pick demonstrations
// (datagen/run.h) and prints the run's summary.
// mlspaces merge OUTPUT RUN_DIR... [--partial]: combines the folders of a sharded run.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/library/license_policy.h"

namespace mlspaces::cli {
namespace {

struct RunFlags {
  bool quiet = false;
  bool resume = false;
  int workers = 0;
  std::string shard;
  std::string gl;
  std::string license_policy;
  std::string format = "hdf5";
};

// --workers W runs work items in parallel, never the episodes of one item: says so (one
// line) when the run has fewer items than W, with the knob that splits them. The split is
// left as it is: it decides the batch files, so the dataset's bytes.
void WarnIfWorkersCannotHelp(const datagen::ExperimentConfig& config, const datagen::Shard& shard,
                             int workers) {
  const std::vector<datagen::WorkItem> items =
      datagen::ShardItems(datagen::PlanWorkItems(config), shard);
  if (static_cast<int64_t>(items.size()) >= workers) return;
  int64_t episodes = 0;
  std::set<int64_t> houses;
  for (const datagen::WorkItem& item : items) {
    episodes += item.episodes;
    houses.insert(item.house);
  }
  const datagen::TaskSamplerConfig& s = config.task_sampler_config;
  // Batches per scene for W items, and the episodes_per_batch that gives them.
  const int64_t scenes = std::max<int64_t>(1, static_cast<int64_t>(houses.size()));
  const int64_t batches = (workers + scenes - 1) / scenes;
  const int64_t per_batch = std::max<int64_t>(1, s.samples_per_house / batches);
  std::string text = "all " + std::to_string(episodes) + " episodes are in " +
                     std::to_string(items.size()) + " work item" + (items.size() == 1 ? "" : "s") +
                     "; --workers " + std::to_string(workers) + " cannot run " +
                     (items.size() == 1 ? "them in parallel"
                                        : "more than " + std::to_string(items.size()) + " at once");
  const int64_t items_per_scene = static_cast<int64_t>(items.size()) / scenes;
  if (per_batch < s.episodes_per_batch && s.samples_per_house > items_per_scene) {
    text += " (a work item is a batch of up to task_sampler_config.episodes_per_batch = " +
            std::to_string(s.episodes_per_batch) + " episodes of one scene; --set " +
            "task_sampler_config.episodes_per_batch=" + std::to_string(per_batch) +
            " splits them, into other batch files)";
  }
  Warn(text);
}

int Run(const DatagenConfigFlags& flags, const RunFlags& run) {
  const bool quiet = run.quiet;
  const datagen::ConfigRegistry configs = datagen::ConfigRegistry::WithBuiltins();
  datagen::ExperimentConfig config = flags.Resolve(configs);
  if (!run.license_policy.empty()) {
    config.license_policy = ParseLicensePolicy(run.license_policy, "--license-policy");
  }
  const bool tty = isatty(STDERR_FILENO) != 0;
  datagen::RunOptions options;
  options.progress = !quiet;
  options.resume = run.resume;
  options.workers = run.workers;
  if (!run.shard.empty()) options.shard = datagen::ParseShard(run.shard);
  options.gl_backend = sim::ResolveGlBackend(run.gl, "--gl");
  options.log = [&](datagen::LogLevel level, const std::string& line) {
    if (quiet && level < datagen::LogLevel::kWarning) return;
    // On a terminal the progress bar shows the per-episode progress.
    if (tty && !quiet && level == datagen::LogLevel::kDebug) return;
    const char* tag = level >= datagen::LogLevel::kWarning ? "warning: " : "";
    // Clear a progress bar line before printing; UIDs and file names from input escaped.
    std::fprintf(stderr, "%smlspaces: %s%s\n", tty ? "\r\033[K" : "", tag, Printable(line).c_str());
  };
  // --format lerobot: no HDF5; the episodes' records go to a staging folder, written as the
  // LeRobot dataset at the end (lerobot_datagen.cc).
  std::filesystem::path lerobot_out;
  if (run.format == "lerobot") {
#ifdef MLSPACES_HAVE_LEROBOT
    options.hdf5 = false;
    lerobot_out = PrepareLeRobotRun(config, options.shard, options.resume);
    if (lerobot_out.empty()) {
      std::printf("run folder: %s (LeRobot v3.0): already complete\n",
                  datagen::RunFolder(config).c_str());
      return 0;
    }
#else
    throw Error("this mlspaces was built without Arrow C++, so it has no --format lerobot",
                "--format");
#endif
  }
  if (run.workers > 1) WarnIfWorkersCannotHelp(config, options.shard, run.workers);
  const datagen::RunReport report =
      datagen::RunDatagen(config, datagen::TaskSamplerRegistry::WithBuiltins(), options);
#ifdef MLSPACES_HAVE_LEROBOT
  if (!lerobot_out.empty()) FinishLeRobotRun(report.folder, lerobot_out);
#endif
  std::printf("run folder: %s%s\nseed: %llu\n",
              lerobot_out.empty() ? report.folder.c_str() : lerobot_out.c_str(),
              lerobot_out.empty() ? "" : " (LeRobot v3.0)",
              static_cast<unsigned long long>(report.seed));
  if (report.items_skipped > 0) {
    std::printf("work items already done: %lld\n", static_cast<long long>(report.items_skipped));
  }
  std::printf("episodes kept: %lld in %.1f s (%lld policy steps, %lld physics steps)\n",
              static_cast<long long>(report.episodes_kept), report.seconds,
              static_cast<long long>(report.policy_steps),
              static_cast<long long>(report.physics_steps));
  std::printf("%s", datagen::FormatSummary(report.summary).c_str());
  return 0;
}

int Merge(const std::string& output, const std::vector<std::string>& inputs, bool partial) {
#ifdef MLSPACES_HAVE_LEROBOT
  if (MergeLeRobot(output, inputs, partial)) return 0;  // LeRobot datasets (meta/info.json)
#endif
  std::vector<std::filesystem::path> dirs(inputs.begin(), inputs.end());
  const datagen::MergeReport r = datagen::MergeRuns(dirs, output, partial);
  std::printf("merged %zu folders into %s: %lld batch files, %lld episodes, %lld attempts\n",
              dirs.size(), output.c_str(), static_cast<long long>(r.batch_files),
              static_cast<long long>(r.episodes), static_cast<long long>(r.attempts));
  for (const std::string& m : r.missing) Warn("not finished in any input: " + m);
  return 0;
}

}  // namespace

void AddDatagen(CLI::App& app, Action& action) {
  auto flags = std::make_shared<DatagenConfigFlags>();
  auto run = std::make_shared<RunFlags>();
  CLI::App* sub = app.add_subcommand(
      "datagen", "Generate pick demonstrations: trajectories, attempt journal and summary");
  flags->AddTo(*sub);
  sub->add_flag("-q,--quiet", run->quiet, "Only warnings and errors on stderr, no progress bar");
  sub->add_flag("--resume", run->resume,
                "Continue the run in the output folder (after a kill or a crash)");
  sub->add_option("--workers", run->workers, "Worker processes (default: num_workers)")
      ->type_name("N")
      ->check(PositiveInteger());
  sub->add_option("--shard", run->shard,
                  "Run only shard I of N (work item k belongs to shard k % N); needs a seed")
      ->type_name("I/N");
  sub->add_option("--gl", run->gl,
                  "Headless GL for the cameras: osmesa (default) or egl; default from MLSPACES_GL")
      ->type_name("osmesa|egl");
  sub->add_option("--license-policy", run->license_policy,
                  "Which assets the run may use: all, or commercial_safe (no by-nc / by-nc-sa "
                  "asset; scenes holding one are refused). Overrides the config's "
                  "license_policy; default from MLSPACES_LICENSE_POLICY, else all")
      ->type_name("all|commercial_safe");
  sub->add_option("--format", run->format,
                  "hdf5: HDF5 + MP4 (default); lerobot: a LeRobot v3.0 dataset, the same bytes "
                  "as export-lerobot of the hdf5 run (docs/lerobot.md)")
      ->check(CLI::IsMember({"hdf5", "lerobot"}));
  sub->callback([&action, flags, run] { action = [flags, run] { return Run(*flags, *run); }; });

  auto output = std::make_shared<std::string>();
  auto inputs = std::make_shared<std::vector<std::string>>();
  auto partial = std::make_shared<bool>(false);
  CLI::App* merge = app.add_subcommand(
      "merge", "Combine the run folders of a sharded datagen run into one dataset");
  merge->add_option("OUTPUT", *output, "The merged run folder (must not hold a run)")->required();
  merge->add_option("RUN_DIR", *inputs, "Shard run folders")->required();
  merge->add_flag("--partial", *partial, "Merge even when some batches are not finished");
  merge->callback([&action, output, inputs, partial] {
    action = [output, inputs, partial] { return Merge(*output, *inputs, *partial); };
  });
}

}  // namespace mlspaces::cli
