// mlspaces generate-grasps LIBRARY_DIR [--uid UID...] [--robot droid|xarm7|NAME] [--joints]
//   [--max-grasps N] [--seed S] [-j N] [--overwrite] [--min-quality Q] [--dtype f2|f8] [-o DIR]
//   [-q]:
// stable grasps for the objects of an asset library (docs/graspgen.md), written as
// <uid>/<robot>/grasps.npz or joint_grasps_<joint>.npz, then grasps_index.json.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/graspgen/generate.h"

namespace mlspaces::cli {
namespace {

struct GenerateGraspsFlags {
  graspgen::GenerateOptions options;
  std::string library_dir;
  std::string output;
  std::string dtype = "f2";
  size_t max_grasps = 1000;
  int threads = 0;
  bool quiet = false;
};

int Run(GenerateGraspsFlags& flags) {
  graspgen::GenerateOptions& options = flags.options;
  options.library_dir = flags.library_dir;
  options.output_dir = flags.output;
  options.max_grasps = flags.max_grasps;
  options.threads = flags.threads;
  options.float64 = flags.dtype == "f8";
  options.progress = !flags.quiet;
  graspgen::GenerateReport report =
      graspgen::GenerateGrasps(options, [&](const graspgen::ObjectReport& object) {
        std::FILE* out = object.status == graspgen::ObjectReport::Status::kFailed ? stderr : stdout;
        if (flags.quiet && out == stdout) return;
        std::fprintf(out, "%s\n", graspgen::ObjectReportLine(object).c_str());
        std::fflush(out);
      });
  const char* what = options.joints ? "joints" : "objects";
  // --joints also skips objects without a hinge or slide joint (their line says so).
  const char* skipped = options.joints ? "existing, or no joint" : "existing";
  std::printf("generate-grasps: %zu %s done, %zu skipped (%s), %zu failed", report.done(), what,
              report.skipped(), skipped, report.failed());
  if (!report.index.empty()) std::printf("; wrote %s", report.index.string().c_str());
  std::printf("\n");
  return report.failed() > 0 ? 1 : 0;
}

}  // namespace

void AddGenerateGrasps(CLI::App& app, Action& action) {
  auto flags = std::make_shared<GenerateGraspsFlags>();
  CLI::App* sub = app.add_subcommand(
      "generate-grasps",
      "Generate stable grasps for an asset library's objects (pickup, or --joints for each "
      "hinge/slide joint) -> <uid>/<robot>/grasps.npz, joint_grasps_<joint>.npz, "
      "grasps_index.json");
  sub->add_option("LIBRARY_DIR", flags->library_dir,
                  "Asset library folder (assets_index.json, or <uid>/<uid>.xml + <uid>.json)")
      ->required();
  sub->add_option("--uid", flags->options.uids, "Only these objects (repeatable)")
      ->take_all()
      ->expected(1, -1);
  sub->add_option("--robot", flags->options.robot,
                  "Robot whose gripper grasps, and the grasp-library folder: droid (franka_droid's "
                  "gripper, the default), xarm7, or a robot on $MLSPACES_ROBOT_PATH");
  sub->add_flag("--joints", flags->options.joints,
                "Joint grasps of each hinge/slide joint instead of pickup grasps");
  sub->add_option("--max-grasps", flags->max_grasps, "Grasps kept per object or joint (1000)")
      ->check(PositiveInteger());
  AddSeedOption(
      *sub, [flags](uint64_t seed) { flags->options.seed = seed; },
      "Seed (default 0); same seed, same files");
  sub->add_option("-j,--threads", flags->threads, "Threads (default: all cores)")
      ->check(PositiveInteger());
  sub->add_flag("--overwrite", flags->options.overwrite,
                "Regenerate objects whose grasp file exists (default: skip them)");
  sub->add_option("--min-quality", flags->options.candidates.min_quality,
                  "Antipodal quality a candidate needs, the cosine between each contact normal "
                  "and the closing line (0.005, the original's; 0.9: near-perpendicular contacts)");
  sub->add_option("--dtype", flags->dtype, "f2 (float16, like the original's files) or f8")
      ->check(CLI::IsMember({"f2", "f8"}));
  sub->add_option("-o,--output", flags->output, "Grasp library folder (default: LIBRARY_DIR)");
  sub->add_flag("-q,--quiet", flags->quiet, "No progress bars and no lines for finished objects");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
