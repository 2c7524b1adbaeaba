// validate-dataset: one file and its trajectories (datasets, flags, obs_scene, provenance).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "dataset_validate_internal.h"
#include "mlspaces/library/license_policy.h"

namespace mlspaces::datagen::dataset_check {

// -------------------------------------------------------------------------------------------
// One file
void Validator::File(const fs::path& p) {
  ++report_.files;
  file_ = p.string();
  dir_ = p.parent_path();
  h5::QuietErrors quiet;
  Handle f(H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (f.get() < 0) {
    Add("", HdfMessage("not a readable HDF5 file"));
    MarkIncomplete(dir_);
    return;
  }
  const auto names = ListLinks(f.get(), false);
  if (!names) {
    Add("/", HdfMessage("cannot list the root group"));
    MarkIncomplete(dir_);
    return;
  }
  std::map<int64_t, std::string> trajs;
  for (const std::string& name : *names) {
    if (!StartsWith(name, schema::kTrajPrefix)) continue;  // e.g. post-processing outputs
    const std::string digits = name.substr(sizeof(schema::kTrajPrefix) - 1);
    const bool canonical = !digits.empty() && digits.size() <= 9 &&
                           digits.find_first_not_of("0123456789") == std::string::npos &&
                           (digits == "0" || digits[0] != '0');
    if (!canonical) {
      Add(name, "unexpected name: trajectories are traj_<k>, k = 0, 1, …");
      continue;
    }
    trajs.emplace(std::stoll(digits), name);
  }
  if (trajs.empty()) {
    Add("", "no traj_<k> group");
    return;
  }
  const int64_t last = trajs.rbegin()->first;
  const int64_t missing = last + 1 - static_cast<int64_t>(trajs.size());
  if (missing > 0) {
    int64_t first_missing = 0;
    while (trajs.count(first_missing) != 0) ++first_missing;
    Add("", "trajectory numbering has gaps: " + std::to_string(missing) + " of traj_0 … traj_" +
                std::to_string(last) + " missing (first: traj_" + std::to_string(first_missing) +
                ")");
  }
  for (const auto& [k, name] : trajs) {
    ++report_.trajectories;
    CheckTraj(f.get(), name, k);
  }
}

// -------------------------------------------------------------------------------------------
// One trajectory
void Validator::CheckTraj(hid_t file, const std::string& name, int64_t k) {
  Handle g(H5Oopen(file, name.c_str(), H5P_DEFAULT), H5Oclose);
  if (g.get() < 0) {
    Add(name, HdfMessage("cannot open"));
    return;
  }
  if (H5Iget_type(g.get()) != H5I_GROUP) {
    Add(name, "expected a group, found a dataset");
    return;
  }
  Traj t;
  t.g = g.get();
  t.name = name;
  t.k = k;
  // T: the rows of obs/agent/qpos (or, when that is unusable, of rewards, to go on checking).
  {
    h5::QuietErrors quiet;
    const std::string qpos = std::string(schema::kAgent) + "/" + schema::kAgentDatasets[0];
    for (const std::string& source : {qpos, std::string(schema::kRewards)}) {
      if (!Exists(t.g, source)) continue;
      Handle ds(H5Dopen2(t.g, source.c_str(), H5P_DEFAULT), H5Dclose);
      Handle space(ds.get() >= 0 ? H5Dget_space(ds.get()) : H5I_INVALID_HID, H5Sclose);
      if (space.get() < 0 || H5Sget_simple_extent_ndims(space.get()) < 1) continue;
      std::vector<hsize_t> dims(H5Sget_simple_extent_ndims(space.get()));
      H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
      t.t = static_cast<int64_t>(dims[0]);
      t.t_source = source;
      break;
    }
  }
  if (t.t >= 0 && t.t < 2) {
    Add(name + "/" + t.t_source,
        "T = " + std::to_string(t.t) +
            " rows: an episode needs at least one observation and one step (T >= 2)");
  }

  JsonGroup(t, schema::kAgent, schema::kAgentDatasets);
  JsonGroup(t, schema::kActions, schema::kActionDatasets);
  if (auto ds = Open(t.g, name, schema::kRewards, true)) {
    const hid_t type = ds->type.get();
    if (H5Tget_class(type) != H5T_FLOAT || H5Tget_size(type) != 4 || ds->dims.size() != 1) {
      Add(ds->path, "expected float32 (T,), got " + TypeName(type) + " " + Shape(ds->dims));
    } else if (Rows(*ds, t)) {
      ReadNumeric(*ds);
    }
  }
  for (const char* flag : schema::kFlagDatasets) Bools(t, flag);
  FlagConsistency(t);
  ObsScene(t);
  Provenance(t);
  // Per-step numeric (and JSON) datasets of any name.
  for (const char* group : {schema::kExtra, schema::kEnvStates}) {
    const bool extra = std::strcmp(group, schema::kExtra) == 0;
    VisitDatasets(t, group, [&](const Ds& ds) {
      if (extra && IsUint8(ds.type.get()) && ds.dims.size() == 2) {
        JsonRows(ds, t, false);
      } else if (Rows(ds, t)) {
        ReadNumeric(ds);
      }
    });
  }
  Cameras(t);
}

void Validator::Bools(Traj& t, const std::string& flag) {
  auto ds = Open(t.g, t.name, flag, true);
  if (!ds) return;
  const hid_t type = ds->type.get();
  const H5T_class_t c = H5Tget_class(type);
  if ((c != H5T_ENUM && c != H5T_INTEGER) || H5Tget_size(type) != 1 || ds->dims.size() != 1) {
    Add(ds->path,
        "expected bool (T,) (int8 enum FALSE/TRUE), got " + TypeName(type) + " " + Shape(ds->dims));
    return;
  }
  if (!Rows(*ds, t)) return;
  std::vector<int8_t> v(ds->dims[0]);
  if (!Read(*ds, type, v.data())) return;
  for (size_t i = 0; i < v.size(); ++i) {
    if (v[i] != 0 && v[i] != 1) {
      Add(ds->path, "row " + std::to_string(i) + " holds " + std::to_string(v[i]) +
                        ", expected 0 (FALSE) or 1 (TRUE)");
      return;
    }
  }
  t.flags[flag] = std::move(v);
}

void Validator::FlagConsistency(const Traj& t) {
  auto get = [&](const char* name) -> const std::vector<int8_t>* {
    auto it = t.flags.find(name);
    return it == t.flags.end() ? nullptr : &it->second;
  };
  const auto *success = get(schema::kSuccess), *fail = get(schema::kFail);
  const auto *terminated = get(schema::kTerminated), *truncated = get(schema::kTruncated);
  if (success != nullptr && fail != nullptr && success->size() == fail->size()) {
    int64_t differ = 0;
    size_t first = 0;
    for (size_t i = 0; i < success->size(); ++i) {
      if ((*fail)[i] == (*success)[i] && differ++ == 0) first = i;
    }
    if (differ > 0) {
      Add(t.name + "/fail", "row " + std::to_string(first) + " equals success (" +
                                ((*success)[first] ? "TRUE" : "FALSE") +
                                "): fail must be !success (" + std::to_string(differ) + " of " +
                                std::to_string(success->size()) + " rows)");
    }
  }
  for (const auto* flags : {terminated, truncated}) {
    if (flags == nullptr || flags->empty()) continue;
    int64_t early = 0;
    size_t first = 0;
    for (size_t i = 0; i + 1 < flags->size(); ++i) {
      if ((*flags)[i] != 0 && early++ == 0) first = i;
    }
    if (early > 0) {
      Add(t.name + (flags == terminated ? "/terminated" : "/truncated"),
          "set on row " + std::to_string(first) + " of " + std::to_string(flags->size()) +
              ": only the last row may end the episode" +
              (early > 1 ? " (" + std::to_string(early) + " rows set early)" : ""));
    }
  }
  if (terminated != nullptr && truncated != nullptr && !terminated->empty() &&
      terminated->size() == truncated->size() && terminated->back() == 0 &&
      truncated->back() == 0) {
    Add(t.name + "/terminated", "the last row (" + std::to_string(terminated->size() - 1) +
                                    ") is neither terminated nor truncated");
  }
}

void Validator::ObsScene(const Traj& t) {
  auto ds = Open(t.g, t.name, schema::kObsScene, true);
  if (!ds) return;
  const auto text = ReadString(ds->id.get(), false, ds->path);
  if (!text) return;
  const auto j = ParsePythonJson(*text);
  if (!j) {
    Add(ds->path, "is not valid JSON: " + Snippet(*text));
  } else if (!j->is_object()) {
    Add(ds->path, "is a JSON " + JsonTypeName(*j) + ", expected an object");
  }
}

void Validator::Provenance(const Traj& t) {
  const std::string path = t.name + "@" + schema::kProvenance;
  const htri_t exists = H5Aexists(t.g, schema::kProvenance);
  if (exists <= 0) {
    Add(path, exists == 0 ? "missing" : HdfMessage("cannot read"));
    return;
  }
  Handle attr(H5Aopen(t.g, schema::kProvenance, H5P_DEFAULT), H5Aclose);
  if (attr.get() < 0) {
    Add(path, HdfMessage("cannot open"));
    return;
  }
  const auto text = ReadString(attr.get(), true, path);
  if (!text) return;
  const auto p = ParsePythonJson(*text);
  if (!p || !p->is_object()) {
    Add(path, p ? "is a JSON " + JsonTypeName(*p) + ", expected an object"
                : "is not valid JSON: " + Snippet(*text));
    return;
  }
  auto non_empty_string = [&](const FlatJson& obj, const char* key, const std::string& where,
                              const std::string& uid = "") {
    auto it = obj.find(key);
    const std::string suffix = uid.empty() ? "" : " (uid \"" + uid + "\")";
    if (it == obj.end()) {
      Add(where + "/" + key, "missing" + suffix);
    } else if (!it->is_string() || it->get<std::string>().empty()) {
      Add(where + "/" + key,
          (it->is_string() ? std::string("empty") : "expected a string, got " + JsonTypeName(*it)) +
              suffix);
    }
  };
  non_empty_string(*p, "config_hash", path);
  non_empty_string(*p, "mujoco_version", path);
  non_empty_string(*p, "mlspaces_version", path);
  if (auto it = p->find("seed"); it == p->end()) {
    Add(path + "/seed", "missing");
  } else if (!it->is_number_unsigned()) {
    Add(path + "/seed", "expected an unsigned integer, got " + it->dump());
  }
  if (auto it = p->find("assets"); it == p->end()) {
    Add(path + "/assets", "missing");
  } else if (!it->is_array()) {
    Add(path + "/assets", "expected an array, got " + JsonTypeName(*it));
  } else {
    for (size_t i = 0; i < it->size(); ++i) {
      const FlatJson& a = (*it)[i];
      const std::string where = path + "/assets/" + std::to_string(i);
      if (!a.is_object()) {
        Add(where, "expected an object, got " + JsonTypeName(a));
        continue;
      }
      const std::string uid =
          a.contains("uid") && a["uid"].is_string() ? a["uid"].get<std::string>() : "";
      non_empty_string(a, "uid", where);
      non_empty_string(a, "library", where, uid);
      non_empty_string(a, "license", where, uid);
    }
  }
  // Optional (older runs lack it): the run's licence policy, which its assets must obey.
  if (auto it = p->find("license_policy"); it != p->end()) {
    if (!it->is_string() || (*it != "all" && *it != "commercial_safe")) {
      Add(path + "/license_policy", it->dump() + ", expected \"all\" or \"commercial_safe\"");
    } else if (*it == "commercial_safe" && p->contains("assets") && (*p)["assets"].is_array()) {
      const FlatJson& assets = (*p)["assets"];
      for (size_t i = 0; i < assets.size(); ++i) {
        const FlatJson& a = assets[i];
        if (!a.is_object() || !a.contains("license") || !a["license"].is_string()) continue;
        const std::string license = a["license"].get<std::string>();
        if (license == "CC-BY-NC-4.0" || license == "CC-BY-NC-SA-4.0" ||
            IsNonCommercialLicense(license)) {
          Add(path + "/assets/" + std::to_string(i) + "/license",
              license + " (non-commercial) under license_policy commercial_safe");
        }
      }
    }
  }
  // Optional (older runs lack it): the robot, {"name", "description_hash"}.
  if (auto it = p->find("robot"); it != p->end()) {
    if (!it->is_object()) {
      Add(path + "/robot", "expected an object, got " + JsonTypeName(*it));
    } else {
      non_empty_string(*it, "name", path + "/robot");
      non_empty_string(*it, "description_hash", path + "/robot");
    }
  }
  // Optional fields, when present, must agree with the datasets.
  if (auto it = p->find("episode_index"); it != p->end() && *it != FlatJson(t.k)) {
    Add(path + "/episode_index",
        it->dump() + ", expected " + std::to_string(t.k) + " (the k of traj_<k>)");
  }
  if (auto it = p->find("num_steps"); it != p->end() && t.t >= 0 && *it != FlatJson(t.t)) {
    Add(path + "/num_steps", it->dump() + ", expected T = " + std::to_string(t.t));
  }
  for (const char* flag : {"success", "terminated", "truncated"}) {
    auto it = p->find(flag);
    auto rows = t.flags.find(flag);
    if (it == p->end() || rows == t.flags.end() || rows->second.empty()) continue;
    const bool last = rows->second.back() != 0;
    if (!it->is_boolean() || it->get<bool>() != last) {
      Add(path + "/" + flag, it->dump() + ", but the last row of " + t.name + "/" + flag + " is " +
                                 (last ? "TRUE" : "FALSE"));
    }
  }
}

}  // namespace mlspaces::datagen::dataset_check
