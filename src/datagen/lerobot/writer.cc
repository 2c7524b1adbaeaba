// The LeRobot v3.0 layout (docs/lerobot.md): parquet through Arrow C++, JSON meta, videos
// through VideoConcat.
#include "mlspaces/datagen/lerobot/writer.h"

#include <arrow/api.h>
#include <arrow/io/file.h>
#include <parquet/arrow/writer.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "video_concat.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;

namespace {

constexpr int64_t kChunksSize = 1000;
constexpr int64_t kDataFileSizeMb = 100;
constexpr int64_t kVideoFileSizeMb = 500;
constexpr char kChunkFile[] = "chunk-000/file-000";

template <class T>
T Check(arrow::Result<T> r, const fs::path& path) {
  if (!r.ok()) throw Error("Arrow: " + r.status().ToString(), path.string());
  return std::move(r).ValueOrDie();
}
void Check(const arrow::Status& s, const fs::path& path) {
  if (!s.ok()) throw Error("Arrow: " + s.ToString(), path.string());
}

// Running min, max, sum, sum of squares per value of a feature.
struct Stats {
  std::vector<double> min, max, sum, sum_sq;
  int64_t count = 0;
  explicit Stats(size_t dim = 0)
      : min(dim, std::numeric_limits<double>::infinity()),
        max(dim, -std::numeric_limits<double>::infinity()),
        sum(dim),
        sum_sq(dim) {}
  void Add(const double* row) {
    for (size_t i = 0; i < min.size(); ++i) {
      const double v = row[i];
      if (!std::isfinite(v)) continue;  // a missing command (NaN) counts for nothing
      min[i] = std::min(min[i], v);
      max[i] = std::max(max[i], v);
      sum[i] += v;
      sum_sq[i] += v * v;
    }
    ++count;
  }
  Json ToJson() const {
    Json j = Json::object();
    std::vector<double> mean(min.size()), std(min.size());
    for (size_t i = 0; i < min.size(); ++i) {
      const double n = static_cast<double>(count);
      mean[i] = count > 0 ? sum[i] / n : 0;
      std[i] = count > 0 ? std::sqrt(std::max(0.0, sum_sq[i] / n - mean[i] * mean[i])) : 0;
    }
    auto finite = [](std::vector<double> v) {
      for (double& x : v) {
        if (!std::isfinite(x)) x = 0;
      }
      return v;
    };
    j["min"] = finite(min);
    j["max"] = finite(max);
    j["mean"] = mean;
    j["std"] = std;
    j["count"] = std::vector<int64_t>{count};
    return j;
  }
};

// `values` (rows * dim) as a column: a scalar column for dim 1, else fixed_size_list<dim>.
std::shared_ptr<arrow::Array> Column(const std::string& dtype, size_t dim,
                                     const std::vector<double>& values, const fs::path& path) {
  std::shared_ptr<arrow::Array> flat;
  if (dtype == "float32") {
    arrow::FloatBuilder b;
    Check(b.Reserve(static_cast<int64_t>(values.size())), path);
    for (double v : values) b.UnsafeAppend(static_cast<float>(v));
    flat = Check(b.Finish(), path);
  } else if (dtype == "int64") {
    arrow::Int64Builder b;
    Check(b.Reserve(static_cast<int64_t>(values.size())), path);
    for (double v : values) b.UnsafeAppend(static_cast<int64_t>(v));
    flat = Check(b.Finish(), path);
  } else {
    arrow::BooleanBuilder b;
    Check(b.Reserve(static_cast<int64_t>(values.size())), path);
    for (double v : values) b.UnsafeAppend(v != 0);
    flat = Check(b.Finish(), path);
  }
  if (dim == 1) return flat;
  return Check(arrow::FixedSizeListArray::FromArrays(flat, static_cast<int32_t>(dim)), path);
}

template <class Builder, class T>
std::shared_ptr<arrow::Array> Simple(const std::vector<T>& values, const fs::path& path) {
  Builder b;
  for (const T& v : values) Check(b.Append(v), path);
  return Check(b.Finish(), path);
}

void WriteParquet(const std::shared_ptr<arrow::Table>& table, const fs::path& path) {
  CreateDirectories(path.parent_path());
  auto out = Check(arrow::io::FileOutputStream::Open(path.string()), path);
  parquet::WriterProperties::Builder props;
  props.compression(parquet::Compression::SNAPPY);
  // The Arrow schema goes into the file too: fixed_size_list<N> columns read back as such.
  Check(parquet::arrow::WriteTable(
            *table, arrow::default_memory_pool(), out, std::max<int64_t>(1, table->num_rows()),
            props.build(), parquet::ArrowWriterProperties::Builder().store_schema()->build()),
        path);
  Check(out->Close(), path);
}

void WriteJson(const fs::path& path, const Json& j) {
  WriteFileAtomic(path, j.dump(4) + "\n", /*sync=*/false);
}

}  // namespace

