#include "mlspaces/robots/robot_spec.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <regex>
#include <system_error>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/sim/compute_metadata.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::robots {
namespace {

namespace fs = std::filesystem;

constexpr char kRobotYaml[] = "robot.yaml";

// Collects "<field>: <problem>" pairs; the loader throws the first, inspect prints them all.
struct Problems {
  std::vector<std::pair<std::string, std::string>> items;
  void Add(std::string field, std::string message) {
    items.emplace_back(std::move(field), std::move(message));
  }
};

std::string Indexed(const std::string& key, size_t i) {
  return key + "[" + std::to_string(i) + "]";
}

void CheckFinite(Problems& p, const std::string& key, const std::vector<double>& values) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) p.Add(Indexed(key, i), "not a finite number");
  }
}

// Required fields, lengths, finite numbers: what needs no MJCF.
void CheckFields(const RobotDescription& d, Problems& p) {
  static const std::regex kName("[a-z0-9_]+");
  if (d.name.empty()) {
    p.Add("name", "missing (the robot's name, e.g. xarm7)");
  } else if (!std::regex_match(d.name, kName)) {
    p.Add("name", "'" + d.name + "' must be lower-case letters, digits and _");
  }
  if (d.mjcf.empty()) p.Add("mjcf", "missing (the robot's MJCF file, relative to robot.yaml)");
  if (d.root_body.empty()) p.Add("root_body", "missing (the arm's root body in the MJCF)");
  if (d.tcp_site.empty()) p.Add("tcp_site", "missing (the TCP site)");
  if (d.arm.joints.empty()) p.Add("arm.joints", "missing (the arm joints, base to tip)");
  if (d.arm.home.size() != d.arm.joints.size()) {
    p.Add("arm.home", std::to_string(d.arm.home.size()) + " values for " +
                          std::to_string(d.arm.joints.size()) + " arm joints");
  }
  CheckFinite(p, "arm.home", d.arm.home);
  if (d.arm.actuators && d.arm.actuators->size() != d.arm.joints.size()) {
    p.Add("arm.actuators", std::to_string(d.arm.actuators->size()) + " actuators for " +
                               std::to_string(d.arm.joints.size()) + " arm joints");
  }
  if (d.arm.home_noise) {
    if (d.arm.home_noise->size() != d.arm.joints.size()) {
      p.Add("arm.home_noise", std::to_string(d.arm.home_noise->size()) + " values for " +
                                  std::to_string(d.arm.joints.size()) + " arm joints");
    }
    CheckFinite(p, "arm.home_noise", *d.arm.home_noise);
    for (size_t i = 0; i < d.arm.home_noise->size(); ++i) {
      if ((*d.arm.home_noise)[i] < 0) p.Add(Indexed("arm.home_noise", i), "must be >= 0");
    }
  }
  const GripperDescription& g = d.gripper;
  if (g.body.empty()) p.Add("gripper.body", "missing (the gripper's root body)");
  if (g.actuator.empty()) p.Add("gripper.actuator", "missing (the gripper actuator)");
  if (g.home.size() != g.joints.size()) {
    p.Add("gripper.home", std::to_string(g.home.size()) + " values for " +
                              std::to_string(g.joints.size()) + " gripper joints");
  }
  CheckFinite(p, "gripper.home", g.home);
  CheckFinite(p, "gripper.open_ctrl", {g.open_ctrl});
  CheckFinite(p, "gripper.closed_ctrl", {g.closed_ctrl});
  if (g.open_ctrl == g.closed_ctrl) {
    p.Add("gripper.closed_ctrl", "equals open_ctrl: the gripper could not close");
  }
  for (size_t k = 0; k < 2; ++k) {
    if (g.finger_pads[k].empty()) p.Add(Indexed("gripper.finger_pads", k), "missing");
  }
  CheckFinite(p, "gripper.finger_range", {g.finger_range[0], g.finger_range[1]});
  if (!(g.finger_range[0] >= 0 && g.finger_range[0] < g.finger_range[1])) {
    p.Add("gripper.finger_range", "must be [closed, open] with 0 <= closed < open (metres)");
  }
  for (size_t i = 0; i < d.cameras.size(); ++i) {
    const RobotCamera& c = d.cameras[i];
    const std::string key = Indexed("cameras", i);
    if (c.name.empty()) p.Add(key + ".name", "missing");
    if (c.type == "mjcf") {
      if (!c.mjcf_name) p.Add(key + ".mjcf_name", "missing (an mjcf camera names its camera)");
    } else if (c.type == "robot_mounted") {
      if (!c.reference_body) p.Add(key + ".reference_body", "missing (the body it rides on)");
    } else {
      p.Add(key + ".type", "'" + c.type + "' is not mjcf or robot_mounted");
    }
    if (!(c.fov > 0 && c.fov < 180)) p.Add(key + ".fov", "must be in (0, 180) degrees");
    CheckFinite(p, key + ".offset", {c.offset.begin(), c.offset.end()});
    CheckFinite(p, key + ".quaternion", {c.quaternion.begin(), c.quaternion.end()});
  }
  if (d.record.articulation && d.record.articulation->empty()) {
    p.Add("record.articulation", "must not be empty");
  }
  if (d.record.articulation_width && *d.record.articulation_width == 0) {
    p.Add("record.articulation_width", "must be > 0");
  }
}

