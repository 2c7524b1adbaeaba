// What one recorded episode holds, before it is written: per-step arrays, JSON dict sensors,
// cameras and provenance. Pure data (no HDF5, no MuJoCo); the Recorder writes it.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/json.h"

namespace mlspaces::datagen {

/// Element type of a numeric dataset. kBool is written as h5py's bool (int8 enum FALSE/TRUE).
enum class DType : uint8_t { kBool, kUint8, kInt32, kInt64, kFloat32, kFloat64 };

/// Name of a dtype as numpy spells it ("bool", "uint8", "int32", "int64", "float32", ...): a
/// static string, never null.
MLSPACES_API const char* DTypeName(DType dtype);
/// Size of one element in bytes.
MLSPACES_API size_t DTypeSize(DType dtype);

/// One per-step numeric dataset: a row of `row_shape` values per step, stored as `dtype`.
/// Its dataset shape is (T, *row_shape). Rows are appended in step order. The references its
/// accessors return are valid while the Series lives (Append grows bytes()).
class MLSPACES_API Series {
 public:
  Series() = default;
  /// An empty series of rows shaped `row_shape` ({} = one scalar per step).
  Series(DType dtype, std::vector<size_t> row_shape);

  /// Appends one row; `row` holds product(row_shape) values in row-major order, converted to
  /// dtype (float32 rounds, integers truncate toward zero and saturate, NaN -> 0; bool is
  /// value != 0).
  /// @throws Error if the row has the wrong number of values.
  void Append(const std::vector<double>& row);
  void Append(std::initializer_list<double> row) { Append(std::vector<double>(row)); }
  /// Appends one row of integers (exact for int64 values beyond 2^53).
  void AppendInts(const std::vector<int64_t>& row);
  /// A series of `steps` rows given as their raw bytes (what bytes() returns).
  /// @throws Error if `bytes` is not steps * row_size() elements of `dtype`.
  static Series FromBytes(DType dtype, std::vector<size_t> row_shape, size_t steps,
                          std::vector<unsigned char> bytes);

  DType dtype() const { return dtype_; }
  const std::vector<size_t>& row_shape() const { return row_shape_; }
  /// Values per row (product of row_shape; 1 for scalars).
  size_t row_size() const;
  size_t steps() const { return steps_; }
  /// Raw native-endian element bytes, steps() * row_size() elements.
  const std::vector<unsigned char>& bytes() const { return bytes_; }

 private:
  void CheckRow(size_t n) const;

  DType dtype_ = DType::kFloat32;
  std::vector<size_t> row_shape_;
  std::vector<unsigned char> bytes_;
  size_t steps_ = 0;
};

/// One per-step dict sensor. Each step is JSON-encoded as Python's
/// json.dumps(d, sort_keys=True, separators=(",", ":")) and stored zero-padded in a uint8
/// row of `max_len` bytes. A longer encoding widens the dataset instead of being truncated.
struct MLSPACES_API JsonSeries {
  std::vector<Json> steps;
  size_t max_len = 2000;
};

/// Values per move group ("arm", "base", "gripper"); an empty map is the JSON `{}`.
using MoveGroupValues = std::map<std::string, std::vector<double>>;

/// One camera of the episode. Per-step parameters go to obs/sensor_param/<name>/<key>
/// (cam2world_gl (T,4,4), extrinsic_cv (T,3,4), intrinsic_cv (T,3,3), all float64);
/// the video file names go to obs/sensor_data/<name> and obs/sensor_data/<name>_depth.
struct MLSPACES_API CameraRecord {
  std::string name;
  std::map<std::string, Series> params;
  /// The MP4 of this camera, a file name inside the recorder's folder (see
  /// Recorder::VideoFileName). Empty: no video (no sensor_data entry). The file must exist when
  /// the episode is written: a trajectory never names a missing video.
  std::string video_file;
  /// As video_file, for a depth video (obs/sensor_data/<name>_depth); usually empty.
  std::string depth_video_file;
};

/// Where an asset used by the episode came from.
struct MLSPACES_API AssetProvenance {
  std::string uid;
  std::string library;
  std::string license;
  std::string role;  ///< e.g. "pickup_obj", "scene", "robot"; may be empty
};

/// Provenance written with every episode (traj_k attribute "provenance", JSON).
struct MLSPACES_API EpisodeMetadata {
  std::string config_hash;       ///< required
  uint64_t seed = 0;             ///< the episode's own seed
  std::string scene;             ///< scene / house id, e.g. "house_0"
  int64_t source_episode = -1;   ///< episode number in the run (attempt counter), -1 = unknown
  std::string task_description;  ///< e.g. "Pick up the block"
  std::vector<AssetProvenance> assets;
  /// The run's licence policy ("all", "commercial_safe"); empty = not recorded (older runs).
  std::string license_policy;
  /// The robot (robot.yaml name) and its description hash (RobotDescription::hash); empty =
  /// not recorded (older runs).
  std::string robot, robot_description_hash;
  std::string mujoco_version;    ///< required, e.g. mj_versionString() of the running library
  std::string mlspaces_version;  ///< required
  Json extra = Json::object();   ///< anything else worth keeping (object)
};

/// One episode of T observations (T = 1 + number of policy steps). Every per-step member has
/// exactly T entries; observation i is paired with action row i (row 0 the dummy, the last row
/// the done sentinel), as the dataset format pairs them (docs/dataset.md).
struct MLSPACES_API EpisodeRecord {
  EpisodeMetadata meta;

