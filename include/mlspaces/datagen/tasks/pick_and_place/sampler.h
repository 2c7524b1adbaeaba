// The pick-and-place task samplers (spec A.5-7; docs/tasks.md), registered under the
// original's names: "PickAndPlaceTaskSampler" (= "PickAndPlaceReceptacleTaskSampler"),
// "PickAndPlaceNextToTaskSampler" and "PickAndPlaceColorTaskSampler".
//
// Scene build (AddAuxiliaryObjects, once per scene): receptacle assets of the user libraries
// (annotation receptacle true, primaryProperty CanPickup, boundingBox x, y in (0.17, 0.5] m and
// z <= 0.15 m, category in task_sampler_config.place_receptacle_types when given) are drawn
// (min(num_place_receptacles, n), without replacement, from a seed of the run seed and the
// scene) and inserted as "place_receptacle/<i>_<j>/<body>" (j: copies, 2 for colour) on a
// static staging floor 35 m above the scene. None found: an Error naming the field.
// Per episode (on the episode's Rng): reset + arm noise, the pickup object (the base's
// choice; receptacles are never candidates), robot base and object noise as block_pickup,
// then the place target:
//   receptacle / colour: receptacle uid (episode / episodes_per_receptacle) mod n, the
//     original's rotation by episode number (task_config.place_receptacle_name presets
//     it), placed around the pickup object at distance U(min, max
//     object_to_receptacle_dist), azimuth and yaw uniform, within
//     max_robot_to_place_receptacle_dist of the robot base (the original never enforces it),
//     inside the supporting geom's xy extent (boxes), its bottom 3 mm above the support top,
//     touching nothing but the support, its AABB >= 5 cm (xy) from the object's;
//     max_place_receptacle_sampling_attempts tries, then
//     TaskRejected. Colour: both copies placed, colours drawn from the 13 named colours.
//   next to: a scene object (not the pickup, not a receptacle) whose AABB bottom is within
//     5 cm of the pickup's and whose xy centre distance is in [min, max]; none: TaskRejected.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/library/registry.h"

namespace mlspaces::datagen {

/// One of the colour variant's 13 named colours (rgb in [0, 1]).
struct MLSPACES_API NamedColor {
  std::string_view name;
  std::array<float, 3> rgb;
};
/// The 13 colours of the original's colour task, in its order.
MLSPACES_API const std::vector<NamedColor>& PlaceColors();

/// True for task types pick_and_place, pick_and_place_next_to and pick_and_place_color.
MLSPACES_API bool IsPickAndPlaceTask(TaskType type);

/// The receptacle bodies added to `env`'s scene ("place_receptacle/..." top-level free
/// bodies), by body id.
MLSPACES_API std::vector<std::string> PlaceReceptacles(const Env& env);

class MLSPACES_API PickAndPlaceTaskSampler : public TaskSampler {
 public:
  /// Builds its own Registry from config.libraries (receptacle assets).
  PickAndPlaceTaskSampler(const ExperimentConfig& config, uint64_t run_seed);
  ~PickAndPlaceTaskSampler() override;

  void AddAuxiliaryObjects(sim::Scene& scene) override;

 protected:
  void SampleAndPlaceRobot(Env& env, Rng& rng, TaskDraft& draft) override;

 private:
  std::unique_ptr<Registry> registry_;
};

/// Registers the three samplers (and the alias PickAndPlaceReceptacleTaskSampler).
MLSPACES_API void RegisterPickAndPlaceSamplers(TaskSamplerRegistry& registry);

}  // namespace mlspaces::datagen
