// The pick family: task_type pick (spec section 6; docs/datagen.md).
#include <memory>
#include <string>
#include <utility>

#include "mlspaces/datagen/tasks/task_family.h"
#include "mlspaces/sim/mj_pose.h"
#include "tasks/families.h"

namespace mlspaces::datagen {
namespace {

class PickEpisode final : public TaskEpisode {
 public:
  PickEpisode(const Env& env, const ExperimentConfig& config, Task task,
              std::string_view /*sampler*/)
      : TaskEpisode(env, config, std::move(task)), goal_(ToMat4(task_.pickup_obj_goal_pose)) {}

  PlanFailure Plan(PickPlanner& planner, const mjData* d, std::vector<Mat4> grasps) const override {
    return planner.Reset(d, object_, std::move(grasps));
  }

  void Judge(const mjData* /*d*/, PickSuccess& /*verdict*/) override {}

  void Record(EpisodeRecord& rec, const mjData* d, int64_t step,
              const PickSuccess& verdict) const override {
    const Mat4 obj = ToMat4(sim::BodyPose(d, object_));
    rec.extra_json["task_info"].steps.push_back(
        Json{{"episode_step", step},
             {"position_error", TranslationDistance(obj, goal_)},
             {"rotation_error", RotationAngle(obj, goal_)},
             {"success", verdict.success}});
  }

  std::string FailureMessage(const PickSuccess& verdict, int64_t /*step*/) const override {
    return "the plan finished but the object is not held: lift " + std::to_string(verdict.lift) +
           " m, " + std::to_string(verdict.robot_contacts) + " robot / " +
           std::to_string(verdict.other_contacts) + " other contacts";
  }

  std::string Description(const Registry& /*registry*/, const std::string& pickup) const override {
    return "Pick up the " + pickup;
  }

 private:
  Mat4 goal_;
};

bool HasType(TaskType type) { return type == TaskType::kPick; }

// Any sampler may draw pick tasks; the other families' own samplers are refused by theirs.
std::string SamplerRefusal(TaskType /*type*/, std::string_view /*sampler_class*/) { return {}; }
bool OwnsSampler(std::string_view /*sampler_class*/) { return false; }

}  // namespace

const TaskFamily& detail::PickFamily() {
  static const TaskFamily kFamily{
      "pick",         HasType,    MakeFamilyPlanner<PickPlanner>, MakeFamilyEpisode<PickEpisode>,
      SamplerRefusal, OwnsSampler};
  return kFamily;
}

}  // namespace mlspaces::datagen
