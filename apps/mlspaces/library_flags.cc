// Library flags shared by the lookup commands: which asset and grasp libraries to register.
#include <cstdio>
#include <string>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/resources/objathor.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::cli {

void LibraryFlags::AddTo(CLI::App& app) {
  // One value per occurrence, so a following positional UID is never swallowed.
  app.add_option("--asset-library", asset_flags,
                 "Register a user asset library NAME=DIR (repeatable, in priority order)")
      ->type_name("NAME=DIR")
      ->allow_extra_args(false);
  app.add_option("--grasp-library", grasp_flags,
                 "Register a user grasp library NAME=DIR:ASSET_LIBRARY (repeatable; one "
                 "library NAME/<robot> per robot folder)")
      ->type_name("NAME=DIR:ASSET_LIBRARY")
      ->allow_extra_args(false);
  app.add_option("--libraries", yaml_file,
                 "YAML file listing assets_dir, asset_libraries and grasp_libraries")
      ->type_name("FILE.yaml");
}

std::filesystem::path LibraryFlags::AssetsDir() const {
  std::optional<std::filesystem::path> given;
  if (!yaml_file.empty()) given = LibraryConfig::LoadYaml(yaml_file).assets_dir;
  return ResolveAssetsDir(given).dir;
}

Registry LibraryFlags::Build() const {
  // Parse every flag first: a malformed one is a usage error before anything is read.
  std::vector<AssetLibrarySpec> assets;
  std::vector<GraspLibrarySpec> grasps;
  for (const std::string& flag : asset_flags) assets.push_back(LibraryConfig::ParseAssetFlag(flag));
  for (const std::string& flag : grasp_flags) grasps.push_back(LibraryConfig::ParseGraspFlag(flag));
  LibraryConfig config;
  if (!yaml_file.empty()) config = LibraryConfig::LoadYaml(yaml_file);

  Registry::Options options;
  // The default dir (where `mlspaces install` puts packages) only when it exists.
  const AssetsDirChoice assets_dir = ResolveAssetsDir(config.assets_dir);
  std::error_code ignored;
  if (assets_dir.origin != AssetsDirOrigin::kDefault ||
      std::filesystem::is_directory(assets_dir.dir, ignored)) {
    options.assets_dir = assets_dir.dir;
  }
  if (objathor && options.assets_dir) {
    if (auto report = EnsureObjathorStore(*options.assets_dir); report && report->converted) {
      std::fprintf(stderr, "objathor metadata: %zu annotations converted from %s into %s\n",
                   report->annotations, report->from.c_str(), report->index_dir.c_str());
    }
  }
  Registry registry(options);
  config.ApplyTo(registry);
  for (const AssetLibrarySpec& spec : assets) registry.RegisterAssetLibrary(spec.name, spec.dir);
  for (const GraspLibrarySpec& spec : grasps) {
    registry.RegisterGraspLibrary(spec.name, spec.dir, spec.asset_library);
  }
  for (const DuplicateUid& dup : registry.duplicates()) {
    std::string where;
    for (size_t i = 0; i < dup.libraries.size(); ++i) {
      if (i > 0) where += ", ";
      where += dup.libraries[i];
      if (i < dup.paths.size()) where += " (" + dup.paths[i].string() + ")";
    }
    Warn("UID " + dup.uid + " is in several asset libraries: " + where + "; using the first");
  }
  return registry;
}

}  // namespace mlspaces::cli
