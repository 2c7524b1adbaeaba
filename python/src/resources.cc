// The resources layer: where built-in data is installed, and installing packaged assets.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/installer.h"
#include "mlspaces/resources/molmo_remote.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::python {

void BindResources(nb::module_& m) {
  // (dir, origin): the install dir in the one order every command uses (given, else
  // MLSPACES_ASSETS_DIR, else the default); origin is "given", "environment" or "default".
  m.def(
      "resolve_assets_dir",
      [](const std::optional<std::filesystem::path>& given) {
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
  // install_uid: the UID's object archive and its grasp archives (from `grasp_source`), from
  // an mlspaces package or a MolmoSpaces-format remote; returns the MJCF path through the
  // install dir. Raises for an unknown UID.
  m.def(
      "install_uid",
      [](const std::string& uid, const std::string& grasp_source) {
        nb::gil_scoped_release no_gil;
        InstallOptions options;
        options.grasp_source = grasp_source;
        const ResourceSettings settings = ResourceSettings::FromEnvironment();
        Installer installer(settings, options);
        installer.Install(installer.PlanUids({uid}));
        Registry registry(Registry::Options{settings.assets_dir});
        return registry.LocateOrThrow(uid).mjcf_path;
      },
      nb::arg("uid"), nb::arg("grasp_source") = "droid_objaverse");
  // install_scene_with_objects_and_grasps_from_path: the scene archive (by path inside a
  // scene source, under <assets>/scenes, or a scene number), then the objects and grasps its
  // MJCFs reference. Returns {"scenes"|"objects"|"grasps": {source: [archives]}} as the
  // original (every archive asked for, installed before or now).
  m.def(
      "install_scene_with_objects_and_grasps_from_path",
      [](const std::string& scene, const std::vector<std::string>& grasp_sources,
         bool exclude_thor) {
        nb::gil_scoped_release no_gil;
        Installer installer(ResourceSettings::FromEnvironment());
        SceneRequest request;
        const InstallPlan scene_plan = installer.PlanScene(scene, &request);
        installer.Install(scene_plan);
        const InstallPlan contents =
            installer.PlanSceneContents(request, grasp_sources, /*objects=*/true, exclude_thor);
        installer.Install(contents);
        auto out = contents.requested;
        out["scenes"] = scene_plan.requested.count("scenes") != 0
                            ? scene_plan.requested.at("scenes")
                            : std::map<std::string, std::vector<std::string>>{};
        out.try_emplace("objects");
        out.try_emplace("grasps");
        return out;
      },
      nb::arg("scene"), nb::arg("grasp_sources") = std::vector<std::string>{"droid_objaverse"},
      nb::arg("exclude_thor") = true);
  // install_objects_for_scene / install_grasps_for_scene: for one installed scene MJCF under
  // <assets>/scenes/<source>/, the object archives it references, or the archives of
  // `grasp_source` matching the tokens of each referenced file's name. Returns
  // {source: [archives]} ({} when objaverse, or the grasp source, is not configured, and for
  // THOR's grasp sources when THOR is excluded), as the original.
  m.def(
      "install_objects_for_scene",
      [](const std::filesystem::path& xml, bool exclude_thor) {
        nb::gil_scoped_release no_gil;
        Installer installer(ResourceSettings::FromEnvironment());
        const InstallPlan plan = installer.PlanSceneContents(installer.RequestForSceneFile(xml), {},
                                                             /*objects=*/true, exclude_thor);
        installer.Install(plan);
        auto it = plan.requested.find("objects");
        return it != plan.requested.end() ? it->second
                                          : std::map<std::string, std::vector<std::string>>{};
      },
      nb::arg("xml_path"), nb::arg("exclude_thor") = true);
  m.def(
      "install_grasps_for_scene",
      [](const std::filesystem::path& xml, const std::string& grasp_source, bool exclude_thor) {
        nb::gil_scoped_release no_gil;
        Installer installer(ResourceSettings::FromEnvironment());
        const InstallPlan plan = installer.PlanSceneContents(
            installer.RequestForSceneFile(xml), {grasp_source}, /*objects=*/false, exclude_thor);
        installer.Install(plan);
        auto it = plan.requested.find("grasps");
        return it != plan.requested.end() ? it->second
                                          : std::map<std::string, std::vector<std::string>>{};
      },
      nb::arg("xml_path"), nb::arg("grasp_source") = "droid_objaverse",
      nb::arg("exclude_thor") = true);
  // find_object_paths: (source, path in the source) of each ../objects/... file a scene MJCF
  // references (mesh, texture, material, hfield, skin under <asset>).
  m.def(
      "find_object_paths",
      [](const std::filesystem::path& scene_xml, bool exclude_thor) {
        const ResourceSettings settings = ResourceSettings::FromEnvironment();
        std::vector<std::pair<std::string, std::string>> out;
        for (const SceneObjectRef& r : FindSceneObjectRefs(scene_xml, settings.assets_dir)) {
          if (exclude_thor && r.source == "thor") continue;
          out.emplace_back(r.source, r.path);
        }
        return out;
      },
      nb::arg("scene_xml"), nb::arg("exclude_thor") = true);
}

}  // namespace mlspaces::python
