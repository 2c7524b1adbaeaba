#include "mlspaces/datagen/recorder.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <set>

#include "hdf5_util.h"
#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/datagen/dataset_schema.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
using h5::Check;
using h5::Handle;

namespace {

constexpr size_t kVideoNameLen = 100;  // obs/sensor_data/<cam>: (100,) uint8, as the original

// traj_<k:08d>.h5, or .rec for an EpisodeRecord part (RecorderOptions::hdf5 false).
std::string PartName(int k, bool hdf5) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "traj_%08d.%s", k, hdf5 ? "h5" : "rec");
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Validation

void CheckName(const std::string& name, const std::string& field, bool allow_slash) {
  bool ok = !name.empty() && name.front() != '/' && name.back() != '/' &&
            name.find("//") == std::string::npos;
  if (ok && !allow_slash && name.find('/') != std::string::npos) ok = false;
  if (ok) {
    size_t start = 0;
    while (start <= name.size()) {
      size_t end = name.find('/', start);
      if (end == std::string::npos) end = name.size();
      const std::string part = name.substr(start, end - start);
      if (part == "." || part == "..") ok = false;
      start = end + 1;
    }
  }
  if (!ok) {
    throw Error("bad name \"" + name + "\" (" +
                    (allow_slash ? "'/'-separated, non-empty parts" : "no '/', not empty") + ")",
                "", field);
  }
}

void CheckSteps(size_t have, size_t want, const std::string& field) {
  if (have != want) {
    throw Error("has " + std::to_string(have) + " steps, expected " + std::to_string(want) +
                    " (the number of rows of obs/agent/qpos)",
                "", field);
  }
}

// No two leaves share a path and no leaf is a folder of another (`base`/a and `base`/a/b).
void CheckNoClash(std::vector<std::string> paths, const std::string& base) {
  std::sort(paths.begin(), paths.end());
  for (size_t i = 0; i + 1 < paths.size(); ++i) {
    const std::string& a = paths[i];
    for (size_t j = i + 1; j < paths.size() && paths[j].compare(0, a.size(), a) == 0; ++j) {
      if (paths[j] == a) throw Error("written twice", "", base + "/" + a);
      if (paths[j][a.size()] == '/') {
        throw Error("is both a dataset and the group of " + base + "/" + paths[j], "",
                    base + "/" + a);
      }
    }
  }
}

void CheckVideo(const std::string& file, const fs::path& video_dir, const std::string& field) {
  if (file.empty()) return;
  CheckName(file, field, false);
  if (file.size() > 255) throw Error("video file name too long", "", field);
  if (!video_dir.empty()) {
    std::error_code ec;
    if (!fs::is_regular_file(video_dir / file, ec)) {
      throw Error("video file does not exist: " + (video_dir / file).string(), "", field);
    }
  }
}

}  // namespace

