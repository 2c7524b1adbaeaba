// Datagen configs: the field descriptions (Serialize, config.h) drive strict YAML loading,
// `--set` overrides, the canonical dump, the hash and path resolution through the YAML archive
// (core/yaml_archive.h). Validation: config_validate.cc; named configs: config_registry.cc.
#include "mlspaces/datagen/config.h"

#include <cstdio>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/core/yaml_archive.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;

namespace {

ExperimentConfig ReadConfig(const YAML::Node& root, const std::string& origin,
                            const fs::path& base_dir, const ConfigRegistry& registry) {
  const YamlReader reader(YamlContext{origin, base_dir});
  ExperimentConfig config;
  if (root.IsNull()) {
    ResolvePaths(config, base_dir);
    return config;
  }
  if (!root.IsMap()) reader.Fail(root, "", "expected a mapping, got " + DescribeYaml(root));
  if (const YAML::Node base = root["base"]) {
    if (!base.IsScalar())
      reader.Fail(base, "base", "expected a config name, got " + DescribeYaml(base));
    try {
      config = registry.Make(base.Scalar());
    } catch (const Error& e) {
      reader.Fail(base, "base", e.message());
    }
  }
  reader.ReadStruct(root, "", config, {"base"});
  ResolvePaths(config, base_dir);
  return config;
}

}  // namespace

ExperimentConfig LoadConfigFile(const fs::path& file, const ConfigRegistry& registry) {
  return ReadConfig(LoadYamlFile(file, "config file"), file.string(),
                    fs::absolute(file).parent_path(), registry);
}

ExperimentConfig ParseConfigText(std::string_view text, const std::string& origin,
                                 const fs::path& base_dir, const ConfigRegistry& registry) {
  return ReadConfig(LoadYamlString(text, origin), origin, fs::absolute(base_dir), registry);
}

void ApplyOverride(ExperimentConfig& config, std::string_view assignment,
                   const fs::path& base_dir) {
  const size_t eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw UsageError(
        "--set expects KEY=VALUE (e.g. task_sampler_config.samples_per_house=4), "
        "got '" +
        std::string(assignment) + "'");
  }
  const std::string key(assignment.substr(0, eq));
  const std::string text(assignment.substr(eq + 1));
  std::vector<std::string> parts;
  for (size_t start = 0;;) {
    const size_t dot = key.find('.', start);
    parts.push_back(key.substr(start, dot == std::string::npos ? dot : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  for (const std::string& p : parts) {
    if (p.empty()) throw UsageError("--set " + key + ": empty key component");
  }
  YAML::Node value;
  try {
    value = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw UsageError("--set " + key + ": invalid YAML value '" + text + "': " + e.msg);
  }
  const YamlReader reader(YamlContext{"", base_dir, "--set "});
  SetYamlKey(reader, config, parts, value);
}

void ResolvePaths(ExperimentConfig& config, const fs::path& base_dir) {
  ResolveYamlPaths(config, base_dir);
}

std::string DumpConfig(const ExperimentConfig& config) { return DumpYaml(config); }

uint64_t ConfigHash(const ExperimentConfig& config) { return HashString(DumpConfig(config)); }

std::string ConfigHashHex(const ExperimentConfig& config) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(ConfigHash(config)));
  return buf;
}

std::string DataConfigHashHex(const ExperimentConfig& config) {
  ExperimentConfig data = config;
  const ExperimentConfig defaults;
  data.output_dir = defaults.output_dir;
  data.log_level = defaults.log_level;
  data.num_workers = defaults.num_workers;
  data.profile = defaults.profile;
  return ConfigHashHex(data);
}

}  // namespace mlspaces::datagen
