#include "mlspaces/datagen/tasks/task_family.h"

#include <algorithm>
#include <array>
#include <string>
#include <utility>

#include "families.h"
#include "mlspaces/core/error.h"
#include "mlspaces/datagen/preflight.h"

namespace mlspaces::datagen {

TaskEpisode::TaskEpisode(const Env& env, const ExperimentConfig& config, Task task)
    : env_(env), config_(config), task_(std::move(task)) {
  object_ = env.BodyId(task_.pickup_obj_name);
}

TaskEpisode::~TaskEpisode() = default;

void TaskEpisode::AddSampleInfo(Json& /*extra*/) const {}

GraspSet TaskEpisode::LoadGrasps(const Registry& registry, const std::string& uid,
                                 const std::filesystem::path& metadata_file,
                                 const std::vector<std::string>& filter) const {
  return LoadPickupGrasps(registry, uid, task_.pickup_obj_name, metadata_file, filter);
}

void TaskEpisode::AddPlanInfo(const PickPlanner& /*planner*/, Json& /*extra*/) const {}

void TaskEpisode::DeclareSeries(EpisodeRecord& /*rec*/) const {}

void TaskEpisode::AddRolloutInfo(Json& /*extra*/, int64_t /*step*/) const {}

void TaskEpisode::AddToObsScene(const Registry& /*registry*/, const std::string& /*pickup*/,
                                Json& /*obs_scene*/) const {}

std::span<const TaskFamily* const> TaskFamilies() {
  // Adding a family: its folder under tasks/, its TaskType values, and a line here.
  static const std::array<const TaskFamily*, 3> kFamilies = {
      &detail::PickFamily(), &detail::OpenCloseFamily(), &detail::PickAndPlaceFamily()};
  return kFamilies;
}

const TaskFamily& TaskFamilyOf(TaskType type) {
  for (const TaskFamily* family : TaskFamilies()) {
    if (family->has_type(type)) return *family;
  }
  // Not EnumName: a value cast from a bad integer has no name.
  throw Error("task_type " + std::to_string(static_cast<int>(type)) + " has no task family", "",
              "task_type");
}

std::string Referral(const std::string& body, const Annotation* annotation) {
  if (annotation != nullptr && annotation->json.is_object()) {
    const auto it = annotation->json.find("category");
    if (it != annotation->json.end() && it->is_string() && !it->get<std::string>().empty()) {
      return it->get<std::string>();
    }
  }
  std::string out = body;
  std::replace(out.begin(), out.end(), '_', ' ');
  return out;
}

}  // namespace mlspaces::datagen
