#include "mlspaces/datagen/journal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;

constexpr std::array<std::string_view, kOutcomeCount> kOutcomeNames = {
    "sampler_reject", "no_grasp", "ik_fail", "collision", "grasp_slip", "timeout", "success"};

void CheckTiming(const std::string& stage, double seconds, const std::string& path,
                 const std::string& field) {
  if (!std::isfinite(seconds) || seconds < 0) {
    throw Error("timing of stage \"" + stage + "\" must be a finite number >= 0, got " +
                    std::to_string(seconds),
                path, field);
  }
}

// Throws the error for key `key` of a line.
[[noreturn]] void Bad(const std::string& path, const std::string& field, std::string_view key,
                      const std::string& message) {
  throw Error("/" + JsonPointerToken(key) + ": " + message, path, field);
}

const Json& Need(const Json& json, std::string_view key, const std::string& path,
                 const std::string& field) {
  const auto it = json.find(key);
  if (it == json.end()) Bad(path, field, key, "missing");
  return *it;
}

// Fsyncs a folder so a file just created in it survives a crash.
void SyncDir(const fs::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Offset just past the last '\n' of the file (0 when there is none).
off_t EndOfLastLine(int fd, off_t size, const std::string& path) {
  char buf[4096];
  off_t end = size;
  while (end > 0) {
    const off_t start = std::max<off_t>(0, end - static_cast<off_t>(sizeof buf));
    const size_t n = static_cast<size_t>(end - start);
    if (::pread(fd, buf, n, start) != static_cast<ssize_t>(n)) {
      throw Error(Errno("cannot read journal"), path);
    }
    for (size_t i = n; i > 0; --i) {
      if (buf[i - 1] == '\n') return start + static_cast<off_t>(i);
    }
    end = start;
  }
  return 0;
}

}  // namespace

std::string_view OutcomeName(Outcome outcome) {
  return kOutcomeNames.at(static_cast<size_t>(outcome));
}

std::optional<Outcome> OutcomeFromName(std::string_view name) {
  for (Outcome o : kAllOutcomes) {
    if (OutcomeName(o) == name) return o;
  }
  return std::nullopt;
}

void AttemptRecord::AddTiming(std::string_view stage, double seconds) {
  for (auto& [name, value] : timings) {
    if (name == stage) {
      value += seconds;
      return;
    }
  }
  timings.emplace_back(std::string(stage), seconds);
}

double AttemptRecord::Timing(std::string_view stage) const {
  for (const auto& [name, value] : timings) {
    if (name == stage) return value;
  }
  return 0;
}

Json AttemptRecord::ToJson() const {
  Json j = Json::object();
  j["scene"] = scene;
  j["episode"] = episode;
  j["attempt"] = attempt;
  j["seed"] = seed;
  j["outcome"] = std::string(OutcomeName(outcome));
  j["message"] = message;
  Json t = Json::object();
  for (const auto& [name, value] : timings) t[name] = value;
  j["timings"] = std::move(t);
  if (!extra.is_null() && !extra.empty()) j["extra"] = extra;
  return j;
}

