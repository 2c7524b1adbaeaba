// mlspaces validate: deep checks of an asset and/or grasp library folder, and (with the sim
// layer) a compile of every indexed asset.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/library/validate.h"
#ifdef MLSPACES_HAVE_SIM
#include "mlspaces/sim/compute_metadata.h"
#endif

namespace mlspaces::cli {
namespace {

struct ValidateFlags {
  std::string dir;
  bool no_compile = false;
  int threads = 0;
};

int Run(const ValidateFlags& flags) {
  std::vector<Problem> problems = ValidateLibrary(flags.dir);
#ifdef MLSPACES_HAVE_SIM
  if (!flags.no_compile) {
    std::unique_ptr<ProgressBar> bar;
    sim::ComputeMetadataOptions compile;
    compile.threads = flags.threads;
    compile.progress = [&bar](size_t done, size_t total) {
      if (!bar) bar = std::make_unique<ProgressBar>("compile", total);
      bar->Update(done);
    };
    std::vector<Problem> failed = sim::CompileLibraryAssets(flags.dir, compile);
    if (bar) bar->Finish();
    problems.insert(problems.end(), failed.begin(), failed.end());
  }
#endif
  for (const Problem& problem : problems) std::printf("%s\n", problem.ToString().c_str());
  if (problems.empty()) {
    std::printf("%s: OK\n", flags.dir.c_str());
    return 0;
  }
  std::printf("%zu problems in %s\n", problems.size(), flags.dir.c_str());
  return 1;
}

}  // namespace

void AddValidate(CLI::App& app, Action& action) {
  auto flags = std::make_shared<ValidateFlags>();
  CLI::App* sub = app.add_subcommand(
      "validate",
      "Check a library folder: index entries, files, metadata types, computed files against "
      "their sources, grasp poses, and that every asset compiles");
  sub->add_option("LIBRARY_DIR", flags->dir,
                  "Library folder (with assets_index.json and/or "
                  "grasps_index.json)")
      ->required();
  sub->add_flag("--no-compile", flags->no_compile,
                "Skip compiling each asset's MJCF with MuJoCo (the slow part on big libraries)");
  sub->add_option("-j,--threads", flags->threads, "Compile threads (default: all cores)")
      ->check(PositiveInteger());
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
