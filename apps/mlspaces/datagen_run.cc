// mlspaces datagen CONFIG [--set KEY=VALUE]... [--seed S] [--episodes N] [--output DIR]:
// generates pick demonstrations (datagen/run.h) and prints the run's summary.
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/datagen/run.h"

namespace mlspaces::cli {
namespace {

int Run(const DatagenConfigFlags& flags, bool quiet) {
  const datagen::ConfigRegistry configs = datagen::ConfigRegistry::WithBuiltins();
  const datagen::ExperimentConfig config = flags.Resolve(configs);
  const bool tty = isatty(STDERR_FILENO) != 0;
  datagen::RunOptions options;
  options.progress = !quiet;
  options.log = [&](datagen::LogLevel level, const std::string& line) {
    if (quiet && level < datagen::LogLevel::kWarning) return;
    // On a terminal the progress bar shows the per-episode progress.
    if (tty && !quiet && level == datagen::LogLevel::kDebug) return;
    const char* tag = level >= datagen::LogLevel::kWarning ? "warning: " : "";
    // Clear a progress bar line before printing.
    std::fprintf(stderr, "%smlspaces: %s%s\n", tty ? "\r\033[K" : "", tag, line.c_str());
  };
  const datagen::RunReport report =
      datagen::RunDatagen(config, datagen::TaskSamplerRegistry::WithBuiltins(), options);
  std::printf("run folder: %s\nseed: %llu\n", report.folder.c_str(),
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

}  // namespace

void AddDatagen(CLI::App& app, Action& action) {
  auto flags = std::make_shared<DatagenConfigFlags>();
  auto quiet = std::make_shared<bool>(false);
  CLI::App* sub = app.add_subcommand(
      "datagen", "Generate pick demonstrations: trajectories, attempt journal and summary");
  flags->AddTo(*sub);
  sub->add_flag("-q,--quiet", *quiet, "Only warnings and errors on stderr, no progress bar");
  sub->callback([&action, flags, quiet] { action = [flags, quiet] { return Run(*flags, *quiet); }; });
}

}  // namespace mlspaces::cli
