// Licences (resources/license.h): the engine behind mlspaces.utils.license_utils.
#include <algorithm>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/license.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::python {
namespace {

/// The context of a registry: its install dir, and the environment's cache dir.
LicenseContext Context(const Registry& registry, const std::filesystem::path& assets_dir) {
  return LicenseContext{&registry, assets_dir, ResourceSettings::FromEnvironment().cache_dir};
}

}  // namespace

void BindLicense(nb::module_& m) {
  // resolve_license(registry, assets_dir, data_type, data_source, identifier) -> dict, in the
  // original's key order. assets_dir may be empty (user libraries only).
  m.def(
      "resolve_license",
      [](const Registry& registry, const std::filesystem::path& assets_dir,
         const std::string& data_type, const std::string& source, const std::string& identifier) {
        return JsonToPython(
            ResolveLicense(Context(registry, assets_dir), data_type, source, identifier));
      },
      nb::arg("registry"), nb::arg("assets_dir"), nb::arg("data_type"), nb::arg("data_source"),
      nb::arg("identifier"));
  // The identifiers of a source (archive names without "<source>_" and ".tar.zst"), sorted.
  m.def(
      "license_identifiers",
      [](const Registry& registry, const std::filesystem::path& assets_dir,
         const std::string& data_type, const std::string& source) {
        std::vector<std::string> out;
        for (const std::string& archive :
             SourceArchiveNames(Context(registry, assets_dir), data_type, source)) {
          out.push_back(ArchiveIdentifier(archive, source));
        }
        std::sort(out.begin(), out.end());
        return out;
      },
      nb::arg("registry"), nb::arg("assets_dir"), nb::arg("data_type"), nb::arg("data_source"));
  // The source of an object UID when none is given, or None.
  m.def(
      "default_object_source",
      [](const Registry& registry, const std::string& uid) -> nb::object {
        const auto source = DefaultObjectSource(registry, uid);
        return source ? nb::cast(*source) : nb::none();
      },
      nb::arg("registry"), nb::arg("uid"));
  // The licence policy in force: `given` ("all", "commercial_safe") when not None, else
  // MLSPACES_LICENSE_POLICY, else "all". Raises for a bad name.
  m.def(
      "resolve_license_policy",
      [](const nb::object& given) {
        std::optional<LicensePolicy> policy;
        if (!given.is_none()) {
          policy = ParseLicensePolicy(nb::cast<std::string>(given), "license_policy");
        }
        return std::string(LicensePolicyName(ResolveLicensePolicy(policy)));
      },
      nb::arg("given") = nb::none());
}

}  // namespace mlspaces::python