bool IsTopBody(const mjModel* m, int body) { return body > 0 && m->body_parentid[body] == 0; }

// Every listed name against the MJCF compiled alone.
void CheckNames(const RobotDescription& d, const mjModel* m, Problems& p) {
  const std::string model = d.mjcf.filename().string();
  auto find = [&](mjtObj type, const std::string& name, const std::string& key, const char* what) {
    const int id = mj_name2id(m, type, name.c_str());
    if (id < 0) p.Add(key, std::string(what) + " '" + name + "' is not in " + model);
    return id;
  };
  const int root = find(mjOBJ_BODY, d.root_body, "root_body", "body");
  if (d.base.body) {
    const int base = find(mjOBJ_BODY, *d.base.body, "base.body", "body");
    if (base >= 0 && !IsTopBody(m, base)) {
      p.Add("base.body", "'" + *d.base.body + "' is not a top-level body of " + model);
    } else if (base >= 0 && d.base.kind == BaseKind::kMocap && m->body_mocapid[base] < 0) {
      p.Add("base.body", "'" + *d.base.body + "' is not a mocap body (base.kind is mocap)");
    } else if (base >= 0 && d.base.kind != BaseKind::kMocap) {
      p.Add("base.kind", "a base body inside the MJCF is supported for kind mocap only");
    }
    if (root >= 0 && base >= 0 && m->body_parentid[root] != base) {
      p.Add("root_body",
            "'" + d.root_body + "' is not a child of the base body '" + *d.base.body + "'");
    }
  }
  find(mjOBJ_SITE, d.tcp_site, "tcp_site", "site");
  for (size_t i = 0; i < d.arm.joints.size(); ++i) {
    const std::string key = Indexed("arm.joints", i);
    const int j = find(mjOBJ_JOINT, d.arm.joints[i], key, "joint");
    if (j >= 0 && m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE) {
      p.Add(key, "joint '" + d.arm.joints[i] + "' is not a hinge or slide joint");
    }
    const std::string act_name = d.arm.actuators ? (*d.arm.actuators)[i] : d.arm.joints[i];
    const std::string act_key = d.arm.actuators ? Indexed("arm.actuators", i) : key;
    const int a = find(mjOBJ_ACTUATOR, act_name, act_key, "actuator");
    if (a >= 0 && j >= 0 &&
        (m->actuator_trntype[a] != mjTRN_JOINT || m->actuator_trnid[2 * a] != j)) {
      p.Add(act_key, "actuator '" + act_name + "' does not drive joint '" + d.arm.joints[i] + "'");
    }
    if (j >= 0 && i < d.arm.home.size() && m->jnt_limited[j]) {
      const double lo = m->jnt_range[2 * j], hi = m->jnt_range[2 * j + 1];
      if (d.arm.home[i] < lo || d.arm.home[i] > hi) {
        p.Add(Indexed("arm.home", i), std::to_string(d.arm.home[i]) + " is outside joint '" +
                                          d.arm.joints[i] + "''s range [" + std::to_string(lo) +
                                          ", " + std::to_string(hi) + "]");
      }
    }
  }
  const GripperDescription& g = d.gripper;
  const int gbody = find(mjOBJ_BODY, g.body, "gripper.body", "body");
  const int gact = find(mjOBJ_ACTUATOR, g.actuator, "gripper.actuator", "actuator");
  if (gact >= 0 && m->actuator_ctrllimited[gact]) {
    const double lo = m->actuator_ctrlrange[2 * gact], hi = m->actuator_ctrlrange[2 * gact + 1];
    for (auto [key, v] : {std::pair{"gripper.open_ctrl", g.open_ctrl},
                          std::pair{"gripper.closed_ctrl", g.closed_ctrl}}) {
      if (v < lo || v > hi) {
        p.Add(key, std::to_string(v) + " is outside the actuator's ctrlrange [" +
                       std::to_string(lo) + ", " + std::to_string(hi) + "]");
      }
    }
  }
  for (size_t i = 0; i < g.joints.size(); ++i) {
    find(mjOBJ_JOINT, g.joints[i], Indexed("gripper.joints", i), "joint");
  }
  for (size_t i = 0; i < g.mirrored.size(); ++i) {
    for (size_t k = 0; k < 2; ++k) {
      find(mjOBJ_JOINT, g.mirrored[i][k], Indexed(Indexed("gripper.mirrored", i), k), "joint");
    }
  }
  for (size_t k = 0; k < 2; ++k) {
    const int geom = find(mjOBJ_GEOM, g.finger_pads[k], Indexed("gripper.finger_pads", k), "geom");
    if (geom >= 0 && gbody >= 0) {
      bool inside = false;
      for (int b = m->geom_bodyid[geom]; b > 0 && !inside; b = m->body_parentid[b]) {
        inside = b == gbody;
      }
      if (!inside) {
        p.Add(Indexed("gripper.finger_pads", k),
              "geom '" + g.finger_pads[k] + "' is not in the gripper body '" + g.body + "'");
      }
    }
  }
  for (size_t i = 0; i < d.cameras.size(); ++i) {
    const RobotCamera& c = d.cameras[i];
    if (c.type == "mjcf" && c.mjcf_name) {
      find(mjOBJ_CAMERA, *c.mjcf_name, Indexed("cameras", i) + ".mjcf_name", "camera");
    } else if (c.type == "robot_mounted" && c.reference_body) {
      find(mjOBJ_BODY, *c.reference_body, Indexed("cameras", i) + ".reference_body", "body");
    }
  }
  for (const auto& [from, to] : d.aliases) {
    const bool known = mj_name2id(m, mjOBJ_BODY, to.c_str()) >= 0 ||
                       mj_name2id(m, mjOBJ_CAMERA, to.c_str()) >= 0 ||
                       mj_name2id(m, mjOBJ_SITE, to.c_str()) >= 0;
    if (!known) p.Add("aliases." + from, "'" + to + "' is no body, camera or site of " + model);
  }
}

