// The open / close family: task_type open and close (spec A.3; docs/tasks.md).
#include <algorithm>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/datagen/tasks/open_close/planner.h"
#include "mlspaces/datagen/tasks/open_close/sampler.h"
#include "mlspaces/datagen/tasks/open_close/success.h"
#include "mlspaces/datagen/tasks/task_family.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "tasks/families.h"

namespace mlspaces::datagen {
namespace {

class OpenCloseEpisode final : public TaskEpisode {
 public:
  OpenCloseEpisode(const Env& env, const ExperimentConfig& config, Task task,
                   std::string_view sampler)
      : TaskEpisode(env, config, std::move(task)), threshold_(OpenCloseThreshold(config)) {
    if (!task_.joint) {
      throw Error("task sampler '" + std::string(sampler) + "' chose no joint; task_type " +
                      std::string(EnumName(config.task_type)) + " needs one (OpenTaskSampler)",
                  "", "task_sampler_config.task_sampler_class");
    }
    joint_id_ = mj_name2id(env.model(), mjOBJ_JOINT, task_.joint->name.c_str());
    if (joint_id_ < 0) {
      throw Error("task sampler '" + std::string(sampler) + "' chose joint '" + task_.joint->name +
                      "', which is not a joint of the scene",
                  "", "joint_name");
    }
  }

  void AddSampleInfo(Json& extra) const override { extra["joint"] = task_.joint->name; }

  GraspSet LoadGrasps(const Registry& registry, const std::string& uid,
                      const std::filesystem::path& /*metadata_file*/,
                      const std::vector<std::string>& filter) const override {
    return registry.LoadGrasps({uid, task_.joint->asset_joint, filter},
                               std::numeric_limits<size_t>::max());
  }

  PlanFailure Plan(PickPlanner& planner, const mjData* d, std::vector<Mat4> grasps) const override {
    // The articulation must be reachable past the success threshold, with a margin.
    const double min_fraction = std::min(1.0, threshold_ + 0.05);
    return static_cast<OpenClosePlanner&>(planner).ResetJoint(d, joint_id_, *task_.joint,
                                                              config_.task_type == TaskType::kOpen,
                                                              min_fraction, std::move(grasps));
  }

  void AddPlanInfo(const PickPlanner& planner, Json& extra) const override {
    extra["planned_fraction"] = static_cast<const OpenClosePlanner&>(planner).planned_fraction();
  }

  void DeclareSeries(EpisodeRecord& rec) const override {
    rec.extra["joint_position"] = Series(DType::kFloat32, {});
    rec.extra["joint_opened_fraction"] = Series(DType::kFloat32, {});
    rec.extra["joint_range"] = Series(DType::kFloat32, {2});
  }

  void Judge(const mjData* d, PickSuccess& verdict) override {
    verdict_ =
        EvaluateOpenClose(env_.model(), d, joint_id_, *task_.joint, config_.task_type, threshold_);
    verdict.success = verdict_.success;
    verdict.reward = verdict_.reward;
  }

  void Record(EpisodeRecord& rec, const mjData* /*d*/, int64_t step,
              const PickSuccess& /*verdict*/) const override {
    // The original's open / close task_info keys, plus the opened fraction.
    rec.extra["joint_position"].Append({verdict_.joint_position});
    rec.extra["joint_opened_fraction"].Append({verdict_.opened_fraction});
    rec.extra["joint_range"].Append({task_.joint->range_lo, task_.joint->range_hi});
    rec.extra_json["task_info"].steps.push_back(Json{{"joint_position", verdict_.joint_position},
                                                     {"opened_fraction", verdict_.opened_fraction},
                                                     {"success", verdict_.success},
                                                     {"episode_step", step}});
  }

  void AddRolloutInfo(Json& extra, int64_t /*step*/) const override {
    extra["opened_fraction"] = verdict_.opened_fraction;
  }

  std::string FailureMessage(const PickSuccess& /*verdict*/, int64_t /*step*/) const override {
    return "the plan finished with joint " + task_.joint->name + " at opened fraction " +
           std::to_string(verdict_.opened_fraction) + " (reward " +
           std::to_string(verdict_.reward) + " below " + std::to_string(threshold_) + ")";
  }

  std::string Description(const Registry& /*registry*/, const std::string& pickup) const override {
    // The joint body's name, when it is not the object's.
    std::string part = sim::MjName(env_.model(), mjOBJ_BODY, env_.model()->jnt_bodyid[joint_id_]);
    std::replace(part.begin(), part.end(), '_', ' ');
    return OpenCloseDescription(config_.task_type, pickup, part);
  }

  void AddToObsScene(const Registry& /*registry*/, const std::string& /*pickup*/,
                     Json& obs_scene) const override {
    // The chosen joint as explicit fields (the original keeps it only in a pickled config).
    const TaskJoint& j = *task_.joint;
    int index = 0;
    for (const ArticulatedJoint& a : ArticulatedJoints(env_, task_.pickup_obj_name)) {
      if (a.joint.name == j.name) index = a.index;
    }
    const Json joint{{"joint_name", j.name},
                     {"asset_joint_name", j.asset_joint},
                     {"joint_index", index},
                     {"joint_start_position", j.start},
                     {"joint_range", Json::array({j.range_lo, j.range_hi})},
                     {"joint_closed_position", j.closed},
                     {"joint_open_position", j.open},
                     {"task_success_threshold", threshold_}};
    for (const auto& [key, value] : joint.items()) obs_scene["frozen_config"][key] = value;
    obs_scene["joint"] = joint;
  }

 private:
  double threshold_;
  int joint_id_ = -1;
  OpenCloseVerdict verdict_;  // Judge's last
};

bool OwnsSampler(std::string_view sampler_class) {
  return Lower(sampler_class) == "opentasksampler";
}

std::string SamplerRefusal(TaskType type, std::string_view sampler_class) {
  if (Lower(sampler_class) != "block_pickup") return {};  // OpenTaskSampler, or a user's own
  return "task_type " + std::string(EnumName(type)) +
         " needs a sampler that chooses a joint (OpenTaskSampler), not block_pickup";
}

}  // namespace

const TaskFamily& detail::OpenCloseFamily() {
  static const TaskFamily kFamily{"open_close",
                                  IsOpenCloseTask,
                                  MakeFamilyPlanner<OpenClosePlanner>,
                                  MakeFamilyEpisode<OpenCloseEpisode>,
                                  SamplerRefusal,
                                  OwnsSampler};
  return kFamily;
}

}  // namespace mlspaces::datagen