void ValidateEpisode(const EpisodeRecord& r, const fs::path& video_dir) {
  const size_t t = NumSteps(r);
  if (t == 0) throw Error("episode has no observation", "", "obs/agent/qpos");
  CheckSteps(r.qvel.size(), t, "obs/agent/qvel");
  CheckSteps(r.rewards.size(), t, "rewards");
  CheckSteps(r.success.size(), t, "success");
  CheckSteps(r.terminated.size(), t, "terminated");
  CheckSteps(r.truncated.size(), t, "truncated");
  for (const auto& [name, steps] : r.actions) {
    CheckName(name, "actions/" + name, true);
    CheckSteps(steps.size(), t, "actions/" + name);
  }
  std::vector<std::string> extra_paths;
  for (const auto& [path, s] : r.extra) {
    CheckName(path, "obs/extra/" + path, true);
    CheckSteps(s.steps(), t, "obs/extra/" + path);
    extra_paths.push_back(path);
  }
  for (const auto& [path, s] : r.extra_json) {
    CheckName(path, "obs/extra/" + path, true);
    CheckSteps(s.steps.size(), t, "obs/extra/" + path);
    if (s.max_len == 0) throw Error("max_len is 0", "", "obs/extra/" + path);
    extra_paths.push_back(path);
  }
  CheckNoClash(extra_paths, "obs/extra");
  std::vector<std::string> action_paths;
  for (const auto& [name, steps] : r.actions) action_paths.push_back(name);
  CheckNoClash(action_paths, "actions");
  std::vector<std::string> env_paths;
  for (const auto& [path, s] : r.env_states) {
    CheckName(path, "env_states/" + path, true);
    CheckSteps(s.steps(), t, "env_states/" + path);
    env_paths.push_back(path);
  }
  CheckNoClash(env_paths, "env_states");
  for (const std::string& g : r.env_state_groups) {
    CheckName(g, "env_states/" + g, true);
    if (r.env_states.count(g) != 0) {
      throw Error("is both a dataset and a group", "", "env_states/" + g);
    }
  }
  std::set<std::string> cams;
  for (const CameraRecord& c : r.cameras) {
    CheckName(c.name, "obs/sensor_param/" + c.name, false);
    if (!cams.insert(c.name).second || !cams.insert(c.name + "_depth").second) {
      throw Error("camera named twice", "", "obs/sensor_param/" + c.name);
    }
    for (const auto& [key, s] : c.params) {
      const std::string field = "obs/sensor_param/" + c.name + "/" + key;
      CheckName(key, field, false);
      CheckSteps(s.steps(), t, field);
    }
    CheckVideo(c.video_file, video_dir, "obs/sensor_data/" + c.name);
    CheckVideo(c.depth_video_file, video_dir, "obs/sensor_data/" + c.name + "_depth");
  }
  for (size_t i = 0; i + 1 < t; ++i) {
    if (r.terminated[i] || r.truncated[i]) {
      throw Error("set at step " + std::to_string(i) + " of " + std::to_string(t) +
                      ": only the last observation may end the episode",
                  "", r.terminated[i] ? "terminated" : "truncated");
    }
  }
  if (!r.terminated[t - 1] && !r.truncated[t - 1]) {
    throw Error("the last observation is neither terminated nor truncated", "", "terminated");
  }
  if (!r.obs_scene.is_object()) throw Error("must be a JSON object", "", "obs_scene");
  const EpisodeMetadata& m = r.meta;
  if (m.config_hash.empty()) throw Error("missing", "", "provenance/config_hash");
  if (m.mujoco_version.empty()) throw Error("missing", "", "provenance/mujoco_version");
  if (m.mlspaces_version.empty()) throw Error("missing", "", "provenance/mlspaces_version");
  if (!m.extra.is_object()) throw Error("must be a JSON object", "", "provenance/extra");
  for (size_t i = 0; i < m.assets.size(); ++i) {
    const AssetProvenance& a = m.assets[i];
    const std::string f = "provenance/assets/" + std::to_string(i);
    if (a.uid.empty()) throw Error("missing", "", f + "/uid");
    if (a.library.empty()) throw Error("missing", "", f + "/library", a.uid);
    if (a.license.empty())
      throw Error("missing (write \"unknown\" if so)", "", f + "/license", a.uid);
  }
}

