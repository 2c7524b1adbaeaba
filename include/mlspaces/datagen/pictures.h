// Pictures of the data engine's work (`mlspaces render scene|episode`, mlspaces.render): a
// datagen scene as the engine composes and samples it, and a recorded episode's camera frames
// at each planner phase.
//
// Episode frames come from the episode's MP4 (obs/sensor_data/<camera>): the frames the
// dataset holds, decoded, one per observation, so frame t is observation t exactly as stored.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/sim/pictures.h"

namespace mlspaces::datagen {

/// Which scene state ScenePicture shows.
struct MLSPACES_API SceneRequest {
  int64_t house = 0;    ///< index into scene_xml_paths
  int64_t episode = 0;  ///< the first episode number tried
  /// Run seed; null = the config's seed, else 0.
  std::optional<uint64_t> seed;
  /// Episodes tried from `episode` on while the sampler rejects them.
  int max_attempts = 20;
  /// Overview views (orbit views around the robot and the object) besides the cameras.
  int overview_views = 1;
};

/// The scene of house `request.house` composed with the robot as a datagen run composes it,
/// with the task of the first episode from `request.episode` on that the sampler accepts
/// (built-in samplers only), seen from the overview views and every configured camera, each
/// tile labelled ("overview", camera names), titled with the house, episode and task object.
/// `config` must be valid (Validate). @throws Error for a bad house, a scene or robot that
/// does not load, every attempt rejected (naming the last reason); Error from the Renderer.
MLSPACES_API sim::Image ScenePicture(const ExperimentConfig& config, const SceneRequest& request,
                                     const sim::PictureOptions& options);
/// ScenePicture with the task sampler given (e.g. one written in Python; never null), made
/// with the run seed the request asks for.
MLSPACES_API sim::Image ScenePicture(const ExperimentConfig& config, const SceneRequest& request,
                                     const sim::PictureOptions& options,
                                     std::unique_ptr<TaskSampler> sampler);

/// An episode of a dataset: its batch file and trajectory group.
struct MLSPACES_API EpisodeRef {
  std::filesystem::path file;  ///< trajectories_batch_<b>_of_<n>.h5
  std::string traj;            ///< traj_<k>
};

/// Every episode of a dataset in reading order, as mlspaces.read_dataset orders them:
/// house_<i> folders by i (or the folder itself when it holds batch files), batch files by b,
/// traj_<k> by k; a .h5 file gives its own episodes. @throws Error naming the path for a
/// missing path, a folder that is not a dataset, or a file that is not HDF5.
MLSPACES_API std::vector<EpisodeRef> ListEpisodes(const std::filesystem::path& dataset);

/// One frame of an episode at a phase change.
struct MLSPACES_API PhaseFrame {
  int64_t step = 0;        ///< observation index
  int64_t phase = 0;       ///< obs/extra/policy_phase[step]
  std::string phase_name;  ///< PolicyPhaseMap()'s name ("phase <n>" when unknown)
  sim::Image image;
};

struct MLSPACES_API EpisodeFrames {
  EpisodeRef episode;
  std::string camera;
  int64_t num_steps = 0;
  /// The first observation of each run of equal phases, then the last observation.
  std::vector<PhaseFrame> frames;
};

/// The frames of episode `index` (ListEpisodes order) of `dataset` from `camera` (empty: the
/// first camera of obs/sensor_data, sorted by name, depth videos left out) at each phase
/// change and at the end. @throws Error for an index out of range, an episode without
/// policy_phase or without videos, an unknown camera (naming the cameras), a missing or
/// corrupt video, or a video with fewer frames than observations.
MLSPACES_API EpisodeFrames EpisodePhaseFrames(const std::filesystem::path& dataset, int64_t index,
                                              const std::string& camera = {});

/// The frames in a grid labelled "step <t>: <phase>" (" (end)" on the last), titled
/// "<folder>/<file> <traj>, <camera>".
/// `tile_width` > 0 scales each frame to that width (nearest pixel, aspect kept).
MLSPACES_API sim::Image EpisodePhaseSheet(const EpisodeFrames& frames, int columns = 0,
                                          int tile_width = 0);

}  // namespace mlspaces::datagen
