// Library lists from YAML files (the strict YAML archive, core/yaml_archive.h) and CLI
// flags.
#include "mlspaces/library/library_config.h"

#include "mlspaces/core/error.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/library/registry.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

template <class Spec>
void ReadSpec(const YamlReader& reader, const YAML::Node& node, const std::string& key,
              Spec& spec) {
  reader.ReadStruct(node, key, spec);
  for (const std::string& name : YamlFieldNames<Spec>()) {
    if (!node[name]) reader.Fail(node, key, "missing '" + name + "'");
  }
  if (spec.name.empty()) reader.Fail(node, YamlChildKey(key, "name"), "must not be empty");
  if (spec.name.find('/') != std::string::npos) {
    reader.Fail(node, YamlChildKey(key, "name"),
                "library name " + spec.name + " must not contain slashes");
  }
  if (!reader.context().file.empty()) {
    spec.origin_file = reader.context().file;
    spec.origin_line = YamlLineOf(node);
  }
}

/// Re-throws a registration error with the YAML location when it has none of its own.
template <class F>
void WithLocation(const std::string& file, const std::string& line, F&& f) {
  try {
    f();
  } catch (const UsageError& e) {
    if (!e.path().empty() || file.empty()) throw;
    throw UsageError(e.message(), file, line, e.uid());
  } catch (const Error& e) {
    if (!e.path().empty() || file.empty()) throw;
    throw Error(e.message(), file, line, e.uid());
  }
}

}  // namespace

void ReadYaml(const YamlReader& reader, const YAML::Node& node, const std::string& key,
              AssetLibrarySpec& spec) {
  ReadSpec(reader, node, key, spec);
}

void ReadYaml(const YamlReader& reader, const YAML::Node& node, const std::string& key,
              GraspLibrarySpec& spec) {
  ReadSpec(reader, node, key, spec);
}

void ReadYaml(const YamlReader& reader, const YAML::Node& node, const std::string& key,
              LibraryConfig& config) {
  if (!node.IsScalar()) {
    reader.ReadStruct(node, key, config);
    return;
  }
  fs::path file;
  reader.Read(node, key, file);
  try {
    config = LibraryConfig::LoadYaml(file);
  } catch (const Error& e) {
    if (!e.field().empty()) throw;  // located in the libraries file itself
    reader.Fail(node, key, e.what());
  }
}

LibraryConfig LibraryConfig::LoadYaml(const fs::path& file) {
  const YAML::Node root = LoadYamlFile(file, "libraries file");
  LibraryConfig config;
  if (root.IsNull()) return config;  // an empty file registers nothing
  YamlContext ctx{file.string(), fs::absolute(file).parent_path()};
  ctx.null_lists_are_empty = true;  // "asset_libraries:" with nothing after it
  const YamlReader reader(ctx);
  reader.ReadStruct(root, "", config);
  for (const auto& kv : root) {  // unlike an optional elsewhere, assets_dir cannot be null
    if (kv.first.Scalar() == "assets_dir" && kv.second.IsNull()) {
      reader.Fail(kv.first, "assets_dir", "expected a path, got null");
    }
  }
  for (size_t i = 0; i < config.grasp_libraries.size(); ++i) {
    if (config.grasp_libraries[i].asset_library.empty()) {
      throw Error("grasp_libraries[" + std::to_string(i) + "].asset_library: must not be empty",
                  file.string(), config.grasp_libraries[i].origin_line);
    }
  }
  return config;
}

AssetLibrarySpec LibraryConfig::ParseAssetFlag(const std::string& flag) {
  const size_t eq = flag.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == flag.size()) {
    throw UsageError("--asset-library expects NAME=DIR, got '" + flag + "'");
  }
  AssetLibrarySpec spec;
  spec.name = flag.substr(0, eq);
  spec.dir = flag.substr(eq + 1);
  return spec;
}

GraspLibrarySpec LibraryConfig::ParseGraspFlag(const std::string& flag) {
  const size_t eq = flag.find('=');
  const size_t colon = flag.rfind(':');
  if (eq == std::string::npos || eq == 0 || colon == std::string::npos || colon < eq ||
      colon == eq + 1 || colon + 1 == flag.size()) {
    throw UsageError("--grasp-library expects NAME=DIR:ASSET_LIBRARY, got '" + flag + "'");
  }
  GraspLibrarySpec spec;
  spec.name = flag.substr(0, eq);
  spec.dir = flag.substr(eq + 1, colon - eq - 1);
  spec.asset_library = flag.substr(colon + 1);
  return spec;
}

void LibraryConfig::ApplyTo(Registry& registry) const {
  for (const AssetLibrarySpec& spec : asset_libraries) {
    WithLocation(spec.origin_file.string(), spec.origin_line,
                 [&] { registry.RegisterAssetLibrary(spec.name, spec.dir); });
  }
  for (const GraspLibrarySpec& spec : grasp_libraries) {
    WithLocation(spec.origin_file.string(), spec.origin_line,
                 [&] { registry.RegisterGraspLibrary(spec.name, spec.dir, spec.asset_library); });
  }
}

}  // namespace mlspaces