namespace {

// ---------------------------------------------------------------------------------------------
// Writing

/// Writes one HDF5 file; every object is created without timestamps, so identical records give
/// identical bytes.
class Writer {
 public:
  /// `in_memory`: the file is HDF5's core driver's image only (`file` names it in messages).
  Writer(const fs::path& file, int compression_level, bool in_memory = false)
      : path_(file.string()), level_(compression_level) {
    Handle fapl(Check(H5Pcreate(H5P_FILE_ACCESS), "H5Pcreate", path_, ""), H5Pclose);
    if (in_memory) {
      Check(H5Pset_fapl_core(fapl.get(), 1 << 20, /*backing_store=*/false), "H5Pset_fapl_core",
            path_, "");
    }
    Check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_EARLIEST, H5F_LIBVER_V18),
          "H5Pset_libver_bounds", path_, "");
    Check(H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG), "H5Pset_fclose_degree", path_, "");
    file_ = Handle(Check(H5Fcreate(path_.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, fapl.get()),
                         "H5Fcreate", path_, ""),
                   H5Fclose);
    gcpl_ = Handle(Check(H5Pcreate(H5P_GROUP_CREATE), "H5Pcreate", path_, ""), H5Pclose);
    Check(H5Pset_obj_track_times(gcpl_.get(), false), "H5Pset_obj_track_times", path_, "");
    bool_type_ =
        Handle(Check(H5Tenum_create(H5T_NATIVE_INT8), "H5Tenum_create", path_, ""), H5Tclose);
    int8_t v = 0;
    H5Tenum_insert(bool_type_.get(), "FALSE", &v);
    v = 1;
    H5Tenum_insert(bool_type_.get(), "TRUE", &v);
  }

  hid_t file() const { return file_.get(); }
  const std::string& path() const { return path_; }

  /// Closes the file, flushing everything. @throws Error if HDF5 reports a failure.
  void Close() {
    if (!file_.Close()) {
      throw Error("HDF5 H5Fclose failed: " + h5::LastErrorMessage(), path_);
    }
  }

  /// The group at `path` (absolute), creating missing ones.
  Handle Group(const std::string& path) {
    Handle cur(Check(H5Gopen2(file_.get(), "/", H5P_DEFAULT), "H5Gopen2", path_, "/"), H5Gclose);
    size_t start = 1;
    while (start < path.size()) {
      size_t end = path.find('/', start);
      if (end == std::string::npos) end = path.size();
      const std::string name = path.substr(start, end - start);
      const std::string sofar = path.substr(0, end);
      const htri_t exists = H5Lexists(cur.get(), name.c_str(), H5P_DEFAULT);
      hid_t id = exists > 0
                     ? H5Gopen2(cur.get(), name.c_str(), H5P_DEFAULT)
                     : H5Gcreate2(cur.get(), name.c_str(), H5P_DEFAULT, gcpl_.get(), H5P_DEFAULT);
      cur = Handle(Check(id, "H5Gcreate2", path_, sofar), H5Gclose);
      start = end + 1;
    }
    return cur;
  }

  /// Writes a dataset `path` (absolute) of `dims` elements of `type` from `data`.
  void Dataset(const std::string& path, hid_t type, const std::vector<hsize_t>& dims,
               const void* data, bool compress = true) {
    const size_t slash = path.rfind('/');
    Handle parent = Group(path.substr(0, slash));
    const std::string name = path.substr(slash + 1);
    Handle space(Check(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
                       "H5Screate_simple", path_, path),
                 H5Sclose);
    Handle dcpl(Check(H5Pcreate(H5P_DATASET_CREATE), "H5Pcreate", path_, path), H5Pclose);
    Check(H5Pset_obj_track_times(dcpl.get(), false), "H5Pset_obj_track_times", path_, path);
    const bool nonempty = std::all_of(dims.begin(), dims.end(), [](hsize_t d) { return d > 0; });
    if (compress && level_ > 0 && nonempty) {
      Check(H5Pset_chunk(dcpl.get(), static_cast<int>(dims.size()), dims.data()), "H5Pset_chunk",
            path_, path);
      if (H5Tget_size(type) > 1) Check(H5Pset_shuffle(dcpl.get()), "H5Pset_shuffle", path_, path);
      Check(H5Pset_deflate(dcpl.get(), static_cast<unsigned>(level_)), "H5Pset_deflate", path_,
            path);
    }
    Handle ds(Check(H5Dcreate2(parent.get(), name.c_str(), type, space.get(), H5P_DEFAULT,
                               dcpl.get(), H5P_DEFAULT),
                    "H5Dcreate2", path_, path),
              H5Dclose);
    if (nonempty) {
      Check(H5Dwrite(ds.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "H5Dwrite", path_, path);
    }
  }

  void Series(const std::string& path, const datagen::Series& s) {
    std::vector<hsize_t> dims = {s.steps()};
    for (size_t d : s.row_shape()) dims.push_back(d);
    Dataset(path, NativeType(s.dtype()), dims, s.bytes().data());
  }

  void Bools(const std::string& path, const std::vector<bool>& flags) {
    std::vector<int8_t> v(flags.begin(), flags.end());
    Dataset(path, bool_type_.get(), {v.size()}, v.data());
  }

  /// T JSON values as a (T, W) uint8 dataset, W = max(max_len, longest encoding).
  void JsonRows(const std::string& path, const std::vector<Json>& rows, size_t max_len) {
    std::vector<std::string> enc;
    enc.reserve(rows.size());
    size_t width = max_len;
    for (const Json& j : rows) {
      enc.push_back(DumpJsonCompactSorted(j));
      width = std::max(width, enc.back().size());
    }
    std::vector<unsigned char> buf(rows.size() * width, 0);
    for (size_t i = 0; i < enc.size(); ++i) {
      std::memcpy(buf.data() + i * width, enc[i].data(), enc[i].size());
    }
    Dataset(path, H5T_NATIVE_UINT8, {rows.size(), width}, buf.data());
  }

  /// A zero-padded uint8 string of at least `len` bytes.
  void PaddedName(const std::string& path, const std::string& name, size_t len) {
    std::vector<unsigned char> buf(std::max(len, name.size()), 0);
    std::memcpy(buf.data(), name.data(), name.size());
    Dataset(path, H5T_NATIVE_UINT8, {buf.size()}, buf.data());
  }

  /// A scalar variable-length UTF-8 string dataset (h5py: f[path].asstr()[()]).
  void ScalarString(const std::string& path, const std::string& text) {
    const size_t slash = path.rfind('/');
    Handle parent = Group(path.substr(0, slash));
    Handle type = VlenString();
    Handle space(Check(H5Screate(H5S_SCALAR), "H5Screate", path_, path), H5Sclose);
    Handle dcpl(Check(H5Pcreate(H5P_DATASET_CREATE), "H5Pcreate", path_, path), H5Pclose);
    Check(H5Pset_obj_track_times(dcpl.get(), false), "H5Pset_obj_track_times", path_, path);
    Handle ds(Check(H5Dcreate2(parent.get(), path.substr(slash + 1).c_str(), type.get(),
                               space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
                    "H5Dcreate2", path_, path),
              H5Dclose);
    const char* p = text.c_str();
    Check(H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &p), "H5Dwrite", path_,
          path);
  }

  /// A variable-length UTF-8 string attribute `name` on the group `path`.
  void StringAttribute(const std::string& path, const std::string& name, const std::string& text) {
    Handle group = Group(path);
    Handle type = VlenString();
    Handle space(Check(H5Screate(H5S_SCALAR), "H5Screate", path_, path), H5Sclose);
    Handle attr(Check(H5Acreate2(group.get(), name.c_str(), type.get(), space.get(), H5P_DEFAULT,
                                 H5P_DEFAULT),
                      "H5Acreate2", path_, path + "@" + name),
                H5Aclose);
    const char* p = text.c_str();
    Check(H5Awrite(attr.get(), type.get(), &p), "H5Awrite", path_, path + "@" + name);
  }

 private:
  hid_t NativeType(DType t) const {
    switch (t) {
      case DType::kBool:
        return bool_type_.get();
      case DType::kUint8:
        return H5T_NATIVE_UINT8;
      case DType::kInt32:
        return H5T_NATIVE_INT32;
      case DType::kInt64:
        return H5T_NATIVE_INT64;
      case DType::kFloat32:
        return H5T_NATIVE_FLOAT;
      case DType::kFloat64:
        return H5T_NATIVE_DOUBLE;
    }
    return H5T_NATIVE_UINT8;
  }

  Handle VlenString() {
    Handle type(Check(H5Tcopy(H5T_C_S1), "H5Tcopy", path_, ""), H5Tclose);
    Check(H5Tset_size(type.get(), H5T_VARIABLE), "H5Tset_size", path_, "");
    Check(H5Tset_cset(type.get(), H5T_CSET_UTF8), "H5Tset_cset", path_, "");
    return type;
  }

  std::string path_;
  int level_;
  Handle file_, gcpl_, bool_type_;
};