struct Writer::Impl {
  fs::path dir;
  DatasetInfo info;
  std::vector<size_t> dims;
  // Data, column by column, every episode appended.
  std::map<std::string, std::vector<double>> data;
  std::vector<float> timestamp;
  std::vector<int64_t> frame_index, episode_index, index, task_index;
  std::vector<Stats> stats;
  // Tasks in order of first use.
  std::vector<std::string> tasks;
  std::map<std::string, int64_t> task_ids;
  // Episodes.
  struct Ep {
    int64_t length, from, task;
    std::vector<Segment> videos;  // per camera
  };
  std::vector<Ep> episodes;
  std::vector<std::unique_ptr<VideoConcat>> videos;
  std::vector<PixelStats> pixel_stats;
  bool finished = false;
};

Writer::Writer(fs::path dir, DatasetInfo info) : impl_(new Impl) {
  Impl& m = *impl_;
  m.dir = std::move(dir);
  if (!(info.fps > 0)) throw Error("fps must be > 0", m.dir.string(), "fps");
  std::set<std::string> keys = {"timestamp", "frame_index", "episode_index", "index", "task_index"};
  for (const Feature& f : info.features) {
    if (f.key.find('/') != std::string::npos || f.key.empty()) {
      throw Error("a feature key must be non-empty and have no '/'", m.dir.string(), f.key);
    }
    if (!keys.insert(f.key).second) throw Error("duplicate feature", m.dir.string(), f.key);
    if (f.dtype != "float32" && f.dtype != "int64" && f.dtype != "bool") {
      throw Error("dtype must be float32, int64 or bool, not '" + f.dtype + "'", m.dir.string(),
                  f.key);
    }
    if (f.names.empty()) throw Error("a feature needs at least one name", m.dir.string(), f.key);
    m.dims.push_back(f.names.size());
    m.stats.emplace_back(f.names.size());
    m.data[f.key];
  }
  for (const Camera& c : info.cameras) {
    if (!keys.insert(c.key).second) throw Error("duplicate feature", m.dir.string(), c.key);
    m.videos.push_back(std::make_unique<VideoConcat>(
        m.dir / "videos" / c.key / (std::string(kChunkFile) + ".mp4"), info.codec, info.fps));
    m.pixel_stats.emplace_back();
  }
  m.info = std::move(info);
  CreateDirectories(m.dir / "meta");
}

Writer::~Writer() = default;

int64_t Writer::episodes() const { return static_cast<int64_t>(impl_->episodes.size()); }
int64_t Writer::frames() const { return static_cast<int64_t>(impl_->index.size()); }

