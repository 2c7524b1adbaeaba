// validate-dataset: the walk over the folder (unfinished writes, files, unnamed videos).
#include "mlspaces/datagen/dataset_validate.h"

#include <algorithm>

#include "mlspaces/core/error.h"

#include "dataset_validate_internal.h"

namespace mlspaces::datagen::dataset_check {

void Validator::Run(const fs::path& dir) {
  // One trajectory file: that file and the videos it names (no folder walk).
  if (std::error_code fec; fs::is_regular_file(dir, fec)) {
    FileIsolated(dir);
    return;
  }
  // Walk first (the .parts folders must be skipped while walking), then check in path order.
  enum class Kind { kH5, kVideo, kPartsDir, kTemp, kEpisodeVideo };
  std::vector<std::pair<fs::path, Kind>> entries;
  std::error_code ec;
  fs::recursive_directory_iterator it(dir, ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    const std::string name = p.filename().string();
    std::error_code ec2;
    if (it->is_directory(ec2)) {
      if (EndsWith(name, ".parts")) {
        entries.emplace_back(p, Kind::kPartsDir);
        it.disable_recursion_pending();
      }
      continue;
    }
    if (name.find(".tmp.") != std::string::npos) {
      entries.emplace_back(p, Kind::kTemp);
    } else if (StartsWith(name, ".episode_") && EndsWith(name, ".mp4")) {
      entries.emplace_back(p, Kind::kEpisodeVideo);
    } else if (EndsWith(name, ".h5")) {
      entries.emplace_back(p, Kind::kH5);
    } else if (EndsWith(name, ".mp4")) {
      entries.emplace_back(p, Kind::kVideo);
    }
  }
  if (ec) Add(dir.string(), "", "cannot list the folder: " + ec.message());
  std::sort(entries.begin(), entries.end());

  std::vector<fs::path> videos;
  bool any_h5 = false;
  for (const auto& [p, kind] : entries) {
    switch (kind) {
      case Kind::kPartsDir:
        Add(p.string(), "",
            "unfinished write: episode part files never merged into the batch file "
            "(finish the run with mlspaces datagen --resume)");
        MarkIncomplete(p.parent_path());
        break;
      case Kind::kTemp:
        Add(p.string(), "", "unfinished write: leftover temp file");
        break;
      case Kind::kEpisodeVideo:
        Add(p.string(), "", "unfinished write: video of an episode that was never kept");
        break;
      case Kind::kH5:
        any_h5 = true;
        FileIsolated(p);
        break;
      case Kind::kVideo:
        videos.push_back(p);
        break;
    }
  }
  if (!any_h5) Add(dir.string(), "", "no trajectory file (*.h5) in the folder");
  // Videos nobody names, in folders whose trajectories could all be read.
  for (const fs::path& v : videos) {
    if (video_refs_.count(Key(v)) == 0 && incomplete_dirs_.count(Key(v.parent_path())) == 0) {
      Add(v.string(), "", "video not named by any trajectory (obs/sensor_data) in its folder");
    }
  }
}

std::string Validator::Key(const fs::path& p) {
  std::error_code ec;
  fs::path abs = fs::absolute(p, ec);
  return (ec ? p : abs).lexically_normal().string();
}

void Validator::Add(const std::string& file, const std::string& path, const std::string& message) {
  report_.problems.push_back(DatasetProblem{file, Printable(path), Printable(message)});
}

void Validator::MarkIncomplete(const fs::path& dir) {
  if (incomplete_dirs_.insert(Key(dir)).second) added_incomplete_.push_back(Key(dir));
}

}  // namespace mlspaces::datagen::dataset_check

namespace mlspaces::datagen {

DatasetReport ValidateDataset(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec) && !std::filesystem::is_regular_file(dir, ec)) {
    const char* what = std::filesystem::exists(dir, ec) ? "not a folder or a file"
                       : dir.extension() == ".h5"       ? "no such file"
                                                        : "no such folder";
    throw Error(what, dir.string());
  }
  DatasetReport report;
  dataset_check::Validator(report).Run(dir);
  return report;
}

}  // namespace mlspaces::datagen
