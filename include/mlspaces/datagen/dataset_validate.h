// `mlspaces validate-dataset`: deep checks of a generated trajectory dataset (a datagen run
// folder, or any folder of trajectory files) against the schema in docs/dataset.md.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/core/diagnostics.h"

namespace mlspaces::datagen {

/// One problem: path = the file or folder concerned (an HDF5 file, a video, a temp file),
/// field = the HDF5 path ("traj_0/obs/agent/qpos", "traj_0@provenance/seed") or "";
/// printed as "file: hdf5 path: message", leaving out empty parts.
using DatasetProblem = Diagnostic;

/// What ValidateDataset looked at and found.
struct MLSPACES_API DatasetReport {
  int64_t files = 0;         ///< *.h5 files checked (outside *.parts folders)
  int64_t trajectories = 0;  ///< traj_<k> groups checked
  int64_t videos = 0;        ///< obs/sensor_data entries checked
  std::vector<DatasetProblem> problems;
  bool ok() const { return problems.empty(); }
};

/// Checks every trajectory file (*.h5, recursively; files inside `*.parts` folders are
/// skipped) under `dir` (or the one file `dir` names) and every video they name, and reports
/// every problem found (a lone file: only its own and its videos'):
///
/// - unfinished writes: `*.parts` folders (episodes not merged), `*.tmp.*` files and
///   `.episode_*` in-progress videos; a `*.h5` that HDF5 cannot open; no `*.h5` at all;
///   `traj_<k>` numbering with gaps; videos (`*.mp4`) no trajectory names.
/// - per `traj_<k>` (T = rows of obs/agent/qpos, at least 2): the required datasets with their
///   types and shapes (obs/agent/{qpos,qvel}, actions/{commanded_action, joint_pos,
///   joint_pos_rel, ee_twist, ee_pose}: uint8 (T, L) JSON-object rows; rewards float32 (T,);
///   success, fail, terminated, truncated: 1-byte bool (T,); obs_scene: scalar JSON-object
///   string), every dataset under obs/extra, env_states and obs/sensor_param with T rows,
///   uint8 (T, L) obs/extra datasets as JSON rows, fail == !success, terminated/truncated set on
///   the last row only (and one of them there), the `provenance` attribute (config_hash, seed,
///   mujoco_version, mlspaces_version, assets with uid/library/license; episode_index,
///   num_steps, success, terminated, truncated consistent when present), every dataset readable.
/// - videos: every obs/sensor_data/<name> names a file beside the HDF5 file that decodes
///   (ProbeVideo) to T frames of the camera's image size (from obs/sensor_param/<cam>/
///   intrinsic_cv row 0: W = 2 cx, H = 2 cy; `<cam>_depth` uses `<cam>`) rounded up to
///   multiples of 16; every camera in obs/sensor_param has a video; no video is named twice.
///
/// Each HDF5 file (with the videos it names) is checked in a forked child process that sends
/// its findings back, so a file corrupt enough to crash the HDF5 library (1.10 can, on damaged
/// metadata) is reported as a problem of that file instead of ending the caller.
///
/// Prints nothing. Problems are in a stable order (files sorted by path); HDF5 paths and
/// messages have non-UTF-8 bytes written as \xNN.
/// @throws Error only when `dir` is neither a folder nor a file; bad data is reported, never
/// thrown.
MLSPACES_API DatasetReport ValidateDataset(const std::filesystem::path& dir);

}  // namespace mlspaces::datagen
