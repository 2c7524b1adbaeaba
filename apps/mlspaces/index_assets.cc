// mlspaces index-assets: writes <DIR>/assets_index.json (MolmoSpaces'
// generate_user_asset_library_index).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/library/asset_index.h"
#ifdef MLSPACES_HAVE_SIM
#include "mlspaces/sim/compute_metadata.h"
#endif

namespace mlspaces::cli {
namespace {

struct IndexAssetsFlags {
  std::string dir;
  std::string output;
  bool overwrite = false;
  bool suppress_missing_metadata = false;
  bool compute_metadata = false;
};

// ---- --compute-metadata ------------------------------------------------------------------
// Mass and bounding box come from the compiled model (spec 4.2), which needs MuJoCo: the sim
// layer computes them on all cores. A build without the sim layer refuses the flag.
int RunComputeMetadata(const IndexAssetsFlags& flags) {
#ifdef MLSPACES_HAVE_SIM
  AssetIndexOptions options;
  options.output = flags.output;
  options.overwrite = flags.overwrite;
  options.suppress_missing_metadata = flags.suppress_missing_metadata;
  std::unique_ptr<ProgressBar> bar;
  sim::ComputeMetadataOptions compute;
  compute.progress = [&bar](size_t done, size_t total) {
    if (!bar) bar = std::make_unique<ProgressBar>("compute-metadata", total);
    bar->Update(done);
  };
  sim::ComputeMetadataReport report = sim::ComputeAssetMetadata(flags.dir, options, compute);
  if (bar) bar->Finish();
  for (const Diagnostic& warning : report.index.warnings) {
    std::fprintf(stderr, "%s\n", IndexWarningLine(warning).c_str());
  }
  // One line per failed asset (file, field, reason); those assets are not in the index.
  for (const sim::AssetFailure& failure : report.failures) {
    std::fprintf(stderr, "mlspaces: error: %s\n", failure.ToString().c_str());
  }
  for (const std::filesystem::path& removed : report.removed) {
    std::fprintf(stderr, "mlspaces: removed %s (written by an earlier run; its asset failed)\n",
                 removed.c_str());
  }
  std::printf("Computed metadata: %zu assets (%zu computed, %zu reused, %zu failed).\n",
              report.computed + report.reused, report.computed, report.reused,
              report.failures.size());
  if (report.failures.empty()) {
    std::printf("Wrote %s with %zu assets.\n", report.index.output.c_str(), report.index.count);
    return 0;
  }
  std::printf("Wrote %s with %zu assets, leaving out the %zu that failed.\n",
              report.index.output.c_str(), report.index.count, report.failures.size());
  return 1;
#else
  (void)flags;
  throw UsageError("--compute-metadata needs the sim layer (build with MLSPACES_BUILD_SIM=ON)");
#endif
}
// -------------------------------------------------------------------------------------------

int Run(const IndexAssetsFlags& flags) {
  if (flags.compute_metadata) return RunComputeMetadata(flags);
  AssetIndexOptions options;
  options.output = flags.output;
  options.overwrite = flags.overwrite;
  options.suppress_missing_metadata = flags.suppress_missing_metadata;
  IndexReport report = WriteAssetIndex(flags.dir, options);
  for (const Diagnostic& warning : report.warnings) {
    std::fprintf(stderr, "%s\n", IndexWarningLine(warning).c_str());
  }
  std::printf("Wrote %s with %zu assets.\n", report.output.c_str(), report.count);
  return 0;
}

}  // namespace

void AddIndexAssets(CLI::App& app, Action& action) {
  auto flags = std::make_shared<IndexAssetsFlags>();
  CLI::App* sub = app.add_subcommand(
      "index-assets", "Index an asset library: <uid>.xml + <uid>.json -> assets_index.json");
  sub->add_option("DIR", flags->dir, "Asset library folder")->required();
  sub->add_option("-o,--output", flags->output, "Output file (default: DIR/assets_index.json)");
  sub->add_flag("--overwrite", flags->overwrite, "Replace an existing output file");
  sub->add_flag("--suppress-missing-metadata", flags->suppress_missing_metadata,
                "Skip XMLs without a sibling <uid>.json, with a warning");
  sub->add_flag("--compute-metadata", flags->compute_metadata,
                "Fill in missing mass and boundingBox into <uid>_computed.json (needs MuJoCo); "
                "assets that fail are left out of the index (exit 1)");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
