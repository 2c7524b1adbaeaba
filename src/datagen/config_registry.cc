// The built-in configs and the registry of named configs (config.h).
#include <algorithm>
#include <cctype>

#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/config.h"

namespace mlspaces::datagen {

std::vector<CameraConfig> CameraSystemConfig::DroidCameras() {
  CameraConfig wrist;
  wrist.name = "wrist_camera";
  wrist.type = CameraType::kMjcf;
  wrist.mjcf_name = "gripper/wrist_camera";
  wrist.robot_namespace = "robot_0/";
  wrist.fov = 56.74;
  CameraConfig exo;
  exo.name = "exo_camera_1";
  exo.type = CameraType::kRobotMounted;
  exo.reference_body_names = {"robot_0/fr3_link0"};
  exo.camera_offset = {0.1, 0.57, 0.66};
  exo.camera_quaternion = {-0.3633, -0.1241, 0.4263, 0.8191};
  exo.fov = 71.0;
  exo.visibility_constraints = {{"__task_objects__", 0.001}};
  return {wrist, exo};
}

ExperimentConfig CustomAssetsDataGenConfig() {
  ExperimentConfig c;
  c.scene_dataset = SceneDataset::kUser;
  c.num_workers = 1;
  c.robot_config.base_size.reset();
  c.camera_config = CameraSystemConfig{};
  TaskSamplerConfig& s = c.task_sampler_config;
  s.task_sampler_class = "block_pickup";
  s.dataset_name = SceneDataset::kUser;
  s.scene_xml_paths = {"scene.xml"};
  s.house_inds.reset();
  s.samples_per_house = 2;
  s.house_variant = "base";
  c.output_dir = "experiment_output";
  c.tag = "tutorial_franka_pick_custom_assets";
  AssetLibrarySpec assets;
  assets.name = "custom_assets";
  assets.dir = "asset_library";
  GraspLibrarySpec grasps;
  grasps.name = "custom_grasps";
  grasps.dir = "asset_library";
  grasps.asset_library = "custom_assets";
  c.libraries.asset_libraries = {assets};
  c.libraries.grasp_libraries = {grasps};
  return c;
}

ConfigRegistry ConfigRegistry::WithBuiltins() {
  ConfigRegistry registry;
  registry.RegisterConfig("PickBaseConfig", [] { return ExperimentConfig{}; });
  registry.RegisterConfig("CustomAssetsDataGenConfig", CustomAssetsDataGenConfig);
  return registry;
}

void ConfigRegistry::RegisterConfig(const std::string& name, ConfigFactory factory, bool replace) {
  if (name.empty() || std::any_of(name.begin(), name.end(), [](char c) {
        return std::isspace(static_cast<unsigned char>(c));
      })) {
    throw UsageError("config name '" + name + "' must be non-empty and without spaces");
  }
  if (!factory) throw UsageError("config " + name + ": the factory is empty");
  for (auto& [existing, f] : entries_) {
    if (Lower(existing) != Lower(name)) continue;
    if (!replace) throw UsageError("config " + name + " is already registered as " + existing);
    existing = name;
    f = std::move(factory);
    return;
  }
  entries_.emplace_back(name, std::move(factory));
}

bool ConfigRegistry::Contains(std::string_view name) const {
  const std::string key = Lower(name);
  return std::any_of(entries_.begin(), entries_.end(),
                     [&](const auto& e) { return Lower(e.first) == key; });
}

const std::string& ConfigRegistry::CanonicalName(std::string_view name) const {
  const std::string key = Lower(name);
  for (const auto& e : entries_) {
    if (Lower(e.first) == key) return e.first;
  }
  const std::vector<std::string> names = Names();
  const std::string hint = DidYouMean(name, names);
  throw Error("unknown config '" + std::string(name) + "' (" + (hint.empty() ? "" : hint + " ") +
              "registered: " + (names.empty() ? "none" : JoinNames(names)) + ")");
}

ExperimentConfig ConfigRegistry::Make(std::string_view name) const {
  const std::string& canonical = CanonicalName(name);
  for (const auto& e : entries_) {
    if (e.first == canonical) return e.second();
  }
  throw Error("unknown config '" + std::string(name) + "'");  // unreachable
}

std::vector<std::string> ConfigRegistry::Names() const {
  std::vector<std::string> names;
  for (const auto& e : entries_) names.push_back(e.first);
  return names;
}

}  // namespace mlspaces::datagen
