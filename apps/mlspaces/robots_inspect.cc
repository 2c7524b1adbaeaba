// mlspaces inspect-robot NAME|PATH [--json] [--settle-time S] [--grid-x MIN MAX] ...: checks a
// robot description and measures the robot in simulation (robots::InspectRobot). Exit 0: no
// problem; 1: problems found (one line each); 2: bad usage or no such robot. With graspgen built,
// a last line says whether generate-grasps can use the robot (not a problem when it cannot).
#include <array>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/robots/inspect.h"
#ifdef MLSPACES_HAVE_GRASPGEN
#include "mlspaces/graspgen/generate.h"
#endif

namespace mlspaces::cli {
namespace {

struct InspectRobotFlags {
  std::string robot;
  bool json = false;
  bool no_ik = false;
  std::vector<double> grid_x, grid_y, grid_z;
  robots::InspectOptions options;
};

int Run(const InspectRobotFlags& flags) {
  robots::InspectOptions options = flags.options;
  options.reachability = !flags.no_ik;
  auto range = [](const std::vector<double>& v, std::array<double, 2>& out) {
    if (v.size() == 2) out = {v[0], v[1]};
  };
  range(flags.grid_x, options.grid_x);
  range(flags.grid_y, options.grid_y);
  range(flags.grid_z, options.grid_z);
  robots::RobotReport report;
  try {
    report = robots::InspectRobot(flags.robot, options);
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    // No such robot (a misspelled name, a path without a robot.yaml): a usage error.
    throw UsageError(e);
  }
  Json json = robots::ToJson(report);
  std::string text = robots::FormatRobotReport(report);
#ifdef MLSPACES_HAVE_GRASPGEN
  if (report.loaded) {
    const graspgen::GraspReadiness grasps = graspgen::CheckGraspGeneration(report.file.string());
    json["grasp_generation"] = graspgen::ToJson(grasps);
    text += graspgen::FormatGraspReadiness(grasps, report.name);
  }
#endif
  std::printf("%s", flags.json ? (DumpJsonIndent4(json) + "\n").c_str() : text.c_str());
  return report.problems.empty() ? 0 : 1;
}

}  // namespace

void AddInspectRobot(CLI::App& app, Action& action) {
  auto flags = std::make_shared<InspectRobotFlags>();
  CLI::App* sub = app.add_subcommand(
      "inspect-robot",
      "Check a robot description and measure it in simulation: kinematic chain, limits, TCP "
      "convention, gripper travel, IK reachability (exit 1 when it finds problems)");
  sub->add_option("ROBOT", flags->robot, "A bundled robot's name, or a robot.yaml or its folder")
      ->required();
  sub->add_flag("--json", flags->json, "Print JSON for scripts");
  sub->add_option("--settle-time", flags->options.settle_time,
                  "Seconds simulated after opening and after closing the gripper")
      ->type_name("S")
      ->check(NumberIn(1e-3, 60.0))
      ->capture_default_str();
  sub->add_option("--finger-tolerance", flags->options.finger_tolerance,
                  "Largest difference between the measured gap and finger_range (m)")
      ->type_name("M")
      ->check(NumberIn(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--tcp-tolerance", flags->options.tcp_tolerance_deg,
                  "Largest angle of the TCP axes from the gripper's geometry (degrees)")
      ->type_name("DEG")
      ->check(NumberIn(0.0, 180.0))
      ->capture_default_str();
  sub->add_option("--grid-x", flags->grid_x,
                  "Reachability grid: x range in the base frame, m (default 0.3 0.8)")
      ->expected(2)
      ->option_text("MIN MAX");
  sub->add_option("--grid-y", flags->grid_y, "Reachability grid: y range, m (default -0.4 0.4)")
      ->expected(2)
      ->option_text("MIN MAX");
  sub->add_option("--grid-z", flags->grid_z, "Reachability grid: z range, m (default 0.05 0.6)")
      ->expected(2)
      ->option_text("MIN MAX");
  sub->add_option("--grid-step", flags->options.grid_step, "Reachability grid: spacing, m")
      ->type_name("M")
      ->check(PositiveNumber())
      ->capture_default_str();
  sub->add_flag("--no-ik", flags->no_ik, "Skip the reachability grid");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