std::vector<VideoSegment> Writer::Add(const EpisodeData& e) {
  Impl& m = *impl_;
  if (m.finished) throw Error("Add after Finish", m.dir.string());
  if (e.length <= 0) throw Error("an episode needs at least one frame", m.dir.string());
  const size_t n = static_cast<size_t>(e.length);
  for (size_t f = 0; f < m.info.features.size(); ++f) {
    const Feature& feat = m.info.features[f];
    auto it = e.columns.find(feat.key);
    if (it == e.columns.end()) throw Error("the episode has no column", m.dir.string(), feat.key);
    if (it->second.size() != n * m.dims[f]) {
      throw Error("has " + std::to_string(it->second.size()) + " values, expected " +
                      std::to_string(n * m.dims[f]),
                  m.dir.string(), feat.key);
    }
  }
  Impl::Ep ep{e.length, frames(), 0, {}};
  for (size_t c = 0; c < m.info.cameras.size(); ++c) {
    auto it = e.videos.find(m.info.cameras[c].key);
    if (it == e.videos.end()) {
      throw Error("the episode has no video", m.dir.string(), m.info.cameras[c].key);
    }
    const Segment seg = m.videos[c]->Append(it->second, m.pixel_stats[c]);
    if (seg.frames < e.length) {
      throw Error(
          "has " + std::to_string(seg.frames) + " frames, the episode " + std::to_string(e.length),
          it->second.string());
    }
    ep.videos.push_back(seg);
  }
  auto [task, added] = m.task_ids.emplace(e.task, static_cast<int64_t>(m.tasks.size()));
  if (added) m.tasks.push_back(e.task);
  ep.task = task->second;
  for (size_t f = 0; f < m.info.features.size(); ++f) {
    const std::vector<double>& v = e.columns.at(m.info.features[f].key);
    auto& col = m.data[m.info.features[f].key];
    col.insert(col.end(), v.begin(), v.end());
    for (size_t i = 0; i < n; ++i) m.stats[f].Add(v.data() + i * m.dims[f]);
  }
  const int64_t episode = episodes();
  for (int64_t i = 0; i < e.length; ++i) {
    m.timestamp.push_back(static_cast<float>(static_cast<double>(i) / m.info.fps));
    m.frame_index.push_back(i);
    m.episode_index.push_back(episode);
    m.index.push_back(ep.from + i);
    m.task_index.push_back(ep.task);
  }
  std::vector<VideoSegment> segments = ep.videos;
  m.episodes.push_back(std::move(ep));
  return segments;
}

