// The pick-and-place family: task_type pick_and_place, pick_and_place_next_to and
// pick_and_place_color (spec A.5-7; docs/tasks.md).
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/datagen/tasks/pick_and_place/planner.h"
#include "mlspaces/datagen/tasks/pick_and_place/sampler.h"
#include "mlspaces/datagen/tasks/pick_and_place/success.h"
#include "mlspaces/datagen/tasks/task_family.h"
#include "tasks/families.h"

namespace mlspaces::datagen {
namespace {

class PickAndPlaceEpisode final : public TaskEpisode {
 public:
  PickAndPlaceEpisode(const Env& env, const ExperimentConfig& config, Task task,
                      std::string_view sampler)
      : TaskEpisode(env, config, std::move(task)) {
    if (!task_.place) {
      throw Error("task sampler '" + std::string(sampler) + "' chose no place target; task_type " +
                      std::string(EnumName(config.task_type)) +
                      " needs one (PickAndPlaceTaskSampler)",
                  "", "task_sampler_config.task_sampler_class");
    }
    place_body_ = env.BodyId(task_.place->receptacle);
    judge_.emplace(env.model(), object_, place_body_, task_.place->receptacle_start_pose,
                   config.task_type, config.task_config, env.robot().prefix);
  }

  void AddSampleInfo(Json& extra) const override {
    extra["place_receptacle"] = task_.place->receptacle;
  }

  PlanFailure Plan(PickPlanner& planner, const mjData* d, std::vector<Mat4> grasps) const override {
    const TaskConfig& t = config_.task_config;
    return static_cast<PickAndPlacePlanner&>(planner).ResetPlace(
        d, object_, place_body_, config_.task_type == TaskType::kPickAndPlaceNextTo,
        0.5 * (t.min_surface_to_surface_gap + t.max_surface_to_surface_gap), std::move(grasps));
  }

  void Judge(const mjData* d, PickSuccess& verdict) override {
    verdict_ = judge_->Evaluate(d);  // once per step, in order (the carry-forward memory)
    verdict.success = verdict_.success;
    verdict.reward = verdict_.reward;
  }

  void Record(EpisodeRecord& rec, const mjData* /*d*/, int64_t step,
              const PickSuccess& /*verdict*/) const override {
    rec.extra_json["task_info"].steps.push_back(verdict_.Info(config_.task_type, step));
  }

  void AddRolloutInfo(Json& extra, int64_t step) const override {
    extra["place"] = verdict_.Info(config_.task_type, step);
  }

  std::string FailureMessage(const PickSuccess& /*verdict*/, int64_t step) const override {
    return "the plan finished but the object is not placed: " +
           verdict_.Info(config_.task_type, step).dump();
  }

  std::string Description(const Registry& registry, const std::string& pickup) const override {
    return PlaceDescription(config_.task_type, pickup, PlaceReferral(registry), task_.place->color);
  }

  void AddToObsScene(const Registry& registry, const std::string& pickup,
                     Json& obs_scene) const override {
    // The original's pick-and-place records (spec A.5.6), the colour variant's colours.
    const TaskPlace& p = *task_.place;
    obs_scene["text"] =
        std::string(EnumName(config_.task_type)) + " " + task_.pickup_obj_name + " " + p.receptacle;
    obs_scene["place_receptacle_name"] = p.receptacle;
    obs_scene["referral_expressions"] =
        Json{{"pickup_name", Json::array({Json::array({pickup, 1.0})})},
             {"place_name", Json::array({Json::array({PlaceReferral(registry), 1.0})})}};
    Json& frozen = obs_scene["frozen_config"];
    frozen["place_receptacle_name"] = p.receptacle;
    frozen["place_receptacle_start_pose"] = ToArray7(p.receptacle_start_pose);
    if (config_.task_type == TaskType::kPickAndPlaceColor) {
      frozen["target_color"] = p.color;
      frozen["other_receptacle_names"] = p.other_receptacles;
      Json poses = Json::array();
      for (const Pose& q : p.other_receptacle_start_poses) poses.push_back(ToArray7(q));
      frozen["other_receptacle_start_poses"] = poses;
    }
  }

 private:
  // The place target's referral expression: its asset's category, else its body name.
  std::string PlaceReferral(const Registry& registry) const {
    const std::string& receptacle = task_.place->receptacle;
    const Json& objects = env_.metadata().value("objects", Json::object());
    const auto entry = objects.find(receptacle);
    std::string uid;
    if (entry != objects.end() && entry->is_object()) uid = entry->value("asset_id", "");
    return Referral(receptacle.substr(receptacle.rfind('/') + 1),
                    uid.empty() ? nullptr : registry.GetAnnotation(uid).get());
  }

  int place_body_ = -1;
  std::optional<PlaceJudge> judge_;
  PlaceVerdict verdict_;  // Judge's last
};

bool OwnsSampler(std::string_view sampler_class) {
  const std::string cls = Lower(sampler_class);
  return cls.starts_with("pickandplace") && cls.ends_with("tasksampler");
}

std::string SamplerRefusal(TaskType type, std::string_view sampler_class) {
  if (OwnsSampler(sampler_class)) return {};
  return "task_type " + std::string(EnumName(type)) +
         " needs a sampler that chooses a place target (PickAndPlaceTaskSampler, "
         "PickAndPlaceNextToTaskSampler, PickAndPlaceColorTaskSampler), not " +
         std::string(sampler_class);
}

}  // namespace

const TaskFamily& detail::PickAndPlaceFamily() {
  static const TaskFamily kFamily{"pick_and_place",
                                  IsPickAndPlaceTask,
                                  MakeFamilyPlanner<PickAndPlacePlanner>,
                                  MakeFamilyEpisode<PickAndPlaceEpisode>,
                                  SamplerRefusal,
                                  OwnsSampler};
  return kFamily;
}

}  // namespace mlspaces::datagen
