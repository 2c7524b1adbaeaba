#include "mlspaces/datagen/episode_record.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <map>

#include "mlspaces/core/error.h"

namespace mlspaces::datagen {
namespace {

template <class T>
void PutValue(std::vector<unsigned char>& bytes, T v) {
  const size_t at = bytes.size();
  bytes.resize(at + sizeof(T));
  std::memcpy(bytes.data() + at, &v, sizeof(T));
}

void DumpInto(const Json& v, std::string& out) {
  switch (v.type()) {
    case Json::value_t::object: {
      // Python's sort_keys compares code points; UTF-8 byte order is the same order.
      std::map<std::string, const Json*> sorted;
      for (auto it = v.begin(); it != v.end(); ++it) sorted.emplace(it.key(), &it.value());
      out += '{';
      bool first = true;
      for (const auto& [key, value] : sorted) {
        if (!first) out += ',';
        first = false;
        out += Json(key).dump(-1, ' ', true);
        out += ':';
        DumpInto(*value, out);
      }
      out += '}';
      return;
    }
    case Json::value_t::array: {
      out += '[';
      for (size_t i = 0; i < v.size(); ++i) {
        if (i > 0) out += ',';
        DumpInto(v[i], out);
      }
      out += ']';
      return;
    }
    case Json::value_t::number_float: {
      const double d = v.get<double>();
      if (std::isnan(d)) {
        out += "NaN";
      } else if (std::isinf(d)) {
        out += d > 0 ? "Infinity" : "-Infinity";
      } else {
        out += v.dump();
      }
      return;
    }
    default:
      out += v.dump(-1, ' ', true);
  }
}

// double -> integer type, saturating (NaN -> 0) instead of undefined behaviour.
template <class T>
T ToInt(double v) {
  if (std::isnan(v)) return 0;
  if (v <= static_cast<double>(std::numeric_limits<T>::min())) {
    return std::numeric_limits<T>::min();
  }
  if (v >= static_cast<double>(std::numeric_limits<T>::max())) {
    return std::numeric_limits<T>::max();
  }
  return static_cast<T>(v);
}

}  // namespace

const char* DTypeName(DType dtype) {
  switch (dtype) {
    case DType::kBool:
      return "bool";
    case DType::kUint8:
      return "uint8";
    case DType::kInt32:
      return "int32";
    case DType::kInt64:
      return "int64";
    case DType::kFloat32:
      return "float32";
    case DType::kFloat64:
      return "float64";
  }
  return "?";
}

size_t DTypeSize(DType dtype) {
  switch (dtype) {
    case DType::kBool:
    case DType::kUint8:
      return 1;
    case DType::kInt32:
    case DType::kFloat32:
      return 4;
    case DType::kInt64:
    case DType::kFloat64:
      return 8;
  }
  return 0;
}

Series::Series(DType dtype, std::vector<size_t> row_shape)
    : dtype_(dtype), row_shape_(std::move(row_shape)) {}

size_t Series::row_size() const {
  size_t n = 1;
  for (size_t d : row_shape_) n *= d;
  return n;
}

void Series::CheckRow(size_t n) const {
  if (n != row_size()) {
    throw Error("row " + std::to_string(steps_) + " has " + std::to_string(n) +
                " values, expected " + std::to_string(row_size()));
  }
}

void Series::Append(const std::vector<double>& row) {
  CheckRow(row.size());
  for (double v : row) {
    switch (dtype_) {
      case DType::kBool:
        PutValue<uint8_t>(bytes_, v != 0.0 ? 1 : 0);
        break;
      case DType::kUint8:
        PutValue(bytes_, ToInt<uint8_t>(v));
        break;
      case DType::kInt32:
        PutValue(bytes_, ToInt<int32_t>(v));
        break;
      case DType::kInt64:
        PutValue(bytes_, ToInt<int64_t>(v));
        break;
      case DType::kFloat32:
        PutValue(bytes_, static_cast<float>(v));
        break;
      case DType::kFloat64:
        PutValue(bytes_, v);
        break;
    }
  }
  ++steps_;
}

void Series::AppendInts(const std::vector<int64_t>& row) {
  CheckRow(row.size());
  for (int64_t v : row) {
    switch (dtype_) {
      case DType::kBool:
        PutValue<uint8_t>(bytes_, v != 0 ? 1 : 0);
        break;
      case DType::kUint8:
        PutValue(bytes_, static_cast<uint8_t>(v));
        break;
      case DType::kInt32:
        PutValue(bytes_, static_cast<int32_t>(v));
        break;
      case DType::kInt64:
        PutValue(bytes_, v);
        break;
      case DType::kFloat32:
        PutValue(bytes_, static_cast<float>(v));
        break;
      case DType::kFloat64:
        PutValue(bytes_, static_cast<double>(v));
        break;
    }
  }
  ++steps_;
}

Series Series::FromBytes(DType dtype, std::vector<size_t> row_shape, size_t steps,
                         std::vector<unsigned char> bytes) {
  Series s(dtype, std::move(row_shape));
  if (bytes.size() != steps * s.row_size() * DTypeSize(dtype)) {
    throw Error(std::to_string(bytes.size()) + " bytes are not " + std::to_string(steps) +
                " rows of " + std::to_string(s.row_size()) + " " + DTypeName(dtype) + " values");
  }
  s.bytes_ = std::move(bytes);
  s.steps_ = steps;
  return s;
}

// ---------------------------------------------------------------------------------------------
// EncodeEpisodeRecord / DecodeEpisodeRecord: the record as one JSON document in CBOR (numbers
// exact: CBOR keeps every double, NaN too; Series bytes as binary strings).

namespace {

constexpr int kRecordVersion = 1;

Json SeriesJson(const Series& s) {
  return Json{{"dtype", static_cast<int>(s.dtype())},
              {"shape", s.row_shape()},
              {"steps", s.steps()},
              {"bytes", Json::binary(s.bytes())}};
}

Series SeriesFrom(const Json& j) {
  const int dtype = j.at("dtype").get<int>();
  if (dtype < 0 || dtype > static_cast<int>(DType::kFloat64)) throw Error("bad dtype");
  return Series::FromBytes(static_cast<DType>(dtype), j.at("shape").get<std::vector<size_t>>(),
                           j.at("steps").get<size_t>(), j.at("bytes").get_binary());
}

template <class T, class F>
Json MapJson(const std::map<std::string, T>& m, F&& f) {
  Json out = Json::object();
  for (const auto& [k, v] : m) out[k] = f(v);
  return out;
}

template <class T, class F>
std::map<std::string, T> MapFrom(const Json& j, F&& f) {
  std::map<std::string, T> out;
  for (auto it = j.begin(); it != j.end(); ++it) out.emplace(it.key(), f(it.value()));
  return out;
}

Json StepsJson(const std::vector<MoveGroupValues>& steps) {
  Json out = Json::array();
  for (const MoveGroupValues& v : steps)
    out.push_back(MapJson(v, [](const auto& x) { return Json(x); }));
  return out;
}

std::vector<MoveGroupValues> StepsFrom(const Json& j) {
  std::vector<MoveGroupValues> out;
  for (const Json& v : j) {
    out.push_back(MapFrom<std::vector<double>>(
        v, [](const Json& x) { return x.get<std::vector<double>>(); }));
  }
  return out;
}

std::vector<unsigned char> FloatBytes(const std::vector<float>& v) {
  std::vector<unsigned char> b(v.size() * sizeof(float));
  if (!v.empty()) std::memcpy(b.data(), v.data(), b.size());
  return b;
}

}  // namespace

std::string EncodeEpisodeRecord(const EpisodeRecord& r) {
  const EpisodeMetadata& m = r.meta;
  Json assets = Json::array();
  for (const AssetProvenance& a : m.assets) {
    assets.push_back(Json::array({a.uid, a.library, a.license, a.role}));
  }
  Json cameras = Json::array();
  for (const CameraRecord& c : r.cameras) {
    cameras.push_back(Json{{"name", c.name},
                           {"params", MapJson(c.params, SeriesJson)},
                           {"video_file", c.video_file},
                           {"depth_video_file", c.depth_video_file}});
  }
  Json j{{"mlspaces_episode_record", kRecordVersion},
         {"meta",
          {{"config_hash", m.config_hash},
           {"seed", m.seed},
           {"scene", m.scene},
           {"source_episode", m.source_episode},
           {"task_description", m.task_description},
           {"assets", std::move(assets)},
           {"license_policy", m.license_policy},
           {"robot", m.robot},
           {"robot_description_hash", m.robot_description_hash},
           {"mujoco_version", m.mujoco_version},
           {"mlspaces_version", m.mlspaces_version},
           {"extra", m.extra}}},
         {"qpos", StepsJson(r.qpos)},
         {"qvel", StepsJson(r.qvel)},
         {"actions", MapJson(r.actions, StepsJson)},
         {"extra", MapJson(r.extra, SeriesJson)},
         {"extra_json", MapJson(r.extra_json,
                                [](const JsonSeries& s) {
                                  return Json{{"steps", s.steps}, {"max_len", s.max_len}};
                                })},
         {"env_states", MapJson(r.env_states, SeriesJson)},
         {"env_state_groups", r.env_state_groups},
         {"cameras", std::move(cameras)},
         {"rewards", Json::binary(FloatBytes(r.rewards))},
         {"success", r.success},
         {"terminated", r.terminated},
         {"truncated", r.truncated},
         {"obs_scene", r.obs_scene}};
  const std::vector<std::uint8_t> cbor = Json::to_cbor(j);
  return std::string(cbor.begin(), cbor.end());
}

EpisodeRecord DecodeEpisodeRecord(std::string_view bytes, const std::string& path_for_errors) {
  EpisodeRecord r;
  try {
    const Json j = Json::from_cbor(bytes.begin(), bytes.end());
    if (j.value("mlspaces_episode_record", 0) != kRecordVersion) {
      throw Error("not an episode record of version " + std::to_string(kRecordVersion),
                  path_for_errors, "mlspaces_episode_record");
    }
    const Json& m = j.at("meta");
    r.meta.config_hash = m.at("config_hash").get<std::string>();
    r.meta.seed = m.at("seed").get<uint64_t>();
    r.meta.scene = m.at("scene").get<std::string>();
    r.meta.source_episode = m.at("source_episode").get<int64_t>();
    r.meta.task_description = m.at("task_description").get<std::string>();
    for (const Json& a : m.at("assets")) {
      r.meta.assets.push_back({a.at(0).get<std::string>(), a.at(1).get<std::string>(),
                               a.at(2).get<std::string>(), a.at(3).get<std::string>()});
    }
    r.meta.license_policy = m.at("license_policy").get<std::string>();
    r.meta.robot = m.at("robot").get<std::string>();
    r.meta.robot_description_hash = m.at("robot_description_hash").get<std::string>();
    r.meta.mujoco_version = m.at("mujoco_version").get<std::string>();
    r.meta.mlspaces_version = m.at("mlspaces_version").get<std::string>();
    r.meta.extra = m.at("extra");
    r.qpos = StepsFrom(j.at("qpos"));
    r.qvel = StepsFrom(j.at("qvel"));
    r.actions = MapFrom<std::vector<MoveGroupValues>>(j.at("actions"), StepsFrom);
    r.extra = MapFrom<Series>(j.at("extra"), SeriesFrom);
    r.extra_json = MapFrom<JsonSeries>(j.at("extra_json"), [](const Json& s) {
      JsonSeries out;
      out.steps = s.at("steps").get<std::vector<Json>>();
      out.max_len = s.at("max_len").get<size_t>();
      return out;
    });
    r.env_states = MapFrom<Series>(j.at("env_states"), SeriesFrom);
    r.env_state_groups = j.at("env_state_groups").get<std::vector<std::string>>();
    for (const Json& c : j.at("cameras")) {
      CameraRecord cam;
      cam.name = c.at("name").get<std::string>();
      cam.params = MapFrom<Series>(c.at("params"), SeriesFrom);
      cam.video_file = c.at("video_file").get<std::string>();
      cam.depth_video_file = c.at("depth_video_file").get<std::string>();
      r.cameras.push_back(std::move(cam));
    }
    const std::vector<std::uint8_t>& rewards = j.at("rewards").get_binary();
    if (rewards.size() % sizeof(float) != 0) throw Error("bad rewards", path_for_errors, "rewards");
    r.rewards.resize(rewards.size() / sizeof(float));
    if (!rewards.empty()) std::memcpy(r.rewards.data(), rewards.data(), rewards.size());
    r.success = j.at("success").get<std::vector<bool>>();
    r.terminated = j.at("terminated").get<std::vector<bool>>();
    r.truncated = j.at("truncated").get<std::vector<bool>>();
    r.obs_scene = j.at("obs_scene");
  } catch (const Json::exception& e) {
    throw Error(std::string("not an episode record: ") + e.what(), path_for_errors);
  } catch (const Error& e) {
    if (!e.path().empty()) throw;
    throw Error(e.message(), path_for_errors, e.field());
  }
  return r;
}

std::string DumpJsonCompactSorted(const Json& value) {
  std::string out;
  DumpInto(value, out);
  return out;
}

Json MoveGroupJson(const MoveGroupValues& values, bool round_to_float32) {
  Json out = Json::object();
  for (const auto& [group, vals] : values) {
    Json arr = Json::array();
    for (double v : vals) {
      arr.push_back(round_to_float32 ? static_cast<double>(static_cast<float>(v)) : v);
    }
    out[group] = std::move(arr);
  }
  return out;
}

}  // namespace mlspaces::datagen
