// _core.inspect_robot, behind mlspaces.robots.inspect_robot: `mlspaces inspect-robot` as a dict
// (robots/inspect.h).
#include <array>
#include <filesystem>
#include <string>

#include <nanobind/stl/array.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/robots/inspect.h"
#ifdef MLSPACES_HAVE_GRASPGEN
#include "mlspaces/graspgen/generate.h"
#endif

namespace mlspaces::python {

void BindRobotsInspect(nb::module_& m) {
  m.def(
      "inspect_robot",
      [](const std::filesystem::path& name_or_path, double settle_time, double finger_tolerance,
         double tcp_tolerance_deg, std::array<double, 2> grid_x, std::array<double, 2> grid_y,
         std::array<double, 2> grid_z, double grid_step, bool reachability) {
        robots::InspectOptions o;
        o.settle_time = settle_time;
        o.finger_tolerance = finger_tolerance;
        o.tcp_tolerance_deg = tcp_tolerance_deg;
        o.grid_x = grid_x;
        o.grid_y = grid_y;
        o.grid_z = grid_z;
        o.grid_step = grid_step;
        o.reachability = reachability;
        Json json;
        {
          nb::gil_scoped_release no_gil;
          const robots::RobotReport report = robots::InspectRobot(name_or_path.string(), o);
          json = robots::ToJson(report);
#ifdef MLSPACES_HAVE_GRASPGEN
          if (report.loaded) {
            json["grasp_generation"] =
                graspgen::ToJson(graspgen::CheckGraspGeneration(report.file.string()));
          }
#endif
        }
        return JsonToPython(json);
      },
      nb::arg("name_or_path"), nb::kw_only(), nb::arg("settle_time") = 1.0,
      nb::arg("finger_tolerance") = 0.002, nb::arg("tcp_tolerance_deg") = 10.0,
      nb::arg("grid_x") = std::array<double, 2>{0.3, 0.8},
      nb::arg("grid_y") = std::array<double, 2>{-0.4, 0.4},
      nb::arg("grid_z") = std::array<double, 2>{0.05, 0.6}, nb::arg("grid_step") = 0.1,
      nb::arg("reachability") = true,
      "The engine of mlspaces.robots.inspect_robot (python/mlspaces/robots/_inspect.py, which "
      "checks the arguments): InspectRobot's report as a dict (ToJson), with grasp_generation "
      "(graspgen::CheckGraspGeneration) when the description loads");
}

}  // namespace mlspaces::python
