// ValidateLeRobot (validate.h): the v3.0 layout, read back with Arrow C++ and FFmpeg.
#include "mlspaces/datagen/lerobot/validate.h"

#include <arrow/api.h>
#include <arrow/io/file.h>
#include <parquet/arrow/reader.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/video.h"
#include "sidecar.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;

namespace {

struct Checker {
  fs::path dir;
  LeRobotReport report;

  void Problem(const fs::path& file, const std::string& field, const std::string& message) {
    std::string line = file.string() + ": ";
    if (!field.empty()) line += field + ": ";
    report.problems.push_back(line + message);
  }

  std::optional<Json> ReadJson(const fs::path& p) {
    if (!fs::is_regular_file(p)) {
      Problem(p, "", "missing");
      return std::nullopt;
    }
    try {
      Json j = Json::parse(ReadFile(p), nullptr, false);
      if (j.is_discarded() || !j.is_object()) {
        Problem(p, "", "not a JSON object");
        return std::nullopt;
      }
      return j;
    } catch (const Error& e) {
      Problem(p, "", e.message());
      return std::nullopt;
    }
  }

  std::shared_ptr<arrow::Table> ReadParquet(const fs::path& p) {
    if (!fs::is_regular_file(p)) {
      Problem(p, "", "missing");
      return nullptr;
    }
    auto file = arrow::io::ReadableFile::Open(p.string());
    if (!file.ok()) {
      Problem(p, "", "cannot open: " + file.status().ToString());
      return nullptr;
    }
    auto reader = parquet::arrow::OpenFile(*file, arrow::default_memory_pool());
    if (!reader.ok()) {
      Problem(p, "", "not a readable parquet file: " + reader.status().message());
      return nullptr;
    }
    std::shared_ptr<arrow::Table> table;
    arrow::Status st = (*reader)->ReadTable(&table);
    if (st.ok()) {
      auto combined = table->CombineChunks();
      if (combined.ok()) {
        table = *combined;
      } else {
        st = combined.status();
      }
    }
    if (!st.ok()) {
      Problem(p, "", "cannot read the rows: " + st.message());
      return nullptr;
    }
    return table;
  }

  // A column as numbers (int64, float, double or bool scalars), or nullopt with a problem.
  std::optional<std::vector<double>> Numbers(const arrow::Table& t, const std::string& name,
                                             const fs::path& p) {
    auto col = t.GetColumnByName(name);
    if (!col) {
      Problem(p, name, "missing column");
      return std::nullopt;
    }
    std::vector<double> v;
    v.reserve(static_cast<size_t>(t.num_rows()));
    for (const auto& chunk : col->chunks()) {
      for (int64_t i = 0; i < chunk->length(); ++i) {
        auto s = chunk->GetScalar(i);
        if (!s.ok() || !(*s)->is_valid) {
          Problem(p, name, "row " + std::to_string(v.size()) + " is null");
          return std::nullopt;
        }
        auto d = (*s)->CastTo(arrow::float64());
        if (!d.ok()) {
          Problem(p, name, "not numbers (" + col->type()->ToString() + ")");
          return std::nullopt;
        }
        v.push_back(std::static_pointer_cast<arrow::DoubleScalar>(*d)->value);
      }
    }
    return v;
  }

  static std::string Format(std::string tpl, const std::map<std::string, std::string>& keys) {
    for (const auto& [k, v] : keys) {
      for (const std::string& pat : {"{" + k + ":03d}", "{" + k + "}"}) {
        for (size_t at; (at = tpl.find(pat)) != std::string::npos;) tpl.replace(at, pat.size(), v);
      }
    }
    return tpl;
  }
  static std::string Pad(int64_t n) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "%03lld", static_cast<long long>(n));
    return buf;
  }

  void Run();
};

std::shared_ptr<arrow::DataType> ArrowType(const std::string& dtype) {
  if (dtype == "float32") return arrow::float32();
  if (dtype == "float64") return arrow::float64();
  if (dtype == "int64") return arrow::int64();
  if (dtype == "int32") return arrow::int32();
  if (dtype == "bool") return arrow::boolean();
  if (dtype == "string") return arrow::utf8();
  return nullptr;
}