// Reads and checks; fills `out` as far as it could be read.
Problems Check(const fs::path& given, std::optional<RobotDescription>* out, fs::path* yaml_file,
               const fs::path& mjcf_dir = {}) {
  Problems p;
  std::error_code ec;
  fs::path file = fs::is_directory(given, ec) ? given / kRobotYaml : given;
  file = fs::absolute(file).lexically_normal();
  *yaml_file = file;
  RobotDescription d;
  // Relative paths (mjcf) resolve against the robot.yaml's folder, or mjcf_dir when given.
  const YamlReader reader(
      YamlContext{file.string(), mjcf_dir.empty() ? file.parent_path() : mjcf_dir});
  reader.Read(LoadYamlFile(file, "robot description"), "", d);  // throws: nothing to go on
  d.file = file;
  CheckFields(d, p);
  if (out != nullptr) *out = d;
  if (d.mjcf.empty()) return p;
  if (!fs::is_regular_file(d.mjcf, ec)) {
    p.Add("mjcf", "file not found: " + d.mjcf.string());
    return p;
  }
  sim::ModelPtr model;
  try {
    sim::MjcfComposer composer(d.mjcf);
    model = composer.Compile();
    std::string hash = SourceFileHash(file);
    for (const fs::path& source : sim::AssetSourceFiles(composer)) {
      hash += SourceFileHash(source);
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx",
                  static_cast<unsigned long long>(HashString(hash)));  // NOLINT(runtime/int)
    d.hash = hex;
  } catch (const Error& e) {
    p.Add("mjcf", std::string("does not compile: ") + e.what());
    if (out != nullptr) *out = d;
    return p;
  }
  CheckNames(d, model.get(), p);
  if (out != nullptr) *out = d;
  return p;
}

std::string JoinRobotNames() {
  const std::vector<std::string> names = BundledRobots();
  return names.empty() ? "none" : JoinNames(names);
}

}  // namespace

RobotDescription LoadRobotDescription(const std::filesystem::path& file,
                                      const std::filesystem::path& mjcf_dir) {
  std::optional<RobotDescription> out;
  fs::path yaml;
  const Problems p = Check(file, &out, &yaml, mjcf_dir);
  if (!p.items.empty()) throw Error(p.items[0].second, yaml.string(), p.items[0].first);
  return *out;
}

std::vector<std::string> CheckRobotDescription(const std::filesystem::path& file,
                                               std::optional<RobotDescription>* out) {
  std::vector<std::string> lines;
  fs::path yaml;
  try {
    const Problems p = Check(file, out, &yaml);
    for (const auto& [field, message] : p.items) {
      lines.push_back(Error(message, yaml.string(), field).what());
    }
  } catch (const Error& e) {
    lines.emplace_back(e.what());
  }
  return lines;
}