AttemptRecord AttemptRecord::FromJson(const Json& json, const std::string& path,
                                      const std::string& field) {
  if (!json.is_object()) {
    throw Error("expected a JSON object, got " + JsonTypeWord(json), path, field);
  }
  static const std::set<std::string, std::less<>> kKeys = {
      "scene", "episode", "attempt", "seed", "outcome", "message", "timings", "extra"};
  for (const auto& [key, value] : json.items()) {
    if (!kKeys.contains(key)) Bad(path, field, key, "unknown key");
  }
  AttemptRecord r;
  auto string_of = [&](std::string_view key) {
    const Json& v = Need(json, key, path, field);
    if (!v.is_string()) Bad(path, field, key, "expected string, got " + JsonTypeWord(v));
    return v.get<std::string>();
  };
  auto int_of = [&](std::string_view key, int64_t max) {
    const Json& v = Need(json, key, path, field);
    if (!v.is_number_integer() || (v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(max)) ||
        v.get<int64_t>() < 0 || v.get<int64_t>() > max) {
      Bad(path, field, key,
          "expected an integer in 0.." + std::to_string(max) + ", got " + v.dump());
    }
    return v.get<int64_t>();
  };
  r.scene = string_of("scene");
  r.episode = int_of("episode", INT64_MAX);
  r.attempt = static_cast<int>(int_of("attempt", INT32_MAX));
  const Json& seed = Need(json, "seed", path, field);
  if (!seed.is_number_unsigned() && !(seed.is_number_integer() && seed.get<int64_t>() >= 0)) {
    Bad(path, field, "seed", "expected an unsigned integer, got " + seed.dump());
  }
  r.seed = seed.get<uint64_t>();
  const std::string outcome = string_of("outcome");
  const std::optional<Outcome> o = OutcomeFromName(outcome);
  if (!o) Bad(path, field, "outcome", "unknown outcome \"" + outcome + "\"");
  r.outcome = *o;
  r.message = string_of("message");
  const Json& timings = Need(json, "timings", path, field);
  if (!timings.is_object()) {
    Bad(path, field, "timings", "expected object, got " + JsonTypeWord(timings));
  }
  for (const auto& [stage, value] : timings.items()) {
    if (!value.is_number()) {
      throw Error(
          "/timings/" + JsonPointerToken(stage) + ": expected number, got " + JsonTypeWord(value),
          path, field);
    }
    CheckTiming(stage, value.get<double>(), path, field);
    r.timings.emplace_back(stage, value.get<double>());
  }
  if (const auto it = json.find("extra"); it != json.end()) {
    if (!it->is_object()) Bad(path, field, "extra", "expected object, got " + JsonTypeWord(*it));
    r.extra = *it;
  }
  return r;
}

Journal::Journal(const fs::path& path) : path_(path) {
  std::error_code ec;
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path(), ec);
  const bool existed = fs::exists(path, ec);
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(Errno("cannot open journal"), path.string());
  try {
    struct stat st {};
    if (::fstat(fd_, &st) != 0) throw Error(Errno("cannot stat journal"), path.string());
    if (st.st_size > 0) {
      const off_t keep = EndOfLastLine(fd_, st.st_size, path.string());
      if (keep != st.st_size) {
        if (::ftruncate(fd_, keep) != 0 || ::fsync(fd_) != 0) {
          throw Error(Errno("cannot cut the partial last line"), path.string());
        }
        truncated_bytes_ = static_cast<size_t>(st.st_size - keep);
      }
    }
    if (!existed) SyncDir(path.parent_path());
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
}

Journal::Journal(Journal&& other) noexcept
    : path_(std::move(other.path_)),
      fd_(std::exchange(other.fd_, -1)),
      truncated_bytes_(other.truncated_bytes_) {}

Journal& Journal::operator=(Journal&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = std::exchange(other.fd_, -1);
    truncated_bytes_ = other.truncated_bytes_;
  }
  return *this;
}

void Journal::Append(const AttemptRecord& record) {
  if (fd_ < 0) throw UsageError("Journal::Append on a moved-from journal");
  std::set<std::string_view> seen;
  for (const auto& [stage, seconds] : record.timings) {
    if (!seen.insert(stage).second) {
      throw Error("stage \"" + stage + "\" timed twice (use AddTiming)", path_.string());
    }
    CheckTiming(stage, seconds, path_.string(), {});
  }
  if (!record.extra.is_null() && !record.extra.is_object()) {
    throw Error("extra must be a JSON object, got " + JsonTypeWord(record.extra), path_.string());
  }
  // dump() escapes nothing that could be a newline: control characters become \uXXXX.
  const std::string line = record.ToJson().dump() + "\n";
  const ssize_t n = ::write(fd_, line.data(), line.size());
  if (n != static_cast<ssize_t>(line.size())) {
    const std::string why = n < 0 ? Errno("cannot append to journal")
                                  : "short write to journal (" + std::to_string(n) + " of " +
                                        std::to_string(line.size()) + " bytes)";
    throw Error(why, path_.string());
  }
  if (::fsync(fd_) != 0) throw Error(Errno("cannot fsync journal"), path_.string());
  CrashPoint("journal line written");
}

