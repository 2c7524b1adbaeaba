// The open gripper of any robot (include/mlspaces/graspgen/antipodal.h, GripperProxyOf).
#include "gripper_proxy.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>

#include "mlspaces/core/error.h"
#include "mlspaces/graspgen/antipodal.h"
#include "mlspaces/graspgen/generate.h"
#include "mlspaces/graspgen/mesh.h"
#include "mlspaces/robots/robot_spec.h"
#include "mlspaces/sim/mj_pose.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::graspgen {

OrientedBox GeomBox(const mjModel* m, const mjData* d, int g, const Mat4& world_to_frame) {
  OrientedBox b;
  const Mat4 t = world_to_frame * sim::GeomBoxFrame(m, d, g, &b.half);
  b.center = Translation(t);
  b.rot = Rotation(t);
  return b;
}

GripperProxy GripperProxyOf(const robots::RobotSpec& robot) {
  const std::string file =
      robot.description_file.empty() ? robot.xml.string() : robot.description_file.string();
  const sim::ModelPtr model = sim::ComposeAndCompile(robot.xml);
  const mjModel* m = model.get();
  const auto id = [&](mjtObj type, const std::string& name, const std::string& field) {
    const int i = mj_name2id(m, type, name.c_str());
    if (i < 0) {
      throw Error(
          "no " + std::string(mju_type2Str(type)) + " '" + name + "' in " + robot.xml.string(),
          file, field);
    }
    return i;
  };
  const int root = id(mjOBJ_BODY, robot.gripper_body, "gripper.body");
  const int site = id(mjOBJ_SITE, robot.tcp_site, "tcp_site");
  const sim::DataPtr data = sim::MakeData(m);
  mj_kinematics(m, data.get());  // qpos0: the fingers open (as GraspScene's hand)
  const Mat4 world_to_tcp = InverseRigid(sim::SiteMat4(data.get(), site));

  GripperProxy g;
  g.name = robot.name;
  for (int geom : sim::CollisionGeoms(m, root)) {
    g.boxes.push_back(GeomBox(m, data.get(), geom, world_to_tcp));
  }
  if (g.boxes.empty()) {
    throw Error("the gripper body '" + robot.gripper_body + "' has no collision geom below it",
                file, "gripper.body");
  }
  // The closing rays: from each pad's centre across y, over the pads' extent along z.
  OrientedBox pads[2];
  for (int side = 0; side < 2; ++side) {
    const int pad = id(mjOBJ_GEOM, robot.finger_pads[side], "gripper.finger_pads");
    if (!sim::InSubtree(m, m->geom_bodyid[pad], root)) {
      throw Error("finger pad '" + robot.finger_pads[side] + "' is not below " + robot.gripper_body,
                  file, "gripper.finger_pads");
    }
    pads[side] = GeomBox(m, data.get(), pad, world_to_tcp);
  }
  if (!(pads[0].center[1] * pads[1].center[1] < 0)) {
    throw Error("the finger pads '" + robot.finger_pads[0] + "' and '" + robot.finger_pads[1] +
                    "' do not face each other across the TCP's y axis (y " +
                    std::to_string(pads[0].center[1]) + " and " +
                    std::to_string(pads[1].center[1]) + ")",
                file, "gripper.finger_pads");
  }
  g.finger_offset = 0.5 * (std::abs(pads[0].center[1]) + std::abs(pads[1].center[1]));
  // The hand must be open at qpos0 (the simulation starts it there too): the pads' inner
  // faces as far apart as robot.yaml says the fingers open, within a fifth.
  double gap = 2 * g.finger_offset;
  for (const OrientedBox& pad : pads) {
    for (int k = 0; k < 3; ++k) gap -= std::abs(pad.rot[3 + k]) * pad.half[k];
  }
  const double open = robot.finger_range[1];
  if (gap < 0.8 * open) {
    throw Error("the gripper is not open at the MJCF's qpos0: its pads' inner faces are " +
                    std::to_string(static_cast<int>(std::lround(gap * 1000))) +
                    " mm apart, gripper.finger_range opens them " +
                    std::to_string(static_cast<int>(std::lround(open * 1000))) +
                    " mm (grasp generation takes the hand at qpos0 as open)",
                file, "gripper.finger_range");
  }
  double lo = 0, hi = 0;  // the pads' common extent along the TCP z
  for (int side = 0; side < 2; ++side) {
    double reach = 0;
    for (int k = 0; k < 3; ++k) reach += std::abs(pads[side].rot[6 + k]) * pads[side].half[k];
    const double a = pads[side].center[2] - reach, b = pads[side].center[2] + reach;
    lo = side == 0 ? a : std::max(lo, a);
    hi = side == 0 ? b : std::min(hi, b);
  }
  if (!(hi > lo)) {
    throw Error("the finger pads '" + robot.finger_pads[0] + "' and '" + robot.finger_pads[1] +
                    "' do not overlap along the TCP's z axis",
                file, "gripper.finger_pads");
  }
  constexpr int kLevels = 20;
  for (int k = 0; k < kLevels; ++k) g.ray_levels.push_back(lo + (hi - lo) * k / (kLevels - 1));
  return g;
}

GraspReadiness CheckGraspGeneration(const robots::RobotSpec& robot) {
  GraspReadiness r;
  try {
    r.gripper = GripperProxyOf(robot);
    r.ready = true;
  } catch (const Error& e) {
    r.problem = e.what();
  }
  try {
    std::error_code ec;
    r.on_search_path =
        std::filesystem::equivalent(robots::FindRobot(robot.name), robot.description_file, ec);
  } catch (const Error&) {
    r.on_search_path = false;  // a robot.yaml given by path, its name found nowhere
  }
  return r;
}

GraspReadiness CheckGraspGeneration(std::string_view name_or_path) {
  robots::RobotSpec robot;
  try {
    robot = robots::LoadRobotSpec(name_or_path);
  } catch (const Error& e) {
    GraspReadiness r;
    r.problem = e.what();
    return r;
  }
  return CheckGraspGeneration(robot);
}

Json ToJson(const GraspReadiness& r) {
  Json j{{"ready", r.ready}};
  if (!r.ready) {
    j["problem"] = r.problem;
  } else {
    j["gripper_boxes"] = r.gripper.boxes.size();
    j["finger_offset"] = r.gripper.finger_offset;
    j["ray_levels"] = Json::array({r.gripper.ray_levels.front(), r.gripper.ray_levels.back()});
  }
  j["on_search_path"] = r.on_search_path;
  return j;
}

std::string FormatGraspReadiness(const GraspReadiness& r, const std::string& robot_name) {
  if (!r.ready) return "grasp generation: not possible: " + r.problem + "\n";
  char what[160];
  std::snprintf(what, sizeof what,
                "%zu gripper boxes, closing rays %.4f m either side of the TCP over z [%.4f, "
                "%.4f] m",
                r.gripper.boxes.size(), r.gripper.finger_offset, r.gripper.ray_levels.front(),
                r.gripper.ray_levels.back());
  std::string line = "grasp generation: ready (" + std::string(what) +
                     "): mlspaces generate-grasps --robot " + robot_name;
  if (!r.on_search_path) {
    line += " (once its folder's parent is on $MLSPACES_ROBOT_PATH)";
  }
  return line + "\n";
}

}  // namespace mlspaces::graspgen
