// mlspaces index-grasps: writes <DIR>/grasps_index.json (MolmoSpaces'
// generate_user_grasp_library_index).
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/library/grasp_index.h"

namespace mlspaces::cli {
namespace {

struct IndexGraspsFlags {
  std::string dir;
  std::string output;
  bool overwrite = false;
};

int Run(const IndexGraspsFlags& flags) {
  GraspIndexOptions options;
  options.output = flags.output;
  options.overwrite = flags.overwrite;
  IndexReport report = WriteGraspIndex(flags.dir, options);
  std::printf("Wrote %s with %zu robots / %zu grasp files.\n", report.output.c_str(), report.robots,
              report.count);
  return 0;
}

}  // namespace

void AddIndexGrasps(CLI::App& app, Action& action) {
  auto flags = std::make_shared<IndexGraspsFlags>();
  CLI::App* sub = app.add_subcommand(
      "index-grasps",
      "Index a grasp library: <uid>/<robot>/grasps.npz and joint_grasps_<joint>.npz -> "
      "grasps_index.json");
  sub->add_option("DIR", flags->dir, "Grasp library folder")->required();
  sub->add_option("-o,--output", flags->output, "Output file (default: DIR/grasps_index.json)");
  sub->add_flag("--overwrite", flags->overwrite, "Replace an existing output file");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