JournalContents ReadJournal(const fs::path& path) {
  const std::string text = ReadFile(path);
  JournalContents out;
  size_t pos = 0;
  int64_t line_no = 0;
  while (pos < text.size()) {
    ++line_no;
    const size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) {  // a partial last line: the write in flight at a crash
      out.truncated_tail = true;
      break;
    }
    const std::string_view line(text.data() + pos, nl - pos);
    pos = nl + 1;
    const std::string field = "line " + std::to_string(line_no);
    Json json;
    try {
      json = Json::parse(line);
    } catch (const Json::parse_error& e) {
      std::string what = e.what();
      if (const size_t colon = what.find(": "); colon != std::string::npos) {
        what = what.substr(colon + 2);
      }
      throw Error("bad JSON: " + what, path.string(), field);
    }
    out.records.push_back(AttemptRecord::FromJson(json, path.string(), field));
  }
  return out;
}

double JournalSummary::success_rate() const {
  return attempts == 0 ? 0.0 : static_cast<double>(count(Outcome::kSuccess)) / attempts;
}

JournalSummary Summarize(const std::vector<AttemptRecord>& records) {
  JournalSummary s;
  std::map<std::pair<std::string, int64_t>, bool> episodes;
  for (const AttemptRecord& r : records) {
    ++s.attempts;
    ++s.counts[static_cast<int>(r.outcome)];
    bool& ok = episodes[{r.scene, r.episode}];
    ok = ok || r.outcome == Outcome::kSuccess;
    for (const auto& timing : r.timings) {
      const std::string& name = timing.first;  // not a structured binding: the lambda uses it
      const double seconds = timing.second;
      auto it = std::find_if(s.stages.begin(), s.stages.end(),
                             [&](const JournalSummary::Stage& st) { return st.name == name; });
      if (it == s.stages.end()) {
        s.stages.push_back({name, 0, 0, 0});
        it = s.stages.end() - 1;
      }
      ++it->runs;
      it->total_seconds += seconds;
    }
  }
  for (JournalSummary::Stage& st : s.stages) st.mean_seconds = st.total_seconds / st.runs;
  s.episodes = static_cast<int64_t>(episodes.size());
  for (const auto& [key, ok] : episodes) s.successful_episodes += ok ? 1 : 0;
  return s;
}

std::string FormatSummary(const JournalSummary& s) {
  std::string out;
  char buf[256];
  auto pct = [](int64_t a, int64_t b) { return b == 0 ? 0.0 : 100.0 * a / b; };
  std::snprintf(buf, sizeof buf, "%-16s %8s %7s\n", "outcome", "count", "share");
  out += buf;
  for (Outcome o : kAllOutcomes) {
    std::snprintf(buf, sizeof buf, "%-16s %8lld %6.1f%%\n", std::string(OutcomeName(o)).c_str(),
                  static_cast<long long>(s.count(o)), pct(s.count(o), s.attempts));
    out += buf;
  }
  std::snprintf(buf, sizeof buf, "%-16s %8lld\n", "total", static_cast<long long>(s.attempts));
  out += buf;
  std::snprintf(buf, sizeof buf,
                "success rate: %.1f%% of attempts (%lld/%lld), %.1f%% of episodes (%lld/%lld)\n",
                100.0 * s.success_rate(), static_cast<long long>(s.count(Outcome::kSuccess)),
                static_cast<long long>(s.attempts), pct(s.successful_episodes, s.episodes),
                static_cast<long long>(s.successful_episodes), static_cast<long long>(s.episodes));
  out += buf;
  if (!s.stages.empty()) {
    std::snprintf(buf, sizeof buf, "%-24s %12s %8s %12s\n", "stage", "mean s", "runs", "total s");
    out += buf;
    for (const JournalSummary::Stage& st : s.stages) {
      std::snprintf(buf, sizeof buf, "%-24s %12.6f %8lld %12.3f\n", st.name.c_str(),
                    st.mean_seconds, static_cast<long long>(st.runs), st.total_seconds);
      out += buf;
    }
  }
  return out;
}

}  // namespace mlspaces::datagen