  /// obs/agent/qpos and qvel: per step, values per move group. Stored as JSON with every value
  /// rounded to float32 (docs/dataset.md), rows of 2000 bytes.
  std::vector<MoveGroupValues> qpos, qvel;
  /// actions/<name> (commanded_action, joint_pos, joint_pos_rel, ee_twist, ee_pose): per step,
  /// values per move group, `{}` where the action is empty. JSON rows of 2000 bytes, float64.
  std::map<std::string, std::vector<MoveGroupValues>> actions;
  /// obs/extra/<path> numeric sensors; the path may nest ("object_image_points/gripper/
  /// wrist_camera/points").
  std::map<std::string, Series> extra;
  /// obs/extra/<path> dict sensors (task_info: max_len 4000, grasp_state_pickup_obj: 2000).
  std::map<std::string, JsonSeries> extra_json;
  /// env_states/<path>, e.g. "articulations/panda" (T,31) float32. Groups named in
  /// env_state_groups are created even when nothing is below them.
  std::map<std::string, Series> env_states;
  std::vector<std::string> env_state_groups = {"actors", "articulations"};
  std::vector<CameraRecord> cameras;

  std::vector<float> rewards;
  /// Per-step success flag; the episode's success is the last one (final state).
  std::vector<bool> success;
  /// What the task reported at each observation: terminated = done action received, truncated =
  /// horizon reached. Only the last row may be set, and it must set at least one of them.
  std::vector<bool> terminated, truncated;

  /// obs_scene (scalar string dataset, JSON): task_type, task_description, policy_dt_ms, ...
  Json obs_scene = Json::object();
};

/// Number of observations T (the size of qpos).
inline size_t NumSteps(const EpisodeRecord& r) { return r.qpos.size(); }

/// `record` as bytes (CBOR) that DecodeEpisodeRecord turns back into an equal record: every
/// number exact (NaN included), JSON key order kept. datagen --format lerobot keeps its
/// episodes so until the dataset is written (docs/lerobot.md).
MLSPACES_API std::string EncodeEpisodeRecord(const EpisodeRecord& record);
/// @throws Error naming `path_for_errors` when `bytes` are not an EncodeEpisodeRecord output.
MLSPACES_API EpisodeRecord DecodeEpisodeRecord(std::string_view bytes,
                                               const std::string& path_for_errors);

/// Python's json.dumps(value, sort_keys=True, separators=(",", ":")) (ASCII, non-ASCII escaped;
/// NaN and infinities as Python writes them: NaN, Infinity, -Infinity).
MLSPACES_API std::string DumpJsonCompactSorted(const Json& value);

/// MoveGroupValues as a JSON object; with `round_to_float32` every value is first rounded to
/// float32 (how qpos/qvel are stored, docs/dataset.md).
MLSPACES_API Json MoveGroupJson(const MoveGroupValues& values, bool round_to_float32);

}  // namespace mlspaces::datagen
