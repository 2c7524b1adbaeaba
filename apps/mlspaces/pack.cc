// mlspaces pack LIBRARY_DIR OUT_DIR: publish a user library as a versioned package.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/resources/pack.h"

namespace mlspaces::cli {
namespace {

struct PackFlags {
  std::string library_dir, out_dir;
  PackOptions options;
  std::string grasp_dir;
  bool quiet = false;
};

int Run(PackFlags& flags) {
  flags.options.grasp_dir = flags.grasp_dir;
  ProgressBar bar("pack", 0, !flags.quiet);
  flags.options.progress = [&](size_t done, size_t total) {
    (void)total;
    bar.Update(done);
  };
  // The bar's total is only known once the library is read; PackLibrary reports it per step.
  const PackReport r = PackLibrary(flags.library_dir, flags.out_dir, flags.options);
  bar.Finish();
  for (const Diagnostic& w : r.warnings) Warn(w.ToString());
  std::printf(
      "Packed %zu assets (%zu grasps in %zu sets) into %zu archives: %.1f MB "
      "(%.1f MB unpacked)\n",
      r.assets, r.grasps, r.grasp_sets, r.archives, r.archive_bytes / 1e6, r.unpacked_bytes / 1e6);
  std::printf("package: %s\n", r.package_dir.c_str());
  std::printf(
      "Serve %s (or use it as a file:// remote) and run:\n"
      "  MLSPACES_REMOTE_URL=<its URL> mlspaces install --library %s\n",
      flags.out_dir.c_str(), r.name.c_str());
  return 0;
}

}  // namespace

void AddPack(CLI::App& app, Action& action) {
  auto flags = std::make_shared<PackFlags>();
  CLI::App* sub =
      app.add_subcommand("pack",
                         "Publish a user asset + grasp library as a versioned package (archives, "
                         "manifest with SHA-256s, UID index, metadata and grasp stores)");
  sub->add_option("LIBRARY_DIR", flags->library_dir, "Asset library (with assets_index.json)")
      ->required();
  sub->add_option("OUT_DIR", flags->out_dir,
                  "Remote root to write into: OUT_DIR/<type>/<name>/<version>/")
      ->required();
  sub->add_option("--name", flags->options.name, "Source name (default: the folder's name)");
  sub->add_option("--version", flags->options.version, "Version (default: today, YYYYMMDD)");
  sub->add_option("--grasps", flags->grasp_dir,
                  "Grasp library folder (default: LIBRARY_DIR when it has grasps_index.json)");
  sub->add_option("--assets-per-archive", flags->options.assets_per_archive,
                  "Assets per .tar.zst archive (default 1: install fetches one asset each)")
      ->check(PositiveInteger());
  sub->add_option("--zstd-level", flags->options.zstd_level, "zstd level 1-19 (default 3)")
      ->check(CLI::Range(1, 19));
  sub->add_option("-j,--threads", flags->options.threads, "Threads (default: all cores)")
      ->check(PositiveInteger());
  sub->add_flag("--overwrite", flags->options.overwrite, "Replace an existing version");
  sub->add_flag("-q,--quiet", flags->quiet, "No progress bar");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
