// import-lerobot: meta/mlspaces/ (sidecar.h) back into the HDF5 + MP4 dataset.
#include "mlspaces/datagen/lerobot/import.h"

#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "sidecar.h"
#include "video_concat.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;

namespace {

Json ReadJson(const fs::path& p) {
  Json j = Json::parse(ReadFile(p), nullptr, false);
  if (j.is_discarded()) throw Error("not JSON", p.string());
  return j;
}

}  // namespace

ImportReport ImportLeRobot(const fs::path& lerobot_dir, const fs::path& out_dir,
                           const std::function<void(int64_t, int64_t)>& progress) {
  ImportReport report;
  const fs::path out = fs::absolute(out_dir).lexically_normal();
  const fs::path parent = out.has_filename() ? out.parent_path() : out.parent_path().parent_path();
  if (fs::exists(out))
    throw Error("already exists; remove it or choose another folder", out.string());
  const fs::path info_path = lerobot_dir / "meta" / "info.json";
  if (!fs::is_regular_file(info_path)) {
    throw Error("not a LeRobot dataset (no meta/info.json)", info_path.string());
  }
  const Json info = ReadJson(info_path);
  const fs::path sidecar_path = lerobot_dir / kSidecarJson;
  if (!fs::is_regular_file(sidecar_path)) {
    throw Error(
        "not a LeRobot dataset made by mlspaces (no meta/mlspaces/mlspaces.json): "
        "import-lerobot reads what export-lerobot and datagen --format lerobot write",
        sidecar_path.string());
  }
  const Sidecar sc = SidecarFromJson(ReadJson(sidecar_path), sidecar_path.string());
  if (sc.codec != VideoCodec::kCopy) {
    throw Error(std::string("its videos were re-encoded (--codec ") + CodecName(sc.codec) +
                    "), so their frames are not the episodes' own; import needs an export "
                    "made with --codec copy",
                sidecar_path.string(), "codec");
  }
  if (!info.is_object() || !info.contains("total_episodes") ||
      info["total_episodes"] != static_cast<int64_t>(sc.episodes.size())) {
    throw Error("total_episodes is not the " + std::to_string(sc.episodes.size()) +
                    " episodes of meta/mlspaces/mlspaces.json",
                info_path.string(), "total_episodes");
  }
  if (sc.episodes.empty()) throw Error("no episodes", sidecar_path.string(), "episodes");

  // Batch files in order of first appearance, their episodes in order.
  std::vector<std::string> files;
  std::map<std::string, std::vector<std::pair<fs::path, std::string>>> sources;
  std::set<std::pair<std::string, std::string>> seen;
  for (const SidecarEpisode& e : sc.episodes) {
    const fs::path h5 = lerobot_dir / kSidecarDir / e.hdf5;
    if (!fs::is_regular_file(h5)) throw Error("missing episode file", h5.string());
    if (!seen.insert({e.file, e.traj}).second) {
      throw Error("episode " + e.file + " " + e.traj + " listed twice", sidecar_path.string(),
                  "episodes");
    }
    if (!sources.count(e.file)) files.push_back(e.file);
    sources[e.file].emplace_back(h5, e.traj);
  }

  StagingFolder staging(parent / out.filename());
  const fs::path tmp = staging.path();
  CreateDirectories(tmp);
  int64_t done = 0;
  for (const std::string& f : files) {
    CopyTrajectories(sources[f], tmp / f);
    ++report.batch_files;
    if (progress) progress(++done, static_cast<int64_t>(files.size()));
  }
  report.episodes = static_cast<int64_t>(sc.episodes.size());

  // Videos: each camera's joined file cut back into the episodes' own MP4s.
  std::map<std::string, std::pair<std::vector<VideoSegment>, std::vector<fs::path>>> cuts;
  for (const SidecarEpisode& e : sc.episodes) {
    for (const auto& [key, v] : e.videos) {
      if (v.file.empty() || v.file.find('/') != std::string::npos || v.file == "..") {
        throw Error("not a file name: '" + v.file + "'", sidecar_path.string(),
                    "videos/" + key + "/file");
      }
      cuts[key].first.push_back(v.segment);
      cuts[key].second.push_back(tmp / fs::path(e.file).parent_path() / v.file);
    }
  }
  for (const auto& [key, cut] : cuts) {
    const fs::path joined = lerobot_dir / "videos" / key / "chunk-000" / "file-000.mp4";
    if (!fs::is_regular_file(joined)) throw Error("missing video", joined.string());
    SplitVideo(joined, cut.first, cut.second);
    report.videos += static_cast<int64_t>(cut.second.size());
  }
  for (const std::string& n : sc.run_files) {
    if (n.find('/') != std::string::npos) {
      throw Error("not a file name: '" + n + "'", sidecar_path.string(), "run_files");
    }
    const fs::path from = lerobot_dir / kSidecarDir / "run" / n;
    std::error_code ec;
    fs::copy_file(from, tmp / n, ec);
    if (ec) throw Error("cannot copy: " + ec.message(), from.string());
  }
  SyncFileSystem(tmp);
  CrashPoint("lerobot import files");
  RenamePath(tmp, out);
  staging.Keep();
  FsyncPath(parent, true, parent.string());
  return report;
}

}  // namespace mlspaces::datagen::lerobot
