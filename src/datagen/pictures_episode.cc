// An episode's frames at each planner phase: policy_phase from the batch file (HDF5), the
// frames from the episode's camera video (ProbeVideo), composed into a labelled grid.
#include <hdf5.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "hdf5_util.h"
#include "mlspaces/core/error.h"
#include "mlspaces/datagen/dataset_schema.h"
#include "mlspaces/datagen/pictures.h"
#include "mlspaces/datagen/tasks/pick/pick_planner.h"
#include "mlspaces/datagen/video.h"

namespace mlspaces::datagen {

namespace {

namespace fs = std::filesystem;
using h5::Check;
using h5::Handle;

const std::regex kHouse("house_(\\d+)");
const std::regex kBatch("trajectories_batch_(\\d+)_of_(\\d+)\\.h5");
const std::regex kTraj("traj_(\\d+)");

/// The number in `name` when it matches `re` fully, else -1.
long long Number(const std::regex& re, const std::string& name) {
  std::smatch m;
  if (!std::regex_match(name, m, re)) return -1;
  try {
    return std::stoll(m[1].str());
  } catch (const std::exception&) {
    return -1;
  }
}

/// Entries of `dir` whose names match `re`, by their number.
std::vector<fs::path> Numbered(const fs::path& dir, const std::regex& re, bool dirs) {
  std::vector<std::pair<long long, fs::path>> found;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    if (dirs ? !e.is_directory() : !e.is_regular_file()) continue;
    const long long n = Number(re, e.path().filename().string());
    if (n >= 0) found.emplace_back(n, e.path());
  }
  std::sort(found.begin(), found.end());
  std::vector<fs::path> out;
  out.reserve(found.size());
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

Handle OpenFile(const fs::path& file) {
  h5::QuietErrors quiet;
  const hid_t id = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) throw Error("cannot read it as an HDF5 batch file", file.string());
  return Handle(id, H5Fclose);
}

/// Names of the members of group `g`.
std::vector<std::string> Members(hid_t g) {
  std::vector<std::string> names;
  H5Literate(
      g, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
      },
      &names);
  return names;
}

std::vector<std::string> Trajs(const fs::path& file) {
  const Handle f = OpenFile(file);
  std::vector<std::pair<long long, std::string>> trajs;
  for (const std::string& name : Members(f.get())) {
    const long long n = Number(kTraj, name);
    if (n >= 0) trajs.emplace_back(n, name);
  }
  std::sort(trajs.begin(), trajs.end());
  std::vector<std::string> out;
  out.reserve(trajs.size());
  for (auto& t : trajs) out.push_back(std::move(t.second));
  return out;
}

