// export-lerobot: reads mlspaces episodes (HDF5, docs/dataset.md) and hands them to the LeRobot
// Writer; datagen --format lerobot's episode records go the same way, each first written as
// the HDF5 file meta/mlspaces/ keeps of it. Frame t of an episode is observation row t with the
// command that followed it (action row t + 1), so an episode of T observations gives T - 1 frames
// (docs/lerobot.md).
#include "mlspaces/datagen/lerobot/export.h"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <utility>

#include "../dataset_validate_internal.h"
#include "../hdf5_util.h"
#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/recorder.h"
#include "sidecar.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;
using h5::Handle;

namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A numeric per-row array of a trajectory: its HDF5 path, values per row, integer or not.
struct Array {
  size_t dim = 0;
  bool integer = false;
  bool operator==(const Array&) const = default;
};

// What the first pass learns about one traj_<k>.
struct EpisodeRef {
  fs::path file;
  std::string traj;
  int64_t t = 0;
  std::string task;
  double dt_ms = 0;
  std::string robot;
  std::map<std::string, std::string> cameras;  // name -> video file name
  std::map<std::string, Array> arrays;  // obs/extra/…, env_states/…, obs/sensor_param/…
  std::string where() const { return file.string() + ": " + traj; }
};

// Where an episode's HDF5 group is and what it is called in the dataset it came from.
struct Source {
  fs::path file;      // the HDF5 file holding group `traj`
  std::string traj;   // "traj_<k>"
  std::string batch;  // its batch file, relative to the run folder ("house_0/…h5")
  fs::path video_dir;
  // `file` is already the episode's meta/mlspaces/hdf5/ file (written from its record).
  bool own = false;
};

// Why an episode is left out, or null: export-lerobot writes successful complete episodes.
const char* SkipReason(bool success, bool truncated, int64_t t) {
  if (truncated) return "truncated";
  if (!success) return "failed";
  if (t < 2) return "fewer than 2 observations";
  return nullptr;
}

std::optional<int64_t> Number(const std::string& name, const std::regex& re) {
  std::smatch m;
  if (!std::regex_match(name, m, re)) return std::nullopt;
  return std::stoll(m[1].str());
}

// Batch files in mlspaces.reader's order: house index, then batch index.
std::vector<fs::path> BatchFiles(const fs::path& dir) {
  static const std::regex house(R"(house_(\d+))"), batch(R"(trajectories_batch_(\d+)_of_\d+\.h5)");
  if (!fs::is_directory(dir)) throw Error("not a folder", dir.string());
  std::vector<std::pair<int64_t, fs::path>> houses;
  for (const fs::path& p : ListFolder(dir)) {
    if (auto n = Number(p.filename().string(), house); n && fs::is_directory(p)) {
      houses.emplace_back(*n, p);
    }
  }
  std::sort(houses.begin(), houses.end());
  if (houses.empty()) houses.emplace_back(0, dir);
  std::vector<fs::path> files;
  for (const auto& [_, h] : houses) {
    std::vector<std::pair<int64_t, fs::path>> b;
    for (const fs::path& p : ListFolder(h)) {
      if (auto n = Number(p.filename().string(), batch)) b.emplace_back(*n, p);
    }
    std::sort(b.begin(), b.end());
    for (auto& [_, p] : b) files.push_back(p);
  }
  if (files.empty()) {
    throw Error(
        "not a dataset folder (no house_<i> folders and no "
        "trajectories_batch_<b>_of_<n>.h5 files)",
        dir.string());
  }
  return files;
}

Handle OpenFile(const fs::path& p) {
  return Handle(h5::Check(H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "open", p.string(), ""),
                H5Fclose);
}

std::vector<std::string> Links(hid_t g, bool recursive) {
  std::vector<std::string> out;
  auto cb = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->push_back(name);
    return 0;
  };
  if (recursive) {
    H5Lvisit(g, H5_INDEX_NAME, H5_ITER_INC, cb, &out);
  } else {
    H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, nullptr, cb, &out);
  }
  return out;
}

