// Robots as data from Python (mlspaces.robots): the bundled robots, finding a robot by name or
// path, and loading or checking its robot.yaml (robots/robot_spec.h).
#include <filesystem>
#include <string>
#include <vector>

#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/robots/robot_spec.h"

namespace mlspaces::python {

namespace {

namespace fs = std::filesystem;

/// FindRobot; an unknown robot name (not a path) is a KeyLookupError (MlspacesKeyError).
fs::path Find(const std::string& name_or_path, const fs::path& base_dir, const std::string& field) {
  const bool is_path = name_or_path.find('/') != std::string::npos ||
                       name_or_path.ends_with(".yaml") || name_or_path.ends_with(".yml");
  try {
    return robots::FindRobot(name_or_path, base_dir, field);
  } catch (const Error& e) {
    if (is_path) throw;
    throw KeyLookupError(e.message(), e.path(), e.field(), e.uid());
  }
}

}  // namespace

void BindRobots(nb::module_& m) {
  m.def("robots_dir", [] { return robots::RobotsDir(); });
  m.def("bundled_robots", [] { return robots::BundledRobots(); });
  // The robot.yaml a robot name or path means (robot_spec.h FindRobot).
  m.def("find_robot", &Find, nb::arg("name_or_path"), nb::arg("base_dir") = fs::path(),
        nb::arg("field") = "robot_config.name");
  // The robot.yaml at `file` loaded strictly: (canonical YAML of the description, file, hash).
  m.def(
      "load_robot_description",
      [](const fs::path& file) {
        robots::RobotDescription d;
        {
          nb::gil_scoped_release no_gil;
          d = robots::LoadRobotDescription(file);
        }
        return nb::make_tuple(DumpYaml(d), d.file, d.hash);
      },
      nb::arg("file"));
  // Every problem of the robot.yaml at `file`, one line each (empty = valid).
  m.def(
      "check_robot_description",
      [](const fs::path& file) {
        nb::gil_scoped_release no_gil;
        return robots::CheckRobotDescription(file);
      },
      nb::arg("file"));
}

}  // namespace mlspaces::python
