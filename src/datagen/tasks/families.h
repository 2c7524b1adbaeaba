// The task families (tasks/<family>/episode.cc), as task_family.cc lists them.
#pragma once

#include "mlspaces/datagen/tasks/task_family.h"

namespace mlspaces::datagen::detail {

const TaskFamily& PickFamily();
const TaskFamily& OpenCloseFamily();
const TaskFamily& PickAndPlaceFamily();

}  // namespace mlspaces::datagen::detail