Json ProvenanceJson(const EpisodeRecord& r, int k) {
  const EpisodeMetadata& m = r.meta;
  Json assets = Json::array();
  for (const AssetProvenance& a : m.assets) {
    assets.push_back(
        Json{{"uid", a.uid}, {"library", a.library}, {"license", a.license}, {"role", a.role}});
  }
  const size_t t = NumSteps(r);
  Json out{{"config_hash", m.config_hash},
           {"seed", m.seed},
           {"scene", m.scene},
           {"episode_index", k},
           {"source_episode", m.source_episode},
           {"task_description", m.task_description},
           {"assets", std::move(assets)}};
  if (!m.license_policy.empty()) out["license_policy"] = m.license_policy;
  if (!m.robot.empty()) {
    out["robot"] = Json{{"name", m.robot}, {"description_hash", m.robot_description_hash}};
  }
  out["mujoco_version"] = m.mujoco_version;
  out["mlspaces_version"] = m.mlspaces_version;
  out["num_steps"] = t;
  out["success"] = static_cast<bool>(r.success[t - 1]);
  out["terminated"] = static_cast<bool>(r.terminated[t - 1]);
  out["truncated"] = static_cast<bool>(r.truncated[t - 1]);
  out["extra"] = m.extra;
  return out;
}