/// A whole dataset's raw bytes of `path` under `g` as `mem` elements (count checked).
template <class T>
std::vector<T> ReadAll(hid_t g, const std::string& path, hid_t mem, const std::string& file,
                       const std::string& field) {
  h5::QuietErrors quiet;
  if (H5Lexists(g, path.c_str(), H5P_DEFAULT) <= 0) throw Error("missing", file, field);
  const Handle d(Check(H5Dopen2(g, path.c_str(), H5P_DEFAULT), "open", file, field), H5Dclose);
  const Handle space(Check(H5Dget_space(d.get()), "read", file, field), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  std::vector<T> v(static_cast<size_t>(std::max<hssize_t>(n, 0)));
  if (!v.empty() && H5Dread(d.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) {
    throw Error("cannot read it", file, field);
  }
  return v;
}

}  // namespace

std::vector<EpisodeRef> ListEpisodes(const fs::path& dataset) {
  std::error_code ec;
  if (!fs::exists(dataset, ec)) throw Error("dataset not found", dataset.string());
  std::vector<fs::path> files;
  if (fs::is_directory(dataset)) {
    std::vector<fs::path> houses = Numbered(dataset, kHouse, true);
    if (houses.empty()) houses.push_back(dataset);
    for (const fs::path& h : houses) {
      for (fs::path& b : Numbered(h, kBatch, false)) files.push_back(std::move(b));
    }
    if (files.empty()) {
      throw Error(
          "not a dataset folder (no house_<i> folders and no trajectories_batch_<b>_of_<n>.h5 "
          "files)",
          dataset.string());
    }
  } else {
    files.push_back(dataset);
  }
  std::vector<EpisodeRef> out;
  for (const fs::path& f : files) {
    for (std::string& t : Trajs(f)) out.push_back({f, std::move(t)});
  }
  return out;
}

EpisodeFrames EpisodePhaseFrames(const fs::path& dataset, int64_t index,
                                 const std::string& camera) {
  const std::vector<EpisodeRef> episodes = ListEpisodes(dataset);
  if (index < 0 || index >= static_cast<int64_t>(episodes.size())) {
    throw Error("episode " + std::to_string(index) + " out of range: the dataset has " +
                    std::to_string(episodes.size()) + " episodes",
                dataset.string());
  }
  EpisodeFrames out;
  out.episode = episodes[static_cast<size_t>(index)];
  const std::string file = out.episode.file.string();
  const std::string& traj = out.episode.traj;
  const Handle f = OpenFile(out.episode.file);
  const std::string phase_field = traj + "/" + schema::kExtra + "/policy_phase";
  const std::vector<int64_t> phases =
      ReadAll<int64_t>(f.get(), phase_field, H5T_NATIVE_INT64, file, phase_field);
  if (phases.empty()) throw Error("no observations", file, phase_field);
  out.num_steps = static_cast<int64_t>(phases.size());
  // The cameras: obs/sensor_data/<cam> (zero-padded file names), depth videos left out.
  const std::string sensor = traj + "/" + schema::kSensorData;
  std::map<std::string, std::string> videos;
  {
    h5::QuietErrors quiet;
    if (H5Lexists(f.get(), sensor.c_str(), H5P_DEFAULT) > 0) {
      const Handle g(Check(H5Gopen2(f.get(), sensor.c_str(), H5P_DEFAULT), "open", file, sensor),
                     H5Gclose);
      for (const std::string& cam : Members(g.get())) {
        if (cam.size() > 6 && cam.compare(cam.size() - 6, 6, "_depth") == 0) continue;
        const std::vector<uint8_t> bytes =
            ReadAll<uint8_t>(g.get(), cam, H5T_NATIVE_UINT8, file, sensor + "/" + cam);
        std::string name(bytes.begin(), bytes.end());
        name.resize(std::strlen(name.c_str()));
        if (!name.empty()) videos[cam] = name;
      }
    }
  }
  if (videos.empty()) {
    throw Error("the episode has no camera videos (recorded without cameras)", file, sensor);
  }
  if (camera.empty()) {
    out.camera = videos.begin()->first;
  } else if (videos.count(camera) == 0) {
    std::string names;
    for (const auto& [cam, _] : videos) names += (names.empty() ? "" : ", ") + cam;
    throw Error("no camera '" + camera + "' (cameras: " + names + ")", file, sensor);
  } else {
    out.camera = camera;
  }
  // The observations to show: each phase change, and the last one.
  std::set<int64_t> steps;
  for (size_t t = 0; t < phases.size(); ++t) {
    if (t == 0 || phases[t] != phases[t - 1]) steps.insert(static_cast<int64_t>(t));
  }
  steps.insert(out.num_steps - 1);
  const Json names = PolicyPhaseMap();
  std::map<int64_t, std::string> phase_names;
  for (const auto& [name, id] : names.items()) phase_names[id.get<int64_t>()] = name;
  for (int64_t t : steps) {
    PhaseFrame pf;
    pf.step = t;
    pf.phase = phases[static_cast<size_t>(t)];
    const auto it = phase_names.find(pf.phase);
    pf.phase_name = it != phase_names.end() ? it->second : "phase " + std::to_string(pf.phase);
    out.frames.push_back(std::move(pf));
  }
  const fs::path video = out.episode.file.parent_path() / videos[out.camera];
  size_t next = 0;
  const VideoInfo info = ProbeVideo(video, [&](const VideoFrame& frame) {
    if (next < out.frames.size() && frame.index == out.frames[next].step) {
      sim::Image& image = out.frames[next].image;
      image.width = frame.width;
      image.height = frame.height;
      image.rgb.assign(frame.rgb, frame.rgb + static_cast<size_t>(frame.width) * frame.height * 3);
      ++next;
    }
  });
  if (info.frames < out.num_steps) {
    throw Error("has " + std::to_string(info.frames) + " frames, the episode " +
                    std::to_string(out.num_steps) + " observations",
                video.string());
  }
  return out;
}

sim::Image EpisodePhaseSheet(const EpisodeFrames& frames, int columns, int tile_width) {
  std::vector<sim::Image> tiles;
  std::vector<std::string> labels;
  for (const PhaseFrame& pf : frames.frames) {
    const sim::Image& src = pf.image;
    if (tile_width <= 0 || tile_width == src.width) {
      tiles.push_back(src);
    } else {
      const int w = tile_width;
      const int h = std::max(1, static_cast<int>(static_cast<int64_t>(src.height) * w / src.width));
      sim::Image dst = sim::Image::Filled(w, h);
      for (int y = 0; y < h; ++y) {
        const int sy = static_cast<int>(static_cast<int64_t>(y) * src.height / h);
        for (int x = 0; x < w; ++x) {
          const int sx = static_cast<int>(static_cast<int64_t>(x) * src.width / w);
          std::memcpy(&dst.rgb[(static_cast<size_t>(y) * w + x) * 3],
                      &src.rgb[(static_cast<size_t>(sy) * src.width + sx) * 3], 3);
        }
      }
      tiles.push_back(std::move(dst));
    }
    const bool last = pf.step == frames.num_steps - 1;
    labels.push_back("step " + std::to_string(pf.step) + ": " + pf.phase_name +
                     (last ? " (end)" : ""));
  }
  const fs::path& file = frames.episode.file;
  const std::string title = (file.parent_path().filename() / file.filename()).string() + " " +
                            frames.episode.traj + ", " + frames.camera;
  return sim::ComposeGrid(tiles, labels, columns, title);
}

}  // namespace mlspaces::datagen
