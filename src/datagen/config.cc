// Datagen configs: the field descriptions (Serialize, config.h) drive strict YAML loading,
// `--set` overrides, the canonical dump, the hash and path resolution through the YAML archive
// (core/yaml_archive.h). Validation: config_validate.cc; named configs: config_registry.cc.
#include "mlspaces/datagen/config.h"

#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <mutex>
#include <tuple>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/library/scene_metadata.h"

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

// ---------------------------------------------------------------------------------------
// Content digests for the data hash: what a path holds, not where it is.

std::string Hex64(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// SourceFileHash of a file (XXH3-128 hex), cached per process while the file's stat is
// unchanged (a run hashes its config several times: config.yaml, resume, every episode's
// provenance).
std::string FileDigest(const fs::path& file) {
  using Stamp = std::tuple<dev_t, ino_t, off_t, int64_t, int64_t, int64_t, int64_t>;
  static std::mutex mutex;
  static std::map<std::string, std::pair<Stamp, std::string>> cache;
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) throw Error("cannot stat", file.string());
  const Stamp stamp{st.st_dev,          st.st_ino,         st.st_size,        st.st_mtim.tv_sec,
                    st.st_mtim.tv_nsec, st.st_ctim.tv_sec, st.st_ctim.tv_nsec};
  {
    const std::lock_guard lock(mutex);
    if (auto it = cache.find(file.string()); it != cache.end() && it->second.first == stamp) {
      return it->second.second;
    }
  }
  std::string h = SourceFileHash(file);
  const std::lock_guard lock(mutex);
  cache[file.string()] = {stamp, h};
  return h;
}

// What a config path stands for in the data hash: a file's bytes (a scene XML's with its
// scene metadata file's), a folder's files by relative path and bytes (hidden entries left
// out: caches; and `run_folder`), or only the name of a path that does not exist.
std::string PathDigest(const fs::path& path, const fs::path& run_folder) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    std::string out = "file:" + FileDigest(path);
    if (path.extension() == ".xml") {
      if (const std::optional<fs::path> meta = FindSceneMetadataFile(path)) {
        out += "+" + meta->filename().string() + ":" + FileDigest(*meta);
      }
    }
    return out;
  }
  if (fs::is_directory(path, ec)) {
    std::vector<std::pair<std::string, fs::path>> files;
    fs::recursive_directory_iterator it(path, fs::directory_options::skip_permission_denied, ec);
    if (ec) throw Error("cannot list: " + ec.message(), path.string());
    for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (ec) throw Error("cannot list: " + ec.message(), path.string());
      const fs::path& p = it->path();
      if (p.filename().string().starts_with(".") || p == run_folder) {
        it.disable_recursion_pending();
        continue;
      }
      if (it->is_regular_file(ec))
        files.emplace_back(p.lexically_relative(path).generic_string(), p);
    }
    std::sort(files.begin(), files.end());
    std::string listing;  // "<relative path>\0<digest>\n" per file
    for (const auto& [rel, file] : files) {
      listing += rel;
      listing += '\0';
      listing += FileDigest(file) + "\n";
    }
    return "dir:" + Hex64(HashString(listing));
  }
  return "missing:" + path.filename().string();
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

std::string ConfigHashHex(const ExperimentConfig& config) { return Hex64(ConfigHash(config)); }

ExperimentConfig DataFields(const ExperimentConfig& config, bool paths_by_content) {
  ExperimentConfig data = config;
  const ExperimentConfig defaults;
  data.output_dir = defaults.output_dir;
  data.log_level = defaults.log_level;
  data.num_workers = defaults.num_workers;
  data.profile = defaults.profile;
  // The built-in data folder is where installed packages sit, as MLSPACES_ASSETS_DIR.
  data.libraries.assets_dir = defaults.libraries.assets_dir;
  // Every other path by what it holds: the same project in another folder, the same hash.
  // A library folder holding the run's own output does not count that output.
  const fs::path run_folder = fs::absolute(RunFolder(config)).lexically_normal();
  MapYamlPaths(data, [&run_folder, paths_by_content](const fs::path& p) {
    return fs::path(paths_by_content ? PathDigest(p, run_folder) : "<path>");
  });
  // The robot by what its files hold too (robot.yaml and its MJCF, RobotDescription::hash):
  // a robot found by name is no path above. A robot that does not load is left to the run,
  // which reports it.
  if (paths_by_content) {
    try {
      const RobotSpec robot =
          RobotSpecFromConfig(config.robot_config, {}, config.libraries.assets_dir);
      data.robot_config.name += " (robot.yaml " + robot.description_hash + ")";
    } catch (const Error&) {}
  }
  return data;
}

std::string DataConfigHashHex(const ExperimentConfig& config) {
  return ConfigHashHex(DataFields(config, true));
}

}  // namespace mlspaces::datagen