void Writer::Finish() {
  Impl& m = *impl_;
  if (m.episodes.empty()) throw Error("no episode to write", m.dir.string());
  if (m.finished) return;
  m.finished = true;
  for (auto& v : m.videos) v->Finish();

  // data/chunk-000/file-000.parquet
  const fs::path data_path = m.dir / "data" / (std::string(kChunkFile) + ".parquet");
  std::vector<std::shared_ptr<arrow::Field>> fields;
  std::vector<std::shared_ptr<arrow::Array>> cols;
  auto add = [&](const std::string& name, std::shared_ptr<arrow::Array> a) {
    fields.push_back(arrow::field(name, a->type()));
    cols.push_back(std::move(a));
  };
  for (size_t f = 0; f < m.info.features.size(); ++f) {
    const Feature& feat = m.info.features[f];
    add(feat.key, Column(feat.dtype, m.dims[f], m.data[feat.key], data_path));
  }
  add("timestamp", Simple<arrow::FloatBuilder>(m.timestamp, data_path));
  add("frame_index", Simple<arrow::Int64Builder>(m.frame_index, data_path));
  add("episode_index", Simple<arrow::Int64Builder>(m.episode_index, data_path));
  add("index", Simple<arrow::Int64Builder>(m.index, data_path));
  add("task_index", Simple<arrow::Int64Builder>(m.task_index, data_path));
  WriteParquet(arrow::Table::Make(arrow::schema(fields), cols), data_path);

  // meta/tasks.parquet: pandas reads "task" back as the index (LeRobot looks tasks up by it).
  {
    const fs::path path = m.dir / "meta" / "tasks.parquet";
    std::vector<int64_t> ids(m.tasks.size());
    for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<int64_t>(i);
    Json pandas = {{"index_columns", {"task"}},
                   {"column_indexes",
                    {{{"name", nullptr},
                      {"field_name", nullptr},
                      {"pandas_type", "unicode"},
                      {"numpy_type", "object"},
                      {"metadata", {{"encoding", "UTF-8"}}}}}},
                   {"columns",
                    {{{"name", "task_index"},
                      {"field_name", "task_index"},
                      {"pandas_type", "int64"},
                      {"numpy_type", "int64"},
                      {"metadata", nullptr}},
                     {{"name", "task"},
                      {"field_name", "task"},
                      {"pandas_type", "unicode"},
                      {"numpy_type", "object"},
                      {"metadata", nullptr}}}},
                   {"creator", {{"library", "mlspaces"}, {"version", "0.1"}}},
                   {"pandas_version", "2.2.3"}};
    auto schema = arrow::schema(
        {arrow::field("task_index", arrow::int64()), arrow::field("task", arrow::utf8())},
        arrow::key_value_metadata({"pandas"}, {pandas.dump()}));
    WriteParquet(arrow::Table::Make(schema, {Simple<arrow::Int64Builder>(ids, path),
                                             Simple<arrow::StringBuilder>(m.tasks, path)}),
                 path);
  }

  // meta/episodes/chunk-000/file-000.parquet
  {
    const fs::path path = m.dir / "meta" / "episodes" / (std::string(kChunkFile) + ".parquet");
    std::vector<int64_t> idx, len, from, to, zeros(m.episodes.size(), 0);
    arrow::ListBuilder tasks_b(arrow::default_memory_pool(),
                               std::make_shared<arrow::StringBuilder>());
    auto* task_str = static_cast<arrow::StringBuilder*>(tasks_b.value_builder());
    for (size_t i = 0; i < m.episodes.size(); ++i) {
      const Impl::Ep& e = m.episodes[i];
      idx.push_back(static_cast<int64_t>(i));
      len.push_back(e.length);
      from.push_back(e.from);
      to.push_back(e.from + e.length);
      Check(tasks_b.Append(), path);
      Check(task_str->Append(m.tasks[static_cast<size_t>(e.task)]), path);
    }
    fields.clear();
    cols.clear();
    add("episode_index", Simple<arrow::Int64Builder>(idx, path));
    add("tasks", Check(tasks_b.Finish(), path));
    add("length", Simple<arrow::Int64Builder>(len, path));
    add("data/chunk_index", Simple<arrow::Int64Builder>(zeros, path));
    add("data/file_index", Simple<arrow::Int64Builder>(zeros, path));
    add("dataset_from_index", Simple<arrow::Int64Builder>(from, path));
    add("dataset_to_index", Simple<arrow::Int64Builder>(to, path));
    for (size_t c = 0; c < m.info.cameras.size(); ++c) {
      const std::string k = "videos/" + m.info.cameras[c].key + "/";
      std::vector<double> f, t;
      for (const Impl::Ep& e : m.episodes) {
        f.push_back(e.videos[c].from_s);
        t.push_back(e.videos[c].to_s);
      }
      add(k + "chunk_index", Simple<arrow::Int64Builder>(zeros, path));
      add(k + "file_index", Simple<arrow::Int64Builder>(zeros, path));
      add(k + "from_timestamp", Simple<arrow::DoubleBuilder>(f, path));
      add(k + "to_timestamp", Simple<arrow::DoubleBuilder>(t, path));
    }
    add("meta/episodes/chunk_index", Simple<arrow::Int64Builder>(zeros, path));
    add("meta/episodes/file_index", Simple<arrow::Int64Builder>(zeros, path));
    WriteParquet(arrow::Table::Make(arrow::schema(fields), cols), path);
  }

  // meta/stats.json
  Json stats = Json::object();
  for (size_t f = 0; f < m.info.features.size(); ++f) {
    stats[m.info.features[f].key] = m.stats[f].ToJson();
  }
  for (size_t c = 0; c < m.info.cameras.size(); ++c) {
    const PixelStats& p = m.pixel_stats[c];
    Json s = Json::object();
    auto per_channel = [](const std::array<double, 3>& v) {
      Json j = Json::array();
      for (double x : v) j.push_back(Json::array({Json::array({x})}));
      return j;
    };
    std::array<double, 3> lo{}, hi{}, mean{}, sd{};
    for (int ch = 0; ch < 3; ++ch) {
      double n = 0, sum = 0, sum_sq = 0;
      int first = -1, last = -1;
      for (int v = 0; v < 256; ++v) {
        const auto k = static_cast<double>(p.histogram[ch][v]);
        if (k == 0) continue;
        if (first < 0) first = v;
        last = v;
        const double x = v / 255.0;
        n += k;
        sum += k * x;
        sum_sq += k * x * x;
      }
      lo[ch] = first < 0 ? 0 : first / 255.0;
      hi[ch] = last < 0 ? 0 : last / 255.0;
      mean[ch] = n > 0 ? sum / n : 0;
      sd[ch] = n > 0 ? std::sqrt(std::max(0.0, sum_sq / n - mean[ch] * mean[ch])) : 0;
    }
    s["min"] = per_channel(lo);
    s["max"] = per_channel(hi);
    s["mean"] = per_channel(mean);
    s["std"] = per_channel(sd);
    s["count"] = std::vector<int64_t>{p.frames};
    stats[m.info.cameras[c].key] = s;
  }
  auto scalar_stats = [&](const std::string& key, const std::vector<double>& v) {
    Stats s(1);
    for (double x : v) s.Add(&x);
    stats[key] = s.ToJson();
  };
  scalar_stats("timestamp", std::vector<double>(m.timestamp.begin(), m.timestamp.end()));
  scalar_stats("frame_index", std::vector<double>(m.frame_index.begin(), m.frame_index.end()));
  scalar_stats("episode_index",
               std::vector<double>(m.episode_index.begin(), m.episode_index.end()));
  scalar_stats("index", std::vector<double>(m.index.begin(), m.index.end()));
  scalar_stats("task_index", std::vector<double>(m.task_index.begin(), m.task_index.end()));
  WriteJson(m.dir / "meta" / "stats.json", stats);

  // meta/info.json
  Json features = Json::object();
  for (size_t f = 0; f < m.info.features.size(); ++f) {
    const Feature& feat = m.info.features[f];
    features[feat.key] = {
        {"dtype", feat.dtype}, {"shape", {static_cast<int64_t>(m.dims[f])}}, {"names", feat.names}};
  }
  for (size_t c = 0; c < m.info.cameras.size(); ++c) {
    const int w = m.videos[c]->width(), h = m.videos[c]->height();
    features[m.info.cameras[c].key] = {
        {"dtype", "video"},
        {"shape", {h, w, 3}},
        {"names", {"height", "width", "channels"}},
        {"info",
         {{"video.height", h},
          {"video.width", w},
          {"video.codec", m.info.codec == VideoCodec::kAv1 ? "av1" : "h264"},
          {"video.pix_fmt", "yuv420p"},
          {"video.is_depth_map", false},
          {"video.fps", m.info.fps},
          {"video.channels", 3},
          {"has_audio", false}}}};
  }
  for (const char* k : {"timestamp", "frame_index", "episode_index", "index", "task_index"}) {
    features[k] = {{"dtype", std::string(k) == "timestamp" ? "float32" : "int64"},
                   {"shape", {1}},
                   {"names", nullptr}};
  }
  Json info = {{"codebase_version", "v3.0"},
               {"robot_type", m.info.robot_type},
               {"total_episodes", episodes()},
               {"total_frames", frames()},
               {"total_tasks", static_cast<int64_t>(m.tasks.size())},
               {"chunks_size", kChunksSize},
               {"data_files_size_in_mb", kDataFileSizeMb},
               {"video_files_size_in_mb", kVideoFileSizeMb},
               {"fps", m.info.fps},
               {"splits", {{"train", "0:" + std::to_string(episodes())}}},
               {"data_path", "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"},
               {"video_path",
                m.info.cameras.empty()
                    ? Json(nullptr)
                    : Json("videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4")},
               {"features", features}};
  WriteJson(m.dir / "meta" / "info.json", info);
}

}  // namespace mlspaces::datagen::lerobot