void WriteTraj(Writer& w, const EpisodeRecord& r, int k) {
  const std::string root = "/" + schema::TrajGroup(k);
  const size_t t = NumSteps(r);
  w.Group(root);
  // Datasets in a fixed order (HDF5 lists them by name anyway; this fixes the file bytes).
  std::vector<Json> rows(t);
  for (const auto& [name, steps] : r.actions) {
    for (size_t i = 0; i < t; ++i) rows[i] = MoveGroupJson(steps[i], false);
    w.JsonRows(root + "/" + schema::kActions + "/" + name, rows, schema::kJsonRowLen);
  }
  const std::string env_states = root + "/" + schema::kEnvStates + "/";
  for (const auto& [path, s] : r.env_states) w.Series(env_states + path, s);
  for (const std::string& g : r.env_state_groups) w.Group(env_states + g);
  const std::string agent = root + "/" + schema::kAgent + "/";
  for (size_t i = 0; i < t; ++i) rows[i] = MoveGroupJson(r.qpos[i], true);
  w.JsonRows(agent + schema::kAgentDatasets[0], rows, schema::kJsonRowLen);
  for (size_t i = 0; i < t; ++i) rows[i] = MoveGroupJson(r.qvel[i], true);
  w.JsonRows(agent + schema::kAgentDatasets[1], rows, schema::kJsonRowLen);
  const std::string extra = root + "/" + schema::kExtra;
  w.Group(extra);
  for (const auto& [path, s] : r.extra) w.Series(extra + "/" + path, s);
  for (const auto& [path, s] : r.extra_json) {
    w.JsonRows(extra + "/" + path, s.steps, s.max_len);
  }
  const std::string sensor_data = root + "/" + schema::kSensorData;
  const std::string sensor_param = root + "/" + schema::kSensorParam;
  w.Group(sensor_data);
  w.Group(sensor_param);
  for (const CameraRecord& c : r.cameras) {
    if (!c.video_file.empty()) {
      w.PaddedName(sensor_data + "/" + c.name, c.video_file, kVideoNameLen);
    }
    if (!c.depth_video_file.empty()) {
      w.PaddedName(sensor_data + "/" + c.name + schema::kDepthSuffix, c.depth_video_file,
                   kVideoNameLen);
    }
    w.Group(sensor_param + "/" + c.name);
    for (const auto& [key, s] : c.params) {
      w.Series(sensor_param + "/" + c.name + "/" + key, s);
    }
  }
  std::vector<bool> fail(t);
  for (size_t i = 0; i < t; ++i) fail[i] = !r.success[i];
  w.Bools(root + "/" + schema::kFail, fail);
  w.Dataset(root + "/" + schema::kRewards, H5T_NATIVE_FLOAT, {t}, r.rewards.data());
  w.Bools(root + "/" + schema::kSuccess, r.success);
  w.Bools(root + "/" + schema::kTerminated, r.terminated);
  w.Bools(root + "/" + schema::kTruncated, r.truncated);
  w.ScalarString(root + "/" + schema::kObsScene, r.obs_scene.dump());
  w.StringAttribute(root, schema::kProvenance, ProvenanceJson(r, k).dump());
}

