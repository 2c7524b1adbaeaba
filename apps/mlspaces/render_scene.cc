// mlspaces render scene CONFIG: a datagen scene as the engine composes and samples it, from an
// overview and each configured camera.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mlspaces/datagen/pictures.h"
#include "render.h"

namespace mlspaces::cli {
namespace {

struct SceneFlags {
  DatagenConfigFlags config;
  int64_t house = 0;
  int64_t episode = 0;
  int overviews = 1;
  RenderFlags render;
};

int Run(const SceneFlags& flags) {
  const sim::PictureOptions options = flags.render.Options();
  const datagen::ConfigRegistry configs = datagen::ConfigRegistry::WithBuiltins();
  const datagen::ExperimentConfig config = flags.config.Resolve(configs);
  datagen::SceneRequest request;
  request.house = flags.house;
  request.episode = flags.episode;
  request.seed = flags.config.seed;
  request.overview_views = flags.overviews;
  flags.render.Progress("composing house " + std::to_string(flags.house) + " of " +
                        flags.config.config);
  flags.render.Write(datagen::ScenePicture(config, request, options));
  return 0;
}

}  // namespace

void AddRenderScene(CLI::App& render, Action& action) {
  auto flags = std::make_shared<SceneFlags>();
  CLI::App* sub = render.add_subcommand(
      "scene",
      "A datagen config's scene as the data engine composes it: robot placed and task sampled "
      "as episode E of a run, from an overview and each configured camera");
  sub->add_option("CONFIG", flags->config.config, "Config YAML file or registered config name")
      ->required();
  sub->add_option("--set", flags->config.sets, "Override a config key (repeatable)")
      ->type_name("KEY=VALUE");
  AddSeedOption(
      *sub, [flags](uint64_t seed) { flags->config.seed = seed; },
      "Run seed (default: the config's, else 0)");
  sub->add_option("--house", flags->house, "Scene index into scene_xml_paths (default 0)")
      ->check(NonNegativeInteger());
  sub->add_option("--episode", flags->episode,
                  "Episode number whose task is shown (default 0; the next while rejected)")
      ->check(NonNegativeInteger());
  sub->add_option("--overviews", flags->overviews,
                  "Overview views besides the cameras (default 1, at most 16)")
      ->check(WholeNumberIn(0, 16));
  flags->render.AddTo(*sub, "320x240");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
