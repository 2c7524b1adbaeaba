// validate-dataset: crash isolation. Each HDF5 file is checked in a forked child
// (core/subprocess.h) that sends its findings back serialized.
#include <cstring>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/subprocess.h"

#include "dataset_validate_internal.h"

namespace mlspaces::datagen::dataset_check {

// -------------------------------------------------------------------------------------------
// Crash isolation: HDF5 (1.10) can crash on corrupt metadata (e.g. an out-of-bounds read of
// a damaged global heap), so each file is checked in a child process that sends its findings
// back through a pipe; a crash becomes a problem of that file.
void Validator::Put(std::string& out, const std::string& s) {
  out += std::to_string(s.size());
  out += ':';
  out += s;
}

bool Validator::Get(std::string_view& in, std::string& s) {
  const size_t colon = in.find(':');
  if (colon == std::string_view::npos || colon == 0 || colon > 18) return false;
  size_t n = 0;
  for (char c : in.substr(0, colon)) {
    if (c < '0' || c > '9') return false;
    n = n * 10 + static_cast<size_t>(c - '0');
  }
  if (in.size() - colon - 1 < n) return false;
  s.assign(in.substr(colon + 1, n));
  in.remove_prefix(colon + 1 + n);
  return true;
}

bool Validator::GetInt(std::string_view& in, int64_t& v) {
  std::string s;
  if (!Get(in, s) || s.empty() || s.size() > 18 ||
      s.find_first_not_of("0123456789") != std::string::npos) {
    return false;
  }
  v = std::stoll(s);
  return true;
}

/// What File() found since `first_problem`, serialized for the parent.
std::string Validator::Serialize(size_t first_problem, int64_t trajectories, int64_t videos) const {
  std::string out;
  Put(out, std::to_string(report_.trajectories - trajectories));
  Put(out, std::to_string(report_.videos - videos));
  Put(out, std::to_string(report_.problems.size() - first_problem));
  for (size_t i = first_problem; i < report_.problems.size(); ++i) {
    const DatasetProblem& p = report_.problems[i];
    Put(out, p.path);
    Put(out, p.field);
    Put(out, p.message);
  }
  Put(out, std::to_string(added_refs_.size()));
  for (const auto& [key, referer] : added_refs_) {
    Put(out, key);
    Put(out, referer);
  }
  Put(out, std::to_string(added_incomplete_.size()));
  for (const std::string& dir : added_incomplete_) Put(out, dir);
  return out;
}

bool Validator::Deserialize(std::string_view in) {
  DatasetReport delta;
  int64_t n = 0;
  if (!GetInt(in, delta.trajectories) || !GetInt(in, delta.videos) || !GetInt(in, n)) {
    return false;
  }
  for (int64_t i = 0; i < n; ++i) {
    DatasetProblem p;
    if (!Get(in, p.path) || !Get(in, p.field) || !Get(in, p.message)) return false;
    delta.problems.push_back(std::move(p));
  }
  std::vector<std::pair<std::string, std::string>> refs;
  if (!GetInt(in, n)) return false;
  for (int64_t i = 0; i < n; ++i) {
    std::string key, referer;
    if (!Get(in, key) || !Get(in, referer)) return false;
    refs.emplace_back(std::move(key), std::move(referer));
  }
  std::vector<std::string> dirs;
  if (!GetInt(in, n)) return false;
  for (int64_t i = 0; i < n; ++i) {
    std::string dir;
    if (!Get(in, dir)) return false;
    dirs.push_back(std::move(dir));
  }
  if (!in.empty()) return false;
  report_.trajectories += delta.trajectories;
  report_.videos += delta.videos;
  for (DatasetProblem& p : delta.problems) report_.problems.push_back(std::move(p));
  for (auto& [key, referer] : refs) video_refs_.emplace(std::move(key), std::move(referer));
  for (std::string& dir : dirs) incomplete_dirs_.insert(std::move(dir));
  return true;
}

/// File(p) in a child process (in this one if fork or pipe fail).
void Validator::FileIsolated(const fs::path& p) {
  ChildResult child;
  try {
    child = RunInChild([&](int fd) {  // child: check, send
      const size_t first = report_.problems.size();
      const int64_t trajectories = report_.trajectories, videos = report_.videos;
      added_refs_.clear();
      added_incomplete_.clear();
      File(p);
      return WriteAll(fd, Serialize(first, trajectories, videos)) ? 0 : 3;
    });
  } catch (const Error&) {
    File(p);
    return;
  }
  if (child.exit.ok() && Deserialize(child.output)) {
    ++report_.files;
    return;
  }
  ++report_.files;
  file_ = p.string();
  std::string how;
  if (child.exit.signaled) {
    const char* name = ::strsignal(child.exit.number);
    how = "signal " + std::to_string(child.exit.number) + (name ? std::string(", ") + name : "");
  } else {
    how = "exit status " + std::to_string(child.exit.number);
  }
  Add("", "checking this file (and the videos it names) crashed the reader (" + how +
              "): a file is corrupt beyond what HDF5 or FFmpeg report as an error");
  MarkIncomplete(p.parent_path());
}

}  // namespace mlspaces::datagen::dataset_check