/// Runs `fill` on a fresh HDF5 file beside `target`, then makes it durable and renames it over
/// `target`. On any failure the temp file is removed and the error rethrown.
template <class Fill>
void WriteHdf5Atomic(const fs::path& target, int compression_level, Fill&& fill) {
  const fs::path tmp = fs::path(target.string() + TempSuffix());
  try {
    {
      Writer w(tmp, compression_level);
      fill(w);
      w.Close();
    }
    FsyncPath(tmp, false, target.string());
    CrashPoint("HDF5 temp file written");
    if (::rename(tmp.c_str(), target.c_str()) != 0) {
      throw Error(std::string("cannot rename into place: ") + std::strerror(errno),
                  target.string());
    }
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  FsyncPath(target.parent_path(), true, target.parent_path().string());
  CrashPoint("HDF5 file renamed into place");
}

}  // namespace

Recorder::Recorder(RecorderOptions options) : options_(std::move(options)) {
  if (options_.batch < 1 || options_.num_batches < options_.batch) {
    throw UsageError("batch " + std::to_string(options_.batch) + " of " +
                     std::to_string(options_.num_batches) + " is out of range");
  }
  if (options_.compression_level < 0 || options_.compression_level > 9) {
    throw UsageError("compression level must be 0-9");
  }
  stem_ = BatchFileStem(options_.batch, options_.num_batches);
  std::error_code ec;
  fs::create_directories(options_.dir, ec);
  if (ec) throw Error("cannot create folder: " + ec.message(), options_.dir.string());
  // A batch file a crash left half-written under its temp name (never under its own name).
  for (const auto& e : fs::directory_iterator(options_.dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(stem_ + ".h5.tmp.", 0) == 0) fs::remove(e.path(), ec);
  }
  // Parts left by a crashed run: keep the complete ones (they were renamed into place only once
  // durable), drop temp files.
  const fs::path parts = parts_dir();
  if (!fs::is_directory(parts, ec)) return;
  std::set<int> found;
  for (const auto& e : fs::directory_iterator(parts, ec)) {
    const std::string name = e.path().filename().string();
    if (name.find(".tmp.") != std::string::npos) {
      fs::remove(e.path(), ec);
      continue;
    }
    int k = -1;
    char tail = 0;
    if (std::sscanf(name.c_str(), "traj_%8d.%c", &k, &tail) == 2 &&
        name == PartName(k, options_.hdf5)) {
      found.insert(k);
    }
  }
  for (int k = 0; k < static_cast<int>(found.size()); ++k) {
    if (found.count(k) == 0) {
      throw Error(
          "episode part " + PartName(k, options_.hdf5) + " is missing (parts are written in order)",
          parts.string());
    }
    parts_.push_back(parts / PartName(k, options_.hdf5));
  }
}

std::string BatchFileStem(int batch, int num_batches) {
  return "trajectories_batch_" + std::to_string(batch) + "_of_" + std::to_string(num_batches);
}

Json Recorder::PartProvenance(int k) const {
  if (k < 0 || k >= next_index()) throw UsageError("no part " + std::to_string(k));
  const std::string path = parts_[k].string();
  if (!options_.hdf5) return ProvenanceJson(DecodeEpisodeRecord(ReadFile(parts_[k]), path), k);
  const std::string group = "traj_" + std::to_string(k);
  h5::QuietErrors quiet;
  h5::Handle file(
      h5::Check(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "H5Fopen", path, ""), H5Fclose);
  h5::Handle attr(
      h5::Check(H5Aopen_by_name(file.get(), group.c_str(), "provenance", H5P_DEFAULT, H5P_DEFAULT),
                "H5Aopen_by_name", path, group + "@provenance"),
      H5Aclose);
  h5::Handle type(h5::Check(H5Aget_type(attr.get()), "H5Aget_type", path, group), H5Tclose);
  char* text = nullptr;
  h5::Check(H5Aread(attr.get(), type.get(), &text), "H5Aread", path, group + "@provenance");
  std::string json = text != nullptr ? text : "";
  h5::Handle space(h5::Check(H5Aget_space(attr.get()), "H5Aget_space", path, group), H5Sclose);
  H5Dvlen_reclaim(type.get(), space.get(), H5P_DEFAULT, &text);
  return ParseJson(json, path);
}

