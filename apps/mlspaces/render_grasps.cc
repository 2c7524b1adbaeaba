// mlspaces render grasps UID [--joint J]: the asset with its pickup (or joint) grasps drawn as
// gripper outlines, from several views.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/robots/robot_spec.h"
#include "render.h"

namespace mlspaces::cli {
namespace {

struct GraspsFlags {
  std::string uid;
  std::string robot;
  std::string joint;
  std::string gripper = "franka_droid";
  size_t num = 20;
  uint64_t seed = 0;
  int views = 4;
  LibraryFlags libraries;
  RenderFlags render;
};

int Run(const GraspsFlags& flags) {
  const sim::PictureOptions options = flags.render.Options();
  // The outline opens as wide as the gripper of --gripper (robot.yaml finger_range). A name
  // or path that is no robot is a bad flag value (exit 2, as inspect-robot and
  // generate-grasps --robot); a robot.yaml that does not load is not.
  std::filesystem::path gripper_file;
  try {
    gripper_file = robots::FindRobot(flags.gripper, {}, "--gripper");
  } catch (const Error& e) {
    throw UsageError(e);
  }
  const robots::RobotDescription gripper = robots::LoadRobotDescription(gripper_file);
  const Registry registry = flags.libraries.Build();
  registry.LocateOrThrow(flags.uid);  // unknown UID: name every library
  sim::GripperOutline outline;
  outline.opening = gripper.gripper.finger_range[1];
  const auto [file, grasps] =
      FindAndLoadGrasps(registry, flags.uid, flags.joint, flags.robot, flags.num, flags.seed);
  flags.render.Progress(flags.uid + ": " + std::to_string(grasps.poses.size()) + " grasps from " +
                        file.library + " (" + grasps.source.string() + ")");
  flags.render.Write(sim::GraspPicture(registry, flags.uid, grasps.poses, outline, options,
                                       flags.views, flags.joint));
  return 0;
}

}  // namespace

void AddRenderGrasps(CLI::App& render, Action& action) {
  auto flags = std::make_shared<GraspsFlags>();
  CLI::App* sub = render.add_subcommand(
      "grasps",
      "An asset with its pickup (or --joint) grasps drawn as gripper outlines, from several views");
  sub->add_option("UID", flags->uid, "Asset UID")->required();
  sub->add_option("--robot", flags->robot,
                  "Only grasp libraries for this robot (the <robot> of NAME/<robot>)");
  sub->add_option("--joint", flags->joint,
                  "Joint grasps of this joint (name in the asset MJCF) instead of pickup grasps");
  sub->add_option("--gripper", flags->gripper,
                  "Robot (name or robot.yaml) whose open finger gap the outlines show (default "
                  "franka_droid)");
  sub->add_option("--num", flags->num, "Draw N grasps, subsampled (default 20)")
      ->check(PositiveInteger());
  AddSeedOption(
      *sub, [flags](uint64_t seed) { flags->seed = seed; }, "Seed of the subsampling (default 0)");
  sub->add_option("--views", flags->views, "Views around the asset (default 4, at most 64)")
      ->check(WholeNumberIn(1, 64));
  flags->libraries.AddTo(*sub);
  flags->render.AddTo(*sub, "320x320");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