std::filesystem::path RobotsDir() {
  if (const char* dir = std::getenv("MLSPACES_ROBOTS_DIR"); dir != nullptr && *dir != 0) {
    return dir;
  }
  // The source tree's copy while it exists (a build tree); an installed package's copy
  // (`cmake --install`: <prefix>/share/mlspaces/robots) once the sources are gone.
  fs::path source = MLSPACES_DEFAULT_ROBOTS_DIR;
  if (std::error_code ec; fs::is_directory(source, ec)) return source;
  return MLSPACES_INSTALLED_ROBOTS_DIR;
}

std::vector<std::filesystem::path> RobotSearchPath() {
  std::vector<fs::path> dirs;
  if (const char* path = std::getenv("MLSPACES_ROBOT_PATH"); path != nullptr) {
    std::string_view rest = path;
    while (!rest.empty()) {
      const size_t colon = rest.find(':');
      const std::string_view dir = rest.substr(0, colon);
      if (!dir.empty()) dirs.emplace_back(dir);
      rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    }
  }
  dirs.push_back(RobotsDir());
  return dirs;
}

std::vector<std::string> BundledRobots() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const fs::path& dir : RobotSearchPath()) {
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (fs::is_regular_file(entry.path() / kRobotYaml, ec)) {
        names.push_back(entry.path().filename().string());
      }
    }
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  return names;
}

std::filesystem::path FindRobot(std::string_view name_or_path,
                                const std::filesystem::path& base_dir, const std::string& field) {
  const std::string given(name_or_path);
  std::error_code ec;
  const bool is_path =
      given.find('/') != std::string::npos || given.ends_with(".yaml") || given.ends_with(".yml");
  if (is_path) {
    fs::path path = given;
    if (path.is_relative() && !base_dir.empty()) path = base_dir / path;
    if (fs::is_directory(path, ec)) path /= kRobotYaml;
    if (!fs::is_regular_file(path, ec)) {
      throw Error("no robot description (robot.yaml) at " + path.string(), "", field);
    }
    return path;
  }
  for (const fs::path& dir : RobotSearchPath()) {
    fs::path file = dir / given / kRobotYaml;
    if (!given.empty() && fs::is_regular_file(file, ec)) return file;
  }
  const std::string hint = DidYouMean(given, BundledRobots());
  throw Error("unknown robot '" + given + "' (mlspaces has: " + JoinRobotNames() +
                  "; or give the path of a robot.yaml)" + (hint.empty() ? "" : "; " + hint),
              "", field);
}

std::string RobotSpec::Resolve(const std::string& name) const {
  const auto it = aliases.find(name);
  return it == aliases.end() ? name : it->second;
}

RobotSpec MakeRobotSpec(const RobotDescription& d, std::string prefix) {
  RobotSpec s;
  s.name = d.name;
  s.xml = d.mjcf;
  s.description_file = d.file;
  s.description_hash = d.hash;
  s.prefix = std::move(prefix);
  s.base_kind = d.base.kind;
  s.base_in_model = d.base.body.has_value();
  s.base_body = d.base.body.value_or("base");
  s.arm_joints = d.arm.joints;
  s.arm_actuators = d.arm.actuators.value_or(d.arm.joints);
  s.gripper_joints = d.gripper.joints;
  s.mirrored_joints.clear();
  for (const auto& pair : d.gripper.mirrored) s.mirrored_joints.emplace_back(pair[0], pair[1]);
  s.home_arm = d.arm.home;
  s.home_gripper = d.gripper.home;
  s.home_noise = d.arm.home_noise.value_or(std::vector<double>{});
  s.pedestal_size.reset();
  s.gravcomp = d.gravcomp;
  s.arm_root_body = d.root_body;
  s.gripper_body = d.gripper.body;
  s.gripper_actuator = d.gripper.actuator;
  s.gripper_open_ctrl = d.gripper.open_ctrl;
  s.gripper_closed_ctrl = d.gripper.closed_ctrl;
  s.tcp_site = d.tcp_site;
  s.finger_pads = d.gripper.finger_pads;
  s.finger_range = d.gripper.finger_range;
  s.articulation_name = d.record.articulation.value_or(d.name);
  s.articulation_width =
      d.record.articulation_width.value_or(2 * (d.arm.joints.size() + d.gripper.joints.size()));
  s.aliases = d.aliases;
  s.cameras = d.cameras;
  return s;
}

RobotSpec LoadRobotSpec(std::string_view name_or_path, std::string prefix) {
  return MakeRobotSpec(LoadRobotDescription(FindRobot(name_or_path)), std::move(prefix));
}

}  // namespace mlspaces::robots
