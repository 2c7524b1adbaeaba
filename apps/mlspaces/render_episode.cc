// mlspaces render episode DATASET [--episode K]: an episode's camera frames at each planner
// phase, from its video.
#include <cstdint>
#include <memory>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/pictures.h"
#include "mlspaces/sim/pictures.h"
#include "render.h"

namespace mlspaces::cli {
namespace {

struct EpisodeFlags {
  std::string dataset;
  int64_t episode = 0;
  std::string camera;
  int width = 320;
  RenderFlags render;
};

int Run(const EpisodeFlags& flags) {
  if (flags.episode < 0) throw UsageError("--episode: expected a whole number >= 0");
  const datagen::EpisodeFrames frames =
      datagen::EpisodePhaseFrames(flags.dataset, flags.episode, flags.camera);
  flags.render.Progress(frames.episode.file.string() + " " + frames.episode.traj + ": " +
                        std::to_string(frames.num_steps) + " steps, " +
                        std::to_string(frames.frames.size()) + " frames from " + frames.camera);
  flags.render.Write(datagen::EpisodePhaseSheet(frames, flags.render.columns, flags.width));
  return 0;
}

}  // namespace

void AddRenderEpisode(CLI::App& render, Action& action) {
  auto flags = std::make_shared<EpisodeFlags>();
  CLI::App* sub = render.add_subcommand(
      "episode",
      "A recorded episode's camera frames at each planner phase change and at its end (from "
      "its video)");
  sub->add_option("DATASET", flags->dataset, "Run folder, house folder or batch file (.h5)")
      ->required();
  sub->add_option("--episode", flags->episode,
                  "Episode index in reading order (houses, batches, traj_<k>; default 0)")
      ->check(NonNegativeInteger());
  sub->add_option("--camera", flags->camera, "Camera (default: the first by name)");
  sub->add_option("--width", flags->width,
                  "Width of each frame in pixels (default 320; " +
                      std::to_string(sim::kMinPictureSide) + "-" +
                      std::to_string(sim::kMaxPictureSide) + ")")
      ->check(WholeNumberIn(sim::kMinPictureSide, sim::kMaxPictureSide));
  sub->add_option("--out,-o", flags->render.out, "The PNG to write")
      ->required()
      ->type_name("FILE.png");
  sub->add_option("--columns", flags->render.columns, "Frames per row (default: about square)")
      ->check(PositiveInteger());
  sub->add_flag("-q,--quiet", flags->render.quiet, "No progress lines");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
