// mlspaces._core: the C++ engine for the mlspaces Python package (python/mlspaces).
#include <mujoco/mujoco.h>
#include <nanobind/stl/string.h>

#include <string>

#include "bindings.h"

NB_MODULE(_core, m) {
  m.doc() = "mlspaces C++ engine (use the mlspaces package, not this module)";
  m.attr("__version__") = MLSPACES_VERSION;
  // The MuJoCo this extension was built against, and the one it runs with (mj_versionString of
  // the libmujoco the process mapped: mlspaces/__init__.py checks it is mujoco's).
  m.attr("MUJOCO_BUILD_VERSION") = MLSPACES_MUJOCO_VERSION;
  m.def("mujoco_runtime_version", [] { return std::string(mj_versionString()); });
  mlspaces::python::BindErrors(m);
  mlspaces::python::BindLibrary(m);
  mlspaces::python::BindSearch(m);
  mlspaces::python::BindResources(m);
  mlspaces::python::BindLicense(m);
  mlspaces::python::BindDatagen(m);
  mlspaces::python::BindEval(m);
  mlspaces::python::BindVideo(m);
  mlspaces::python::BindIndex(m);
  mlspaces::python::BindRobotsInspect(m);
  mlspaces::python::BindRobots(m);
  mlspaces::python::BindRender(m);
#ifdef MLSPACES_HAVE_GRASPGEN
  mlspaces::python::BindGraspgen(m);
#endif
}
