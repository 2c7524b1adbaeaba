#include "sidecar.h"

#include <hdf5.h>

#include <algorithm>
#include <regex>

#include "../hdf5_util.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;
using h5::Check;
using h5::Handle;

const char* CodecName(VideoCodec c) {
  return c == VideoCodec::kAv1 ? "av1" : c == VideoCodec::kH264 ? "h264" : "copy";
}

void CopyTrajectories(const std::vector<std::pair<fs::path, std::string>>& sources,
                      const fs::path& dst) {
  h5::QuietErrors quiet;
  const std::string path = dst.string();
  CreateDirectories(dst.parent_path());
  Handle fapl(Check(H5Pcreate(H5P_FILE_ACCESS), "H5Pcreate", path, ""), H5Pclose);
  Check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_EARLIEST, H5F_LIBVER_V18),
        "H5Pset_libver_bounds", path, "");
  Check(H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG), "H5Pset_fclose_degree", path, "");
  Handle file(
      Check(H5Fcreate(path.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, fapl.get()), "H5Fcreate", path, ""),
      H5Fclose);
  for (const auto& [src, traj] : sources) {
    Handle in(Check(H5Fopen(src.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "H5Fopen", src.string(), ""),
              H5Fclose);
    Check(H5Ocopy(in.get(), traj.c_str(), file.get(), traj.c_str(), H5P_DEFAULT, H5P_DEFAULT),
          "H5Ocopy", src.string(), traj);
  }
  if (!file.Close()) throw Error("HDF5 H5Fclose failed: " + h5::LastErrorMessage(), path);
}

std::vector<std::string> CopyRunFiles(const fs::path& run_dir, const fs::path& root) {
  static const std::regex names(R"(config\.yaml|journal.*\.jsonl|summary.*\.txt)");
  std::vector<std::string> out;
  if (!fs::is_directory(run_dir)) return out;
  for (const fs::path& p : ListFolder(run_dir)) {
    const std::string n = p.filename().string();
    if (!std::regex_match(n, names) || !fs::is_regular_file(p)) continue;
    const fs::path to = root / kSidecarDir / "run" / n;
    CreateDirectories(to.parent_path());
    std::error_code ec;
    fs::copy_file(p, to, ec);
    if (ec) throw Error("cannot copy: " + ec.message(), p.string());
    out.push_back(n);
  }
  std::sort(out.begin(), out.end());
  return out;
}

Json SidecarToJson(const Sidecar& s) {
  Json eps = Json::array();
  for (const SidecarEpisode& e : s.episodes) {
    Json videos = Json::object();
    for (const auto& [key, v] : e.videos) {
      videos[key] = {{"file", v.file},
                     {"frames", v.segment.frames},
                     {"start", v.segment.start},
                     {"offset", v.segment.offset},
                     {"time_base", {v.segment.time_base_num, v.segment.time_base_den}}};
    }
    eps.push_back({{"file", e.file}, {"traj", e.traj}, {"hdf5", e.hdf5}, {"videos", videos}});
  }
  return {{"format", "mlspaces"},
          {"version", kSidecarVersion},
          {"about",
           "what mlspaces import-lerobot needs to give back the HDF5 + MP4 dataset exactly "
           "(docs/lerobot.md); LeRobot does not read it"},
          {"codec", CodecName(s.codec)},
          {"run_files", s.run_files},
          {"episodes", eps}};
}

Sidecar SidecarFromJson(const Json& j, const std::string& path) {
  auto need = [&](const Json& o, const char* k, const std::string& field) -> const Json& {
    if (!o.is_object() || !o.contains(k)) throw Error("missing", path, field + k);
    return o.at(k);
  };
  Sidecar s;
  try {
    if (need(j, "format", "").get<std::string>() != "mlspaces") {
      throw Error("not an mlspaces sidecar", path, "format");
    }
    if (need(j, "version", "").get<int>() != kSidecarVersion) {
      throw Error("version " + j["version"].dump() + " is not " + std::to_string(kSidecarVersion),
                  path, "version");
    }
    const std::string codec = need(j, "codec", "").get<std::string>();
    s.codec = codec == "av1"    ? VideoCodec::kAv1
              : codec == "h264" ? VideoCodec::kH264
                                : VideoCodec::kCopy;
    for (const Json& r : need(j, "run_files", "")) s.run_files.push_back(r.get<std::string>());
    const Json& eps = need(j, "episodes", "");
    for (size_t i = 0; i < eps.size(); ++i) {
      const std::string f = "episodes/" + std::to_string(i) + "/";
      SidecarEpisode e;
      e.file = need(eps[i], "file", f).get<std::string>();
      e.traj = need(eps[i], "traj", f).get<std::string>();
      e.hdf5 = need(eps[i], "hdf5", f).get<std::string>();
      for (const auto& [key, v] : need(eps[i], "videos", f).items()) {
        SidecarVideo sv;
        const std::string vf = f + "videos/" + key + "/";
        sv.file = need(v, "file", vf).get<std::string>();
        sv.segment.frames = need(v, "frames", vf).get<int64_t>();
        sv.segment.start = need(v, "start", vf).get<int64_t>();
        sv.segment.offset = need(v, "offset", vf).get<int64_t>();
        const Json& tb = need(v, "time_base", vf);
        sv.segment.time_base_num = tb.at(0).get<int>();
        sv.segment.time_base_den = tb.at(1).get<int>();
        e.videos[key] = sv;
      }
      for (const std::string& name : {e.file, e.hdf5}) {
        if (name.empty() || fs::path(name).is_absolute() || name.find("..") != std::string::npos) {
          throw Error("not a relative path inside the dataset: '" + name + "'", path, f);
        }
      }
      s.episodes.push_back(std::move(e));
    }
  } catch (const Json::exception& ex) {
    throw Error(std::string("malformed: ") + ex.what(), path);
  }
  return s;
}

}  // namespace mlspaces::datagen::lerobot
