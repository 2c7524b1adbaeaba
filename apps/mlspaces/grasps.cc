// mlspaces grasps UID: find and load the pickup (or joint) grasps of a UID.
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/npz.h"

namespace mlspaces::cli {
namespace {

constexpr size_t kPrintAll = 8;  // more grasps than this: print the first few only
constexpr size_t kPrintFirst = 3;

struct GraspsFlags {
  std::string uid;
  std::string robot;
  std::string joint;
  size_t num = 0;  // 0: all
  uint64_t seed = 0;
  std::string out;
  LibraryFlags libraries;
};

/// The grasp libraries to walk: all (empty filter), or those whose robot is `robot`.
std::vector<std::string> RobotFilter(const Registry& registry, const std::string& uid,
                                     const std::string& robot) {
  std::vector<std::string> filter;
  if (robot.empty()) return filter;
  std::vector<std::string> candidates = registry.GraspLibrariesFor(uid);
  if (candidates.empty()) {
    // A UID in no asset library (joint grasps of iTHOR articulated objects): every library.
    for (const std::string& asset_lib : registry.asset_libraries()) {
      for (const std::string& lib : registry.grasp_libraries_of(asset_lib)) {
        candidates.push_back(lib);
      }
    }
  }
  for (const std::string& name : candidates) {
    const GraspLibraryInfo* info = registry.FindGraspLibrary(name);
    if (info != nullptr && info->robot == robot) filter.push_back(name);
  }
  if (filter.empty()) {
    throw Error("no grasp library for robot " + robot + " serves " + uid, "", "", uid);
  }
  return filter;
}

void PrintPose(const Mat4& pose) {
  for (int r = 0; r < 4; ++r) {
    std::printf("  ");
    for (int c = 0; c < 4; ++c) std::printf("%s% .6f", c == 0 ? "" : " ", pose(r, c));
    std::printf("\n");
  }
}

int Run(const GraspsFlags& flags) {
  const Registry registry = flags.libraries.Build();
  const bool joint = !flags.joint.empty();
  if (!joint) registry.LocateOrThrow(flags.uid);  // unknown UID: name every library
  const size_t num = flags.num == 0 ? std::numeric_limits<size_t>::max() : flags.num;
  const auto [file, grasps] =
      FindAndLoadGrasps(registry, flags.uid, flags.joint, flags.robot, num, flags.seed);
  std::printf("library: %s\npath: %s\n", file.library.c_str(), grasps.source.c_str());
  std::printf("count: %zu (stored %s)\n", grasps.poses.size(),
              DTypeDescr(grasps.stored_dtype).c_str());
  const size_t shown = grasps.poses.size() <= kPrintAll ? grasps.poses.size() : kPrintFirst;
  for (size_t i = 0; i < shown; ++i) {
    std::printf("grasp %zu (row %zu):\n", i, grasps.indices[i]);
    PrintPose(grasps.poses[i]);
  }
  if (shown < grasps.poses.size()) {
    std::printf("... %zu more (use --out FILE.npz for all)\n", grasps.poses.size() - shown);
  }
  if (!flags.out.empty()) {
    std::vector<double> values;
    values.reserve(grasps.poses.size() * 16);
    for (const Mat4& pose : grasps.poses) values.insert(values.end(), pose.m.begin(), pose.m.end());
    WriteNpz(flags.out,
             {{"transforms", NpyArray::FromDoubles({grasps.poses.size(), 4, 4}, values)}});
    std::printf("wrote %s (%zu grasps)\n", flags.out.c_str(), grasps.poses.size());
  }
  return 0;
}

}  // namespace

FoundGrasps FindAndLoadGrasps(const Registry& registry, const std::string& uid,
                              const std::string& joint, const std::string& robot, size_t num,
                              uint64_t seed) {
  GraspQuery query{uid, joint, RobotFilter(registry, uid, robot)};
  std::optional<GraspFileLocation> file = registry.FindGraspFile(query);
  if (!file) {
    throw Error(joint.empty() ? "No grasp file found for " + uid
                              : "No joint grasp file found for " + uid + "/" + joint,
                "", "", uid);
  }
  // Load from the file found, so the library named is the one used.
  query.libraries = {file->library};
  GraspSet grasps = registry.LoadGrasps(query, num, seed);
  return {std::move(*file), std::move(grasps)};
}

void AddGrasps(CLI::App& app, Action& action) {
  auto flags = std::make_shared<GraspsFlags>();
  CLI::App* sub = app.add_subcommand(
      "grasps", "Find and load the pickup (or --joint) grasps of a UID, in its body frame");
  sub->add_option("UID", flags->uid, "Asset UID")->required();
  sub->add_option("--robot", flags->robot,
                  "Only user grasp libraries for this robot (the <robot> of NAME/<robot>)");
  sub->add_option("--joint", flags->joint, "Joint grasps for this joint (name in the asset MJCF)");
  sub->add_option("--num", flags->num, "Subsample N distinct grasps (default: all)")
      ->check(PositiveInteger());
  AddSeedOption(
      *sub, [flags](uint64_t seed) { flags->seed = seed; }, "Seed of the subsampling (default 0)");
  sub->add_option("--out", flags->out, "Write the grasps as an (n,4,4) float64 NPZ")
      ->type_name("FILE.npz");
  flags->libraries.AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
