// mlspaces config CONFIG [--set KEY=VALUE]... [--seed S] [--episodes N] [--output DIR]:
// loads a datagen config, applies the overrides, validates it and prints the resolved config
// (canonical YAML) with its hash. A dry run of `mlspaces datagen`, which shares the flags.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/error.h"

namespace mlspaces::cli {
namespace fs = std::filesystem;

void DatagenConfigFlags::AddTo(CLI::App& app) {
  app.add_option("CONFIG", config,
                 "Config: a YAML file, or the name of a registered config "
                 "(e.g. CustomAssetsDataGenConfig)")
      ->required();
  app.add_option("--set", sets,
                 "Override one field, KEY=VALUE with a dotted KEY and a YAML VALUE "
                 "(e.g. task_sampler_config.samples_per_house=4); repeatable, applied in order")
      ->type_name("KEY=VALUE")
      ->allow_extra_args(false);
  AddSeedOption(
      app, [this](uint64_t value) { seed = value; }, "Run seed (sets `seed`)");
  app.add_option_function<int64_t>(
         "--episodes", [this](const int64_t& n) { episodes = n; },
         "Episodes per scene (sets task_sampler_config.samples_per_house)")
      ->type_name("N")
      ->check(PositiveInteger());
  app.add_option("--output", output, "Output folder (sets output_dir)")->type_name("DIR");
}

datagen::ExperimentConfig DatagenConfigFlags::Resolve(
    const datagen::ConfigRegistry& registry) const {
  const fs::path cwd = fs::current_path();
  const fs::path file(config);
  const std::string ext = file.extension().string();
  const bool looks_like_file =
      ext == ".yaml" || ext == ".yml" || config.find('/') != std::string::npos;
  datagen::ExperimentConfig resolved;
  fs::path origin;
  if (std::error_code ec; looks_like_file || fs::is_regular_file(file, ec)) {
    resolved = datagen::LoadConfigFile(file, registry);
    origin = file;
  } else {
    resolved = registry.Make(config);
    datagen::ResolvePaths(resolved, cwd);
  }
  for (const std::string& assignment : sets) datagen::ApplyOverride(resolved, assignment, cwd);
  if (seed) resolved.seed = *seed;
  if (episodes) resolved.task_sampler_config.samples_per_house = *episodes;
  if (!output.empty()) resolved.output_dir = fs::absolute(output).lexically_normal();
  try {
    datagen::Validate(resolved, origin);
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    // A bad value that a --set gave is named by the flag, not the file (still bad input,
    // exit 1): the last --set of that field or of one above it ("camera_config.cameras" for
    // "camera_config.cameras[0].fov").
    const std::string& field = e.field();
    for (auto it = sets.rbegin(); it != sets.rend(); ++it) {
      const std::string key = it->substr(0, it->find('='));
      const bool above = field.size() > key.size() && field.compare(0, key.size(), key) == 0 &&
                         (field[key.size()] == '.' || field[key.size()] == '[');
      if (field == key || above) throw Error(e.message(), "--set " + *it, above ? field : "");
    }
    throw;
  }
  return resolved;
}

namespace {

int Run(const DatagenConfigFlags& flags) {
  const datagen::ConfigRegistry registry = datagen::ConfigRegistry::WithBuiltins();
  const datagen::ExperimentConfig config = flags.Resolve(registry);
  std::printf("# config hash: %s\n%s", datagen::ConfigHashHex(config).c_str(),
              datagen::DumpConfig(config).c_str());
  return 0;
}

}  // namespace

void AddConfig(CLI::App& app, Action& action) {
  auto flags = std::make_shared<DatagenConfigFlags>();
  CLI::App* sub = app.add_subcommand(
      "config",
      "Load a datagen config, apply overrides, validate, and print it resolved with its hash");
  flags->AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
