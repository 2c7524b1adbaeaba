// Open / close success (tasks/open_close/success.h).
#include "mlspaces/datagen/tasks/open_close/success.h"

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/tasks/open_close/planner.h"

namespace mlspaces::datagen {

double OpenCloseThreshold(const ExperimentConfig& config) {
  if (config.task_config.task_success_threshold) return *config.task_config.task_success_threshold;
  return config.task_type == TaskType::kClose ? 0.85 : 0.15;
}

OpenCloseVerdict EvaluateOpenClose(const mjModel* m, const mjData* d, int joint_id,
                                   const TaskJoint& joint, TaskType type, double threshold) {
  if (joint_id < 0 || joint_id >= m->njnt) {
    throw UsageError("EvaluateOpenClose: bad joint id " + std::to_string(joint_id));
  }
  if (type != TaskType::kOpen && type != TaskType::kClose) {
    throw UsageError("EvaluateOpenClose: task type " + std::string(EnumName(type)) +
                     " is not open or close");
  }
  OpenCloseVerdict v;
  v.joint_position = d->qpos[m->jnt_qposadr[joint_id]];
  v.opened_fraction = OpenedFraction(joint, v.joint_position);
  v.reward = type == TaskType::kOpen ? v.opened_fraction : 1.0 - v.opened_fraction;
  v.success = v.reward >= threshold;
  return v;
}

std::string OpenCloseDescription(TaskType type, const std::string& expr, const std::string& part) {
  std::string out = type == TaskType::kClose ? "Close the " : "Open the ";
  if (!part.empty() && part != expr) out += part + " of the ";
  return out + expr;
}

}  // namespace mlspaces::datagen