bool Exists(hid_t g, const std::string& rel) { return dataset_check::Exists(g, rel); }

struct Ds {
  Handle id, type, space;
  std::vector<hsize_t> dims;
};

std::optional<Ds> OpenDs(hid_t g, const std::string& rel) {
  if (!Exists(g, rel)) return std::nullopt;
  hid_t id = H5Dopen2(g, rel.c_str(), H5P_DEFAULT);
  if (id < 0) return std::nullopt;  // a group
  Ds d{Handle(id, H5Dclose),
       Handle(H5Dget_type(id), H5Tclose),
       Handle(H5Dget_space(id), H5Sclose),
       {}};
  const int nd = H5Sget_simple_extent_ndims(d.space.get());
  d.dims.resize(static_cast<size_t>(std::max(nd, 0)));
  if (nd > 0) H5Sget_simple_extent_dims(d.space.get(), d.dims.data(), nullptr);
  return d;
}

Ds Need(hid_t g, const std::string& rel, const std::string& where) {
  auto d = OpenDs(g, rel);
  if (!d) throw Error("missing dataset", where, rel);
  return std::move(*d);
}

std::vector<double> ReadDoubles(const Ds& d, const std::string& where, const std::string& rel) {
  size_t n = 1;
  for (hsize_t x : d.dims) n *= x;
  std::vector<double> v(n);
  if (H5Dread(d.id.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) {
    throw Error("cannot read as numbers", where, rel);
  }
  return v;
}

// 1-byte flags (h5py bool enum) as 0/1.
std::vector<int8_t> ReadFlags(hid_t g, const std::string& rel, const std::string& where) {
  Ds d = Need(g, rel, where);
  if (H5Tget_size(d.type.get()) != 1) throw Error("not a 1-byte bool", where, rel);
  std::vector<int8_t> v(d.dims.empty() ? 1 : d.dims[0]);
  Handle mem(H5Tget_native_type(d.type.get(), H5T_DIR_ASCEND), H5Tclose);
  if (H5Dread(d.id.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) {
    throw Error("cannot read", where, rel);
  }
  return v;
}

std::string ReadText(hid_t obj, bool attribute, const std::string& where, const std::string& rel) {
  Handle type(attribute ? H5Aget_type(obj) : H5Dget_type(obj), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING) throw Error("not a string", where, rel);
  if (H5Tis_variable_str(type.get()) > 0) {
    char* s = nullptr;
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
    const herr_t rc = attribute ? H5Aread(obj, mem.get(), &s)
                                : H5Dread(obj, mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &s);
    if (rc < 0 || s == nullptr) throw Error("cannot read", where, rel);
    std::string out(s);
    H5free_memory(s);
    return out;
  }
  std::string buf(H5Tget_size(type.get()), '\0');
  const herr_t rc = attribute ? H5Aread(obj, type.get(), buf.data())
                              : H5Dread(obj, type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
  if (rc < 0) throw Error("cannot read", where, rel);
  return buf.substr(0, buf.find('\0'));
}

Json ParseJson(std::string_view text, const std::string& where, const std::string& rel) {
  Json j = Json::parse(dataset_check::PythonJsonToStrict(text), nullptr, false);
  if (j.is_discarded()) throw Error("not JSON", where, rel);
  return j;
}

// uint8 (T, L) zero-padded JSON rows.
std::vector<Json> JsonRows(hid_t g, const std::string& rel, const std::string& where) {
  Ds d = Need(g, rel, where);
  if (d.dims.size() != 2) throw Error("expected (T, L) uint8 JSON rows", where, rel);
  std::vector<char> buf(d.dims[0] * d.dims[1]);
  if (H5Dread(d.id.get(), H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) {
    throw Error("cannot read", where, rel);
  }
  std::vector<Json> rows;
  for (size_t i = 0; i < d.dims[0]; ++i) {
    std::string_view row(buf.data() + i * d.dims[1], d.dims[1]);
    rows.push_back(ParseJson(row.substr(0, row.find('\0')), where, rel));
  }
  return rows;
}

// A move-group layout: group name -> number of values, in JSON key order (sorted).
using Layout = std::vector<std::pair<std::string, size_t>>;

Layout LayoutOf(const Json& row) {
  Layout l;
  for (auto it = row.begin(); it != row.end(); ++it) l.emplace_back(it.key(), it.value().size());
  std::sort(l.begin(), l.end());
  return l;
}

std::vector<std::string> Names(const Layout& l) {
  std::vector<std::string> n;
  for (const auto& [g, k] : l) {
    for (size_t i = 0; i < k; ++i) n.push_back(g + "_" + std::to_string(i));
  }
  return n;
}

size_t Width(const Layout& l) {
  size_t n = 0;
  for (const auto& [_, k] : l) n += k;
  return n;
}

// Appends one row in `layout`'s order; an empty row `{}` gives NaN (no command at that step).
void AppendRow(const Json& row, const Layout& layout, std::vector<double>& out,
               const std::string& where, const std::string& rel) {
  if (row.empty()) {
    out.insert(out.end(), Width(layout), kNaN);
    return;
  }
  for (const auto& [g, k] : layout) {
    auto it = row.find(g);
    if (it == row.end() || !it->is_array() || it->size() != k) {
      throw Error("move group '" + g + "' does not have the " + std::to_string(k) +
                      " values of the first episode's",
                  where, rel);
    }
    for (const Json& v : *it) out.push_back(v.is_number() ? v.get<double>() : kNaN);
  }
}

std::string Key(std::string prefix, const std::string& path) {
  std::string k = std::move(prefix);
  for (char c : path) k += c == '/' ? '.' : c;
  return k;
}

EpisodeRef Scan(hid_t f, const fs::path& file, const std::string& traj) {
  EpisodeRef e;
  e.file = file;
  e.traj = traj;
  const std::string where = e.where();
  Handle g(h5::Check(H5Gopen2(f, traj.c_str(), H5P_DEFAULT), "open group", file.string(), traj),
           H5Gclose);
  const std::vector<int8_t> success = ReadFlags(g.get(), "success", where);
  e.t = static_cast<int64_t>(success.size());
  {
    Ds scene = Need(g.get(), "obs_scene", where);
    const Json j =
        ParseJson(ReadText(scene.id.get(), false, where, "obs_scene"), where, "obs_scene");
    if (!j.is_object()) throw Error("not a JSON object", where, "obs_scene");
    e.task = j.value("task_description", std::string());
    e.dt_ms = j.value("policy_dt_ms", 0.0);
    if (j.contains("robot") && j["robot"].is_string()) e.robot = j["robot"].get<std::string>();
  }
  if (H5Aexists(g.get(), "provenance") > 0) {
    Handle a(H5Aopen(g.get(), "provenance", H5P_DEFAULT), H5Aclose);
    const Json p = ParseJson(ReadText(a.get(), true, where, "@provenance"), where, "@provenance");
    if (p.is_object() && p.contains("robot") && p["robot"].is_object()) {
      e.robot = p["robot"].value("name", e.robot);
    }
    if (e.task.empty() && p.is_object()) e.task = p.value("task_description", std::string());
  }
  if (e.task.empty()) throw Error("no task_description", where, "obs_scene");
  if (!(e.dt_ms > 0)) throw Error("no policy_dt_ms > 0", where, "obs_scene");
  if (Exists(g.get(), "obs/sensor_data")) {
    Handle sd(H5Gopen2(g.get(), "obs/sensor_data", H5P_DEFAULT), H5Gclose);
    for (const std::string& cam : Links(sd.get(), false)) {
      Ds d = Need(sd.get(), cam, where + "/obs/sensor_data");
      std::vector<char> buf(d.dims.empty() ? 0 : d.dims[0]);
      H5Dread(d.id.get(), H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
      std::string name(buf.data(), buf.size());
      name = name.substr(0, name.find('\0'));
      if (!name.empty()) e.cameras[cam] = name;
    }
  }
  for (const char* group : {"obs/extra", "env_states", "obs/sensor_param"}) {
    if (!Exists(g.get(), group)) continue;
    Handle sub(H5Gopen2(g.get(), group, H5P_DEFAULT), H5Gclose);
    for (const std::string& rel : Links(sub.get(), true)) {
      auto d = OpenDs(sub.get(), rel);
      if (!d || d->dims.empty() || d->dims[0] != static_cast<hsize_t>(e.t)) continue;
      const H5T_class_t c = H5Tget_class(d->type.get());
      if (c != H5T_INTEGER && c != H5T_FLOAT) continue;
      // uint8 (T, L) rows are JSON (task_info, grasp_state_…), not numbers.
      if (c == H5T_INTEGER && H5Tget_size(d->type.get()) == 1 && d->dims.size() == 2) continue;
      size_t dim = 1;
      for (size_t i = 1; i < d->dims.size(); ++i) dim *= d->dims[i];
      if (dim == 0) continue;
      e.arrays[std::string(group) + "/" + rel] = Array{dim, c == H5T_INTEGER};
    }
  }
  return e;
}

std::string FeatureKey(const std::string& path) {
  if (path.rfind("obs/extra/", 0) == 0) return Key("extra.", path.substr(10));
  if (path.rfind("env_states/", 0) == 0) return Key("env_state.", path.substr(11));
  return Key("camera.", path.substr(17));  // obs/sensor_param/<cam>/<param>
}

std::string Join(const std::map<std::string, std::string>& m) {
  std::string s;
  for (const auto& [k, _] : m) s += (s.empty() ? "" : ", ") + k;
  return s.empty() ? "none" : s;
}

// The episodes of the batch files of `dataset_dir`, in mlspaces.reader's order.
std::vector<Source> BatchSources(const fs::path& dataset_dir) {
  static const std::regex traj_re(R"(traj_(\d+))");
  const fs::path root = fs::weakly_canonical(dataset_dir);
  std::vector<Source> sources;
  for (const fs::path& file : BatchFiles(dataset_dir)) {
    Handle f = OpenFile(file);
    std::vector<std::pair<int64_t, std::string>> trajs;
    for (const std::string& name : Links(f.get(), false)) {
      if (auto k = Number(name, traj_re)) trajs.emplace_back(*k, name);
    }
    std::sort(trajs.begin(), trajs.end());
    const std::string batch = fs::weakly_canonical(file).lexically_relative(root).generic_string();
    for (const auto& [_, traj] : trajs) {
      sources.push_back({file, traj, batch, file.parent_path(), false});
    }
  }
  return sources;
}

// The entries of `dir` whose names match `re` (group 1 a number), by that number.
std::vector<fs::path> Numbered(const fs::path& dir, const std::regex& re) {
  std::vector<std::pair<int64_t, fs::path>> found;
  for (const fs::path& p : ListFolder(dir)) {
    if (auto n = Number(p.filename().string(), re)) found.emplace_back(*n, p);
  }
  std::sort(found.begin(), found.end());
  std::vector<fs::path> out;
  out.reserve(found.size());
  for (auto& [_, p] : found) out.push_back(std::move(p));
  return out;
}

// The episode records of a run made without HDF5 (RunOptions::hdf5 false), in the order their
// batch files would have: each exported one written as its meta/mlspaces/hdf5/ file in `tmp`.
std::vector<Source> RecordSources(const fs::path& run_dir, const fs::path& tmp,
                                  ExportReport& report) {
  static const std::regex house(R"(house_(\d+))"),
      batch(R"(trajectories_batch_(\d+)_of_\d+\.episodes)"), record(R"(traj_(\d{8})\.rec)");
  if (!fs::is_directory(run_dir)) throw Error("not a folder", run_dir.string());
  std::vector<Source> sources;
  for (const fs::path& h : Numbered(run_dir, house)) {
    for (const fs::path& b : Numbered(h, batch)) {
      for (const fs::path& r : Numbered(b, record)) {
        const EpisodeRecord rec = DecodeEpisodeRecord(ReadFile(r), r.string());
        const int k = static_cast<int>(*Number(r.filename().string(), record));
        const std::string traj = "traj_" + std::to_string(k);
        const auto t = static_cast<int64_t>(NumSteps(rec));
        if (const char* why =
                SkipReason(t > 0 && rec.success.back(), t == 0 || rec.truncated.back(), t)) {
          report.skipped.push_back(r.string() + ": " + traj + ": " + why);
          continue;
        }
        char name[48];
        std::snprintf(name, sizeof name, "hdf5/episode_%06zu.h5", sources.size());
        const fs::path file = tmp / kSidecarDir / name;
        CreateDirectories(file.parent_path());
        WriteEpisodeFile(rec, k, file);
        const std::string stem = b.stem().string();
        sources.push_back({file, traj, h.filename().string() + "/" + stem + ".h5", h, true});
      }
    }
  }
  return sources;
}

// Writes `out_dir` from the episodes `list_sources(tmp, report)` gives (tmp: the folder being
// built) and the run files of `run_dir`.
ExportReport Export(
    const std::function<std::vector<Source>(const fs::path&, ExportReport&)>& list_sources,
    const fs::path& run_dir, const fs::path& out_dir, const ExportOptions& options) {
  h5::QuietErrors quiet;
  ExportReport report;
  const fs::path out = fs::absolute(out_dir).lexically_normal();
  const fs::path parent = out.has_filename() ? out.parent_path() : out.parent_path().parent_path();
  if (fs::exists(out))
    throw Error("already exists; remove it or choose another folder", out.string());
  // Written into a temp folder beside `out`, renamed at the end.
  StagingFolder staging(parent / out.filename());
  const fs::path tmp = staging.path();
  CreateDirectories(tmp);

  // Pass 1: what every episode holds; which ones are exported.
  const std::vector<Source> sources = list_sources(tmp, report);
  std::vector<EpisodeRef> eps;
  std::vector<const Source*> used;
  for (const Source& src : sources) {
    Handle f = OpenFile(src.file);
    EpisodeRef e = Scan(f.get(), src.file, src.traj);
    Handle g(H5Gopen2(f.get(), src.traj.c_str(), H5P_DEFAULT), H5Gclose);
    const std::string where = e.where();
    const std::vector<int8_t> success = ReadFlags(g.get(), "success", where);
    const std::vector<int8_t> truncated = ReadFlags(g.get(), "truncated", where);
    if (const char* why = SkipReason(!success.empty() && success.back() != 0,
                                     truncated.empty() || truncated.back() != 0, e.t)) {
      report.skipped.push_back(where + ": " + why);
    } else {
      eps.push_back(std::move(e));
      used.push_back(&src);
    }
  }
  if (eps.empty()) {
    throw Error("no successful, complete episode to export (" +
                    std::to_string(report.skipped.size()) + " left out)",
                run_dir.string());
  }
  const EpisodeRef& first = eps.front();
  const double fps = 1000.0 / first.dt_ms;
  if (options.fps > 0 && std::abs(options.fps - fps) > 1e-3) {
    throw Error("--fps " + Num(options.fps) + " is not the dataset's " + Num(fps) +
                    " (policy_dt_ms " + Num(first.dt_ms) + ")",
                first.where(), "obs_scene/policy_dt_ms");
  }
  std::map<std::string, Array> common = first.arrays;
  for (const EpisodeRef& e : eps) {
    if (std::abs(e.dt_ms - first.dt_ms) > 1e-9) {
      throw Error("policy_dt_ms " + Num(e.dt_ms) + " (fps " + Num(1000.0 / e.dt_ms) +
                      ") is not the first episode's " + Num(first.dt_ms) + " (" + first.where() +
                      ")",
                  e.where(), "obs_scene/policy_dt_ms");
    }
    if (e.cameras.size() != first.cameras.size() ||
        !std::equal(e.cameras.begin(), e.cameras.end(), first.cameras.begin(),
                    [](const auto& a, const auto& b) { return a.first == b.first; })) {
      throw Error("cameras " + Join(e.cameras) + " are not the first episode's (" +
                      Join(first.cameras) + ", " + first.where() + ")",
                  e.where(), "obs/sensor_data");
    }
    for (auto it = common.begin(); it != common.end();) {
      auto o = e.arrays.find(it->first);
      it = o == e.arrays.end() || !(o->second == it->second) ? common.erase(it) : std::next(it);
    }
  }

  // Layouts of the JSON rows, from the first episode that has a non-empty row.
  struct JsonFeature {
    std::string rel, key;
    bool next;  // action-like: row t + 1
    Layout layout;
  };
  std::vector<JsonFeature> json_features = {
      {"obs/agent/qpos", "observation.state", false, {}},
      {"obs/agent/qvel", "observation.velocity", false, {}},
      {"actions/commanded_action", "action", true, {}},
      {"actions/joint_pos", "command.joint_pos", true, {}},
      {"actions/joint_pos_rel", "command.joint_pos_rel", true, {}},
      {"actions/ee_twist", "command.ee_twist", true, {}},
      {"actions/ee_pose", "command.ee_pose", true, {}}};
  for (JsonFeature& jf : json_features) {
    for (const EpisodeRef& e : eps) {
      Handle f = OpenFile(e.file);
      Handle g(H5Gopen2(f.get(), e.traj.c_str(), H5P_DEFAULT), H5Gclose);
      if (!Exists(g.get(), jf.rel)) continue;
      const std::vector<Json> rows = JsonRows(g.get(), jf.rel, e.where());
      for (size_t i = jf.next ? 1 : 0; i < rows.size(); ++i) {
        if (!rows[i].empty()) {
          jf.layout = LayoutOf(rows[i]);
          break;
        }
      }
      if (!jf.layout.empty()) break;
    }
  }
  std::erase_if(json_features, [](const JsonFeature& jf) { return Width(jf.layout) == 0; });
  if (json_features.empty() || json_features[0].key != "observation.state") {
    throw Error("no obs/agent/qpos values", first.where(), "obs/agent/qpos");
  }

  DatasetInfo info;
  info.fps = fps;
  info.codec = options.codec;
  info.robot_type = first.robot.empty() ? "unknown" : first.robot;
  for (const JsonFeature& jf : json_features) {
    info.features.push_back({jf.key, "float32", Names(jf.layout)});
  }
  for (const auto& [path, a] : common) {
    std::vector<std::string> names;
    for (size_t i = 0; i < a.dim; ++i) names.push_back(a.dim == 1 ? "value" : std::to_string(i));
    info.features.push_back({FeatureKey(path), a.integer ? "int64" : "float32", names});
  }
  info.features.push_back({"next.reward", "float32", {"reward"}});
  info.features.push_back({"next.success", "bool", {"success"}});
  info.features.push_back({"next.done", "bool", {"done"}});
  for (const auto& [cam, _] : first.cameras) {
    info.cameras.push_back({"observation.images." + cam, 0, 0});
    report.cameras.push_back(cam);
  }

  // Pass 2.
  Writer writer(tmp, info);
  Sidecar sidecar;
  sidecar.codec = options.codec;
  int64_t done = 0;
  for (size_t i = 0; i < eps.size(); ++i) {
    const EpisodeRef& e = eps[i];
    const Source& src = *used[i];
    const std::string where = e.where();
    Handle f = OpenFile(e.file);
    Handle g(H5Gopen2(f.get(), e.traj.c_str(), H5P_DEFAULT), H5Gclose);
    EpisodeData ep;
    ep.task = e.task;
    ep.length = e.t - 1;
    const size_t n = static_cast<size_t>(ep.length);
    for (const JsonFeature& jf : json_features) {
      auto& col = ep.columns[jf.key];
      if (!Exists(g.get(), jf.rel)) throw Error("missing dataset", where, jf.rel);
      const std::vector<Json> rows = JsonRows(g.get(), jf.rel, where);
      for (size_t i = 0; i < n; ++i)
        AppendRow(rows[i + (jf.next ? 1 : 0)], jf.layout, col, where, jf.rel);
    }
    for (const auto& [path, a] : common) {
      const std::vector<double> v = ReadDoubles(Need(g.get(), path, where), where, path);
      ep.columns[FeatureKey(path)].assign(v.begin(), v.begin() + static_cast<long>(n * a.dim));
    }
    {
      const std::vector<double> r = ReadDoubles(Need(g.get(), "rewards", where), where, "rewards");
      const std::vector<int8_t> s = ReadFlags(g.get(), "success", where);
      auto& reward = ep.columns["next.reward"];
      auto& success = ep.columns["next.success"];
      auto& done_col = ep.columns["next.done"];
      for (size_t i = 0; i < n; ++i) {
        reward.push_back(r.at(i + 1));
        success.push_back(s.at(i + 1) != 0 ? 1 : 0);
        done_col.push_back(i + 1 == n ? 1 : 0);
      }
    }
    for (const auto& [cam, file] : e.cameras) {
      ep.videos["observation.images." + cam] = src.video_dir / file;
    }
    const std::vector<VideoSegment> segments = writer.Add(ep);
    // meta/mlspaces/: the episode's HDF5 group unchanged and where its video frames went.
    SidecarEpisode se;
    se.file = src.batch;
    se.traj = e.traj;
    char name[48];
    std::snprintf(name, sizeof name, "hdf5/episode_%06zu.h5", sidecar.episodes.size());
    se.hdf5 = name;
    if (src.own) {
      if (src.file != tmp / kSidecarDir / se.hdf5) {
        throw Error("is not episode " + std::to_string(i) + "'s file", src.file.string());
      }
    } else if (options.mlspaces_meta) {
      CopyTrajectories({{e.file, e.traj}}, tmp / kSidecarDir / se.hdf5);
    }
    size_t c = 0;
    for (const auto& [cam, file] : e.cameras) {
      se.videos["observation.images." + cam] = SidecarVideo{file, segments.at(c++)};
    }
    sidecar.episodes.push_back(std::move(se));
    CrashPoint("lerobot episode");
    if (options.progress) options.progress(++done, static_cast<int64_t>(eps.size()));
  }
  writer.Finish();
  if (options.mlspaces_meta) {
    sidecar.run_files = CopyRunFiles(run_dir, tmp);
    WriteFileAtomic(tmp / kSidecarJson, SidecarToJson(sidecar).dump(2) + "\n", /*sync=*/false);
  } else if (fs::exists(tmp / kSidecarDir)) {
    RemoveAll(tmp / kSidecarDir);  // episode files written from records, read, not kept
  }
  SyncFileSystem(tmp);
  CrashPoint("lerobot files");
  RenamePath(tmp, out);
  staging.Keep();
  FsyncPath(parent, true, parent.string());
  CrashPoint("lerobot dataset");
  report.episodes = writer.episodes();
  report.frames = writer.frames();
  report.fps = fps;
  std::set<std::string> tasks;
  for (const EpisodeRef& e : eps) tasks.insert(e.task);
  report.tasks = static_cast<int64_t>(tasks.size());
  return report;
}

}  // namespace

ExportReport ExportLeRobot(const fs::path& dataset_dir, const fs::path& out_dir,
                           const ExportOptions& options) {
  return Export([&](const fs::path&, ExportReport&) { return BatchSources(dataset_dir); },
                dataset_dir, out_dir, options);
}

ExportReport ExportLeRobotRecords(const fs::path& run_dir, const fs::path& out_dir,
                                  const ExportOptions& options) {
  return Export([&](const fs::path& tmp,
                    ExportReport& report) { return RecordSources(run_dir, tmp, report); },
                run_dir, out_dir, options);
}

}  // namespace mlspaces::datagen::lerobot
