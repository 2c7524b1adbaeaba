// The trajectory dataset schema (docs/dataset.md) in one place: the group, dataset and
// attribute names of a traj_<k> group, their types and shapes. The recorder writes by these
// names and validate-dataset checks by them.
//
// A traj_<k> group (T = observations) holds:
//   obs/agent/{qpos,qvel}                 uint8 (T, L) zero-padded JSON-object rows
//   actions/{commanded_action, ...}       uint8 (T, L) zero-padded JSON-object rows
//   rewards                               float32 (T,)
//   success, fail, terminated, truncated  1-byte bool enum (T,)
//   obs/extra/*, env_states/*             (T, ...) numeric series or uint8 (T, L) JSON rows
//   obs/sensor_data/<cam>[_depth]         the video file name (zero-padded string)
//   obs/sensor_param/<cam>/{cam2world_gl, extrinsic_cv, intrinsic_cv}  (T, rows, cols)
//   obs_scene                             scalar string, a JSON object
//   @provenance                           string attribute, a JSON object
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace mlspaces::datagen::schema {

/// Trajectory groups are kTrajPrefix + k (k = 0, 1, ... without leading zeros).
inline constexpr char kTrajPrefix[] = "traj_";
inline std::string TrajGroup(int64_t k) { return kTrajPrefix + std::to_string(k); }

// Groups, relative to a trajectory group.
inline constexpr char kAgent[] = "obs/agent";
inline constexpr char kActions[] = "actions";
inline constexpr char kExtra[] = "obs/extra";
inline constexpr char kEnvStates[] = "env_states";
inline constexpr char kSensorData[] = "obs/sensor_data";
inline constexpr char kSensorParam[] = "obs/sensor_param";

/// JSON-object rows under kAgent, in the order they are written.
inline constexpr std::array<const char*, 2> kAgentDatasets{"qpos", "qvel"};
/// JSON-object rows every trajectory has under kActions.
inline constexpr std::array<const char*, 5> kActionDatasets{"commanded_action", "joint_pos",
                                                            "joint_pos_rel", "ee_twist", "ee_pose"};
/// The row length (bytes) of the agent and action JSON rows.
inline constexpr size_t kJsonRowLen = 2000;

/// float32 (T,).
inline constexpr char kRewards[] = "rewards";
// 1-byte bool enums (T,).
inline constexpr char kSuccess[] = "success";
inline constexpr char kFail[] = "fail";
inline constexpr char kTerminated[] = "terminated";
inline constexpr char kTruncated[] = "truncated";
inline constexpr std::array<const char*, 4> kFlagDatasets{kSuccess, kFail, kTerminated, kTruncated};
/// Scalar string: a JSON object.
inline constexpr char kObsScene[] = "obs_scene";
/// String attribute of the trajectory group: a JSON object.
inline constexpr char kProvenance[] = "provenance";

/// The per-camera series under kSensorParam/<cam>: name and (rows, cols) per observation.
struct MLSPACES_API SensorParam {
  const char* name;
  int rows, cols;
};
inline constexpr std::array<SensorParam, 3> kSensorParams{
    {{"cam2world_gl", 4, 4}, {"extrinsic_cv", 3, 4}, {"intrinsic_cv", 3, 3}}};
/// kSensorData/<cam> + kDepthSuffix names a camera's depth video.
inline constexpr char kDepthSuffix[] = "_depth";

}  // namespace mlspaces::datagen::schema
