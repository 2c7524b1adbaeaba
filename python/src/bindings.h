// The parts of the mlspaces._core module, one Bind* per binding file.
#pragma once

#include <nanobind/nanobind.h>
// Every binding file sees the same casters: a file that casts std::string without them would
// instantiate nanobind::cast<std::string> differently (an ODR clash that fails at run time).
#include <nanobind/stl/string.h>

#include "mlspaces/core/error.h"

namespace mlspaces::python {

namespace nb = nanobind;

/// An unknown name or UID where MolmoSpaces raises KeyError: becomes
/// mlspaces.errors.MlspacesKeyError (a ValueError and a KeyError).
class KeyLookupError : public Error {
 public:
  using Error::Error;
};

void BindErrors(nb::module_& m);
void BindLibrary(nb::module_& m);
void BindResources(nb::module_& m);
void BindLicense(nb::module_& m);
void BindDatagen(nb::module_& m);
void BindVideo(nb::module_& m);
void BindEval(nb::module_& m);
void BindSearch(nb::module_& m);
/// The CLI's index-assets / index-grasps (index.cc).
void BindIndex(nb::module_& m);
/// mlspaces.robots.inspect_robot (robots_inspect.cc).
void BindRobotsInspect(nb::module_& m);
/// Robots as data: bundled robots, robot.yaml loading and checking (robots.cc).
void BindRobots(nb::module_& m);
/// mlspaces.render: pictures as numpy images, PNG files (render.cc).
void BindRender(nb::module_& m);
#ifdef MLSPACES_HAVE_GRASPGEN
/// mlspaces.grasp_generation.generate_grasps (graspgen.cc).
void BindGraspgen(nb::module_& m);
#endif

}  // namespace mlspaces::python
