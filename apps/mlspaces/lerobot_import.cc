// mlspaces import-lerobot LEROBOT_DIR OUT_DIR [-q]: a LeRobot dataset that mlspaces wrote back
// into the HDF5 + MP4 dataset (datagen/lerobot/import.h, docs/lerobot.md). Like
// export-lerobot, built into `mlspaces` (which execs the helper) and into mlspaces-lerobot.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/error.h"
#ifdef MLSPACES_LEROBOT_HELPER
#include "mlspaces/core/progress.h"
#include "mlspaces/datagen/lerobot/import.h"
#endif

namespace mlspaces::cli {
namespace {

struct Flags {
  std::string dir, out;
  bool quiet = false;
};

#ifndef MLSPACES_LEROBOT_HELPER
int Run(const Flags& flags) {
  std::vector<std::string> args = {"import-lerobot", flags.dir, flags.out};
  if (flags.quiet) args.emplace_back("-q");
  ExecLeRobotHelper(args);
}
#else
int Run(const Flags& flags) {
  ProgressStyle style;
  style.enabled = !flags.quiet;
  style.lines_when_not_tty = true;
  style.unit = "files";
  std::unique_ptr<ProgressBar> bar;
  auto progress = [&](int64_t done, int64_t total) {
    if (!bar) {
      bar = std::make_unique<ProgressBar>("import-lerobot", static_cast<size_t>(total), style);
      bar->Start(0, "starting");
    }
    bar->Update(static_cast<size_t>(done));
  };
  const datagen::lerobot::ImportReport r =
      datagen::lerobot::ImportLeRobot(flags.dir, flags.out, progress);
  if (bar) bar->Finish();
  std::printf("%s: %lld episodes in %lld batch files, %lld videos\n", flags.out.c_str(),
              static_cast<long long>(r.episodes), static_cast<long long>(r.batch_files),
              static_cast<long long>(r.videos));
  return 0;
}
#endif

}  // namespace

void AddImportLeRobot(CLI::App& app, Action& action) {
  auto flags = std::make_shared<Flags>();
  CLI::App* sub = app.add_subcommand(
      "import-lerobot",
      "Write a LeRobot dataset made by mlspaces back as the HDF5 + MP4 dataset it came from");
  sub->add_option("LEROBOT_DIR", flags->dir,
                  "A LeRobot v3.0 dataset written by export-lerobot or datagen --format lerobot")
      ->required();
  sub->add_option("OUT_DIR", flags->out, "The dataset folder to create (must not exist)")
      ->required();
  sub->add_flag("-q,--quiet", flags->quiet, "No progress bar");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
