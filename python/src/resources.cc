// The resources layer: where built-in data is installed, and installing packaged assets.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "mlspaces/resources/installer.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::python {

void BindResources(nb::module_& m) {
  // (dir, origin): the install dir in the one order every command uses (given, else
  // MLSPACES_ASSETS_DIR, else the default); origin is "given", "environment" or "default".
  m.def(
      "resolve_assets_dir",
      [](std::optional<std::filesystem::path> given) {
        const AssetsDirChoice choice = ResolveAssetsDir(given);
        const char* origin = choice.origin == AssetsDirOrigin::kGiven         ? "given"
                             : choice.origin == AssetsDirOrigin::kEnvironment ? "environment"
                                                                              : "default";
        return nb::make_tuple(choice.dir, origin);
      },
      nb::arg("given") = nb::none());
  // Installs the packaged archives holding `uids` (with their grasp shards) from the sources
  // of the environment's settings (MLSPACES_CACHE_DIR, MLSPACES_ASSETS_DIR,
  // MLSPACES_REMOTE_URL, MLSPACES_PINNED_ASSETS_FILE). Releases the GIL while downloading.
  m.def(
      "install_uids",
      [](const std::vector<std::string>& uids) {
        nb::gil_scoped_release no_gil;
        Installer installer(ResourceSettings::FromEnvironment());
        installer.Install(installer.PlanUids(uids));
      },
      nb::arg("uids"));
}

}  // namespace mlspaces::python
