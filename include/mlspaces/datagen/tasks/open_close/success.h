// Open / close success and reward, judged on the chosen joint (spec A.3.7; docs/tasks.md).
//
// open:  reward = opened fraction |q - closed| / |open - closed|, success = reward >= threshold
// close: reward = 1 - opened fraction,                              success = reward >= threshold
// threshold: task_config.task_success_threshold, else 0.15 (open) / 0.85 (close) as the
// original. Unlike the original's open rule, no other joint or object counts.
#pragma once

#include "mlspaces/core/export.h"

#include <string>

#include <mujoco/mujoco.h>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/task_sampler.h"

namespace mlspaces::datagen {

struct MLSPACES_API OpenCloseVerdict {
  double joint_position = 0;  ///< qpos of the joint
  double opened_fraction = 0;
  double reward = 0;
  bool success = false;
};

/// The threshold in force for `config` (task_success_threshold or the task type's default).
MLSPACES_API double OpenCloseThreshold(const ExperimentConfig& config);

/// Judges joint `joint_id` (sampled as `joint`) on `d`. @throws UsageError for a bad joint id
/// or a task type other than open / close.
MLSPACES_API OpenCloseVerdict EvaluateOpenClose(const mjModel* m, const mjData* d, int joint_id,
                                                const TaskJoint& joint, TaskType type,
                                                double threshold);

/// The task description: "Open the <expr>" / "Close the <expr>", with "the <part> of" before
/// the object when the joint's body has its own name (e.g. "Open the drawer of the cabinet").
MLSPACES_API std::string OpenCloseDescription(TaskType type, const std::string& expr,
                                              const std::string& part);

}  // namespace mlspaces::datagen