int64_t CountEpisodes(const fs::path& file) {
  const std::string path = file.string();
  h5::QuietErrors quiet;
  h5::Handle f(h5::Check(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "H5Fopen", path, ""),
               H5Fclose);
  H5G_info_t info;
  h5::Check(H5Gget_info(f.get(), &info), "H5Gget_info", path, "/");
  int64_t n = 0;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char name[64] = {0};
    if (H5Lget_name_by_idx(f.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name,
                           H5P_DEFAULT) > 0 &&
        std::strncmp(name, "traj_", 5) == 0) {
      ++n;
    }
  }
  return n;
}

fs::path Recorder::batch_file() const {
  return options_.dir / (stem_ + (options_.hdf5 ? ".h5" : ".episodes"));
}

fs::path Recorder::parts_dir() const { return options_.dir / (stem_ + ".parts"); }

std::string Recorder::VideoFileName(int episode_index, const std::string& camera) const {
  char buf[32];
  std::snprintf(buf, sizeof buf, "episode_%08d_", episode_index);
  return buf + camera + "_batch_" + std::to_string(options_.batch) + "_of_" +
         std::to_string(options_.num_batches) + ".mp4";
}

int Recorder::Write(const EpisodeRecord& record) {
  const int k = next_index();
  const fs::path target = parts_dir() / PartName(k, options_.hdf5);
  if (finished_) throw Error("recorder already finished", batch_file().string());
  try {
    ValidateEpisode(record, options_.dir);
  } catch (const Error& e) {
    throw Error(e.message(), target.string(), "traj_" + std::to_string(k) + "/" + e.field(),
                e.uid());
  }
  std::error_code ec;
  fs::create_directories(parts_dir(), ec);
  if (ec) throw Error("cannot create folder: " + ec.message(), parts_dir().string());
  if (options_.hdf5) {
    h5::QuietErrors quiet;
    WriteHdf5Atomic(target, options_.compression_level,
                    [&](Writer& w) { WriteTraj(w, record, k); });
  } else {
    WriteFileAtomic(target, EncodeEpisodeRecord(record));
    FsyncPath(parts_dir(), true, parts_dir().string());
    CrashPoint("episode record written");
  }
  parts_.push_back(target);
  return k;
}

bool Recorder::Finish() {
  if (finished_) throw Error("recorder already finished", batch_file().string());
  if (parts_.empty()) {
    finished_ = true;
    return false;
  }
  if (!options_.hdf5) {
    // The records stay as they are; the folder's new name marks the batch finished.
    RenamePath(parts_dir(), batch_file());
    FsyncPath(options_.dir, true, options_.dir.string());
    CrashPoint("episode records finished");
    parts_.clear();
    finished_ = true;
    return true;
  }
  h5::QuietErrors quiet;
  WriteHdf5Atomic(batch_file(), options_.compression_level, [&](Writer& w) {
    for (size_t k = 0; k < parts_.size(); ++k) {
      const std::string part = parts_[k].string();
      const std::string name = "traj_" + std::to_string(k);
      Handle src(Check(H5Fopen(part.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "H5Fopen", part, ""),
                 H5Fclose);
      Check(H5Ocopy(src.get(), name.c_str(), w.file(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
            "H5Ocopy", w.path(), name);
    }
  });
  std::error_code ec;
  for (const fs::path& p : parts_) fs::remove(p, ec);
  fs::remove(parts_dir(), ec);  // only if empty
  parts_.clear();
  finished_ = true;
  return true;
}

void WriteEpisodeFile(const EpisodeRecord& record, int k, const fs::path& file,
                      int compression_level) {
  const std::string group = schema::TrajGroup(k);
  try {
    ValidateEpisode(record);
  } catch (const Error& e) {
    throw Error(e.message(), file.string(), group + "/" + e.field(), e.uid());
  }
  h5::QuietErrors quiet;
  // Written in memory as the recorder writes a part, then copied out as a batch file's group
  // is copied (so the bytes are export-lerobot's).
  Writer part(file.string() + " (in memory)", compression_level, /*in_memory=*/true);
  WriteTraj(part, record, k);
  Writer out(file, compression_level);
  Check(H5Ocopy(part.file(), group.c_str(), out.file(), group.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        "H5Ocopy", out.path(), group);
  out.Close();
}

}  // namespace mlspaces::datagen