void Checker::Run() {
  const fs::path info_path = dir / "meta" / "info.json";
  const std::optional<Json> info = ReadJson(info_path);
  if (!info) return;
  auto need_int = [&](const char* k) -> std::optional<int64_t> {
    if (!info->contains(k) || !(*info)[k].is_number_integer() || (*info)[k].get<int64_t>() < 0) {
      Problem(info_path, k, "missing or not a count");
      return std::nullopt;
    }
    return (*info)[k].get<int64_t>();
  };
  if (info->value("codebase_version", std::string()) != "v3.0") {
    Problem(info_path, "codebase_version", "is not \"v3.0\"");
  }
  const double fps =
      info->contains("fps") && (*info)["fps"].is_number() ? (*info)["fps"].get<double>() : 0;
  if (!(fps > 0)) Problem(info_path, "fps", "missing or not > 0");
  const auto total_episodes = need_int("total_episodes");
  const auto total_frames = need_int("total_frames");
  const auto total_tasks = need_int("total_tasks");
  const std::string data_path = info->value("data_path", std::string());
  if (data_path.empty()) Problem(info_path, "data_path", "missing");
  const std::string video_path =
      (*info)["video_path"].is_string() ? (*info)["video_path"].get<std::string>() : "";
  if (!info->contains("features") || !(*info)["features"].is_object()) {
    Problem(info_path, "features", "missing or not an object");
    return;
  }
  struct Feat {
    std::string dtype;
    int64_t dim = 1;
    std::vector<int64_t> shape;
  };
  std::map<std::string, Feat> features;
  std::vector<std::string> video_keys;
  for (const auto& [key, f] : (*info)["features"].items()) {
    const std::string field = "features/" + key;
    if (!f.is_object() || !f.contains("dtype") || !f["dtype"].is_string() || !f.contains("shape") ||
        !f["shape"].is_array()) {
      Problem(info_path, field, "needs dtype and shape");
      continue;
    }
    Feat ft;
    ft.dtype = f["dtype"].get<std::string>();
    for (const Json& d : f["shape"]) {
      if (!d.is_number_integer() || d.get<int64_t>() <= 0) {
        Problem(info_path, field + "/shape", "not positive integers");
        ft.shape.clear();
        break;
      }
      ft.shape.push_back(d.get<int64_t>());
      ft.dim *= d.get<int64_t>();
    }
    if (ft.dtype == "video" || ft.dtype == "image") {
      if (ft.shape.size() != 3)
        Problem(info_path, field + "/shape", "not (height, width, channels)");
      if (ft.dtype == "video") video_keys.push_back(key);  // images are parquet columns
    } else if (!ArrowType(ft.dtype)) {
      Problem(info_path, field + "/dtype", "unknown dtype '" + ft.dtype + "'");
      continue;
    }
    features[key] = ft;
  }
  for (const char* k : {"timestamp", "frame_index", "episode_index", "index", "task_index"}) {
    if (!features.count(k)) Problem(info_path, std::string("features/") + k, "missing");
  }
  if (!video_keys.empty() && video_path.empty()) Problem(info_path, "video_path", "missing");

  // meta/stats.json
  const fs::path stats_path = dir / "meta" / "stats.json";
  if (const std::optional<Json> stats = ReadJson(stats_path)) {
    for (const auto& [key, _] : features) {
      if (!stats->contains(key)) {
        Problem(stats_path, key, "missing");
        continue;
      }
      for (const char* s : {"min", "max", "mean", "std", "count"}) {
        if (!(*stats)[key].contains(s)) Problem(stats_path, key + "/" + s, "missing");
      }
    }
  }

  // meta/tasks.parquet
  const fs::path tasks_path = dir / "meta" / "tasks.parquet";
  int64_t tasks = -1;
  if (auto t = ReadParquet(tasks_path)) {
    tasks = t->num_rows();
    if (!t->GetColumnByName("task_index")) Problem(tasks_path, "task_index", "missing column");
    if (!t->GetColumnByName("task")) Problem(tasks_path, "task", "missing column");
    if (total_tasks && tasks != *total_tasks) {
      Problem(info_path, "total_tasks",
              std::to_string(*total_tasks) + " but tasks.parquet has " + std::to_string(tasks));
    }
  }

  // meta/episodes/*/*.parquet
  const fs::path ep_dir = dir / "meta" / "episodes";
  std::vector<fs::path> ep_files;
  if (fs::is_directory(ep_dir)) {
    for (const fs::path& c : ListFolder(ep_dir)) {
      if (!fs::is_directory(c)) continue;
      for (const fs::path& f : ListFolder(c)) {
        if (f.extension() == ".parquet") ep_files.push_back(f);
      }
    }
  }
  std::sort(ep_files.begin(), ep_files.end());
  if (ep_files.empty()) {
    Problem(ep_dir, "", "no episodes parquet file (chunk-*/file-*.parquet)");
    return;
  }
  std::map<std::string, std::vector<double>> ep;  // column -> values over every file
  std::vector<std::string> ep_cols = {"episode_index",      "length",
                                      "data/chunk_index",   "data/file_index",
                                      "dataset_from_index", "dataset_to_index"};
  for (const std::string& k : video_keys) {
    for (const char* c : {"chunk_index", "file_index", "from_timestamp", "to_timestamp"}) {
      ep_cols.push_back("videos/" + k + "/" + c);
    }
  }
  bool ep_ok = true;
  for (const fs::path& f : ep_files) {
    auto t = ReadParquet(f);
    if (!t) {
      ep_ok = false;
      continue;
    }
    for (const std::string& c : ep_cols) {
      auto v = Numbers(*t, c, f);
      if (!v) {
        ep_ok = false;
        continue;
      }
      ep[c].insert(ep[c].end(), v->begin(), v->end());
    }
  }
  if (!ep_ok) return;
  const size_t n_ep = ep["episode_index"].size();
  report.episodes = static_cast<int64_t>(n_ep);
  const fs::path ep_where = ep_files.front().parent_path().parent_path();
  if (total_episodes && static_cast<int64_t>(n_ep) != *total_episodes) {
    Problem(info_path, "total_episodes",
            std::to_string(*total_episodes) + " but meta/episodes has " + std::to_string(n_ep) +
                " rows");
  }
  int64_t expect_from = 0;
  for (size_t i = 0; i < n_ep; ++i) {
    const std::string row = "row " + std::to_string(i);
    const auto from = static_cast<int64_t>(ep["dataset_from_index"][i]);
    const auto to = static_cast<int64_t>(ep["dataset_to_index"][i]);
    if (static_cast<int64_t>(ep["episode_index"][i]) != static_cast<int64_t>(i)) {
      Problem(ep_where, "episode_index", row + " is not " + std::to_string(i));
    }
    if (from != expect_from || to - from != static_cast<int64_t>(ep["length"][i]) || to <= from) {
      Problem(ep_where, "dataset_from_index",
              row + ": [" + std::to_string(from) + ", " + std::to_string(to) + ") with length " +
                  std::to_string(static_cast<int64_t>(ep["length"][i])) + " does not continue at " +
                  std::to_string(expect_from));
    }
    expect_from = to;
  }
  if (total_frames && expect_from != *total_frames) {
    Problem(info_path, "total_frames",
            std::to_string(*total_frames) + " but the episodes cover " +
                std::to_string(expect_from) + " frames");
  }

  // data files
  std::set<std::pair<int64_t, int64_t>> data_files;
  for (size_t i = 0; i < n_ep; ++i) {
    data_files.insert({static_cast<int64_t>(ep["data/chunk_index"][i]),
                       static_cast<int64_t>(ep["data/file_index"][i])});
  }
  int64_t rows = 0;
  bool data_ok = true;
  for (const auto& [chunk, file] : data_files) {
    const fs::path p =
        dir / Format(data_path, {{"chunk_index", Pad(chunk)}, {"file_index", Pad(file)}});
    auto t = ReadParquet(p);
    if (!t) {
      data_ok = false;
      continue;
    }
    for (const auto& [key, ft] : features) {
      if (ft.dtype == "video") continue;
      auto col = t->GetColumnByName(key);
      if (!col) {
        Problem(p, key, "missing column (a feature of info.json)");
        continue;
      }
      if (ft.dtype == "image") continue;  // a struct of bytes and path, as datasets writes it
      const auto want = ArrowType(ft.dtype);
      const auto& type = col->type();
      bool good = ft.dim == 1 && type->Equals(want);
      if (!good && type->id() == arrow::Type::FIXED_SIZE_LIST) {
        const auto& l = static_cast<const arrow::FixedSizeListType&>(*type);
        good = l.list_size() == ft.dim && l.value_type()->Equals(want);
      }
      if (!good && type->id() == arrow::Type::LIST) {
        good = static_cast<const arrow::ListType&>(*type).value_type()->Equals(want);
      }
      if (!good) {
        Problem(p, key,
                "column type " + type->ToString() + " is not info.json's " + ft.dtype + " of " +
                    std::to_string(ft.dim) + " values");
      }
    }
    for (const auto& f : t->schema()->fields()) {
      if (!features.count(f->name()))
        Problem(p, f->name(), "a column that info.json does not list");
    }
    auto epi = Numbers(*t, "episode_index", p), fi = Numbers(*t, "frame_index", p),
         idx = Numbers(*t, "index", p), ts = Numbers(*t, "timestamp", p);
    if (epi && fi && idx && ts) {
      for (int64_t r = 0; r < t->num_rows(); ++r) {
        const auto e = static_cast<int64_t>((*epi)[r]);
        const auto g = static_cast<int64_t>((*idx)[r]);
        std::string bad;
        if (e < 0 || e >= static_cast<int64_t>(n_ep)) {
          bad = "episode_index " + std::to_string(e) + " is no episode";
        } else if (g < ep["dataset_from_index"][e] || g >= ep["dataset_to_index"][e]) {
          bad = "index " + std::to_string(g) + " is outside episode " + std::to_string(e) +
                "'s range";
        } else if ((*fi)[r] != g - ep["dataset_from_index"][e]) {
          bad = "frame_index is not index - the episode's dataset_from_index";
        } else if (fps > 0 && std::abs((*ts)[r] - (*fi)[r] / fps) > 1e-3) {
          bad = "timestamp is not frame_index / fps";
        }
        if (!bad.empty()) {
          Problem(p, "row " + std::to_string(r), bad);
          break;
        }
      }
    }
    rows += t->num_rows();
  }
  report.frames = rows;
  if (data_ok && total_frames && rows != *total_frames) {
    Problem(info_path, "total_frames",
            std::to_string(*total_frames) + " but the data files have " + std::to_string(rows) +
                " rows");
  }

  // videos
  for (const std::string& key : video_keys) {
    const std::string k = "videos/" + key + "/";
    std::map<std::pair<int64_t, int64_t>, std::vector<size_t>> files;
    for (size_t i = 0; i < n_ep; ++i) {
      files[{static_cast<int64_t>(ep[k + "chunk_index"][i]),
             static_cast<int64_t>(ep[k + "file_index"][i])}]
          .push_back(i);
    }
    for (const auto& [cf, eps] : files) {
      const fs::path p = dir / Format(video_path, {{"video_key", key},
                                                   {"chunk_index", Pad(cf.first)},
                                                   {"file_index", Pad(cf.second)}});
      ++report.videos;
      if (!fs::is_regular_file(p)) {
        Problem(p, key, "missing video");
        continue;
      }
      VideoInfo v;
      try {
        v = ProbeVideo(p);
      } catch (const Error& e) {
        Problem(p, key, e.message());
        continue;
      }
      const Feat& ft = features[key];
      if (ft.shape.size() == 3 && (v.height != ft.shape[0] || v.width != ft.shape[1])) {
        Problem(p, key,
                "frame size " + std::to_string(v.width) + "x" + std::to_string(v.height) +
                    " is not info.json's " + std::to_string(ft.shape[1]) + "x" +
                    std::to_string(ft.shape[0]));
      }
      if (fps > 0 && std::abs(v.fps - fps) > 0.01) {
        Problem(p, key, "frame rate " + std::to_string(v.fps) + " is not the dataset's fps");
      }
      for (size_t i : eps) {
        const double from = ep[k + "from_timestamp"][i], to = ep[k + "to_timestamp"][i];
        const double len = ep["length"][i];
        const double last = std::round(from * fps) + len;  // frames needed
        if (fps > 0 &&
            (last > static_cast<double>(v.frames) + 1e-6 || to + 1e-4 < from + len / fps)) {
          Problem(p, key,
                  "episode " + std::to_string(i) + " needs frames up to " +
                      std::to_string(static_cast<int64_t>(last)) + " ([" + std::to_string(from) +
                      ", " + std::to_string(to) + ") s), the file has " + std::to_string(v.frames));
        }
      }
    }
  }

  // meta/mlspaces (mlspaces-made datasets)
  const fs::path sidecar = dir / kSidecarJson;
  if (fs::exists(sidecar)) {
    if (const std::optional<Json> j = ReadJson(sidecar)) {
      try {
        const Sidecar s = SidecarFromJson(*j, sidecar.string());
        if (s.episodes.size() != n_ep) {
          Problem(
              sidecar, "episodes",
              std::to_string(s.episodes.size()) + " but the dataset has " + std::to_string(n_ep));
        }
        for (const SidecarEpisode& e : s.episodes) {
          if (!fs::is_regular_file(dir / kSidecarDir / e.hdf5)) {
            Problem(dir / kSidecarDir / e.hdf5, "", "missing");
          }
        }
        for (const std::string& r : s.run_files) {
          if (!fs::is_regular_file(dir / kSidecarDir / "run" / r)) {
            Problem(dir / kSidecarDir / "run" / r, "", "missing");
          }
        }
      } catch (const Error& e) {
        Problem(sidecar, e.field(), e.message());
      }
    }
  }
}

}  // namespace

LeRobotReport ValidateLeRobot(const fs::path& dir) {
  Checker c;
  c.dir = dir;
  try {
    c.Run();
  } catch (const std::exception& e) {
    c.Problem(dir, "", e.what());
  }
  return std::move(c.report);
}

}  // namespace mlspaces::datagen::lerobot
