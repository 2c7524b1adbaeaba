// The attempt journal: one JSON line per pick attempt, appended and fsynced as it ends, so a
// crash loses at most the line in flight; read back strictly and summarised at the end of a run.
//
// A line: {"scene": "...", "episode": 0, "attempt": 0, "seed": 42, "outcome": "success",
//          "message": "", "timings": {"plan": 0.12, "rollout": 1.5}, "extra": {...}}
// ("extra" only when not empty; stage timings keep their order.)
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mlspaces/core/json.h"

namespace mlspaces::datagen {

/// How one attempt ended. The names (OutcomeName) are stable: journals store them.
enum class Outcome {
  kSamplerReject,  // "sampler_reject": the task sampler could not place the task
  kNoGrasp,        // "no_grasp": no grasp candidate survived ranking and collision checks
  kIkFail,         // "ik_fail": no IK solution for the plan's waypoints
  kCollision,      // "collision": the robot hit the scene while executing
  kGraspSlip,      // "grasp_slip": the object was grasped but not held to the end
  kTimeout,        // "timeout": the horizon ran out
  kSuccess,        // "success": lifted and touching only the robot on the final state
};
inline constexpr int kOutcomeCount = 7;

/// Every outcome, in enum order.
inline constexpr std::array<Outcome, kOutcomeCount> kAllOutcomes = {
    Outcome::kSamplerReject, Outcome::kNoGrasp, Outcome::kIkFail, Outcome::kCollision,
    Outcome::kGraspSlip,     Outcome::kTimeout, Outcome::kSuccess};

/// The outcome's snake_case name ("sampler_reject", ..., "success"): a view of a static
/// string, never dangles.
MLSPACES_API std::string_view OutcomeName(Outcome outcome);
/// The outcome named `name`, or nullopt.
MLSPACES_API std::optional<Outcome> OutcomeFromName(std::string_view name);

/// One attempt.
// NOLINTNEXTLINE(bugprone-exception-escape): flags the implicit special members
struct MLSPACES_API AttemptRecord {
  std::string scene;
  int64_t episode = 0;  // episode index within the scene
  int attempt = 0;      // retry number within the episode, from 0
  uint64_t seed = 0;    // the episode's derived seed
  Outcome outcome = Outcome::kSuccess;
  std::string message;  // why it failed, for people; empty on success
  /// Seconds per stage, in the order the stages ran; names are unique.
  std::vector<std::pair<std::string, double>> timings;
  /// Anything else worth keeping (lift height, grasp index, ...); a JSON object or null.
  Json extra;

  /// Adds `seconds` to stage `stage` (appended when new, summed when already there).
  void AddTiming(std::string_view stage, double seconds);
  /// The time of `stage`, or 0 when it did not run.
  double Timing(std::string_view stage) const;

  /// The record as one JSON object (the line without its newline).
  Json ToJson() const;
  /// Parses a record. @throws Error with `path` and `field` ("line N") prefixed to the JSON
  /// pointer of the bad key.
  static AttemptRecord FromJson(const Json& json, const std::string& path,
                                const std::string& field);

  friend bool operator==(const AttemptRecord&, const AttemptRecord&) = default;
};

/// An append-only journal file. Not thread-safe: one Journal per file, one thread at a time.
class MLSPACES_API Journal {
 public:
  /// Opens (creating it and its folders) `path` for appending. A truncated last line left by
  /// a crash is cut off (truncated_bytes() says how much), so new lines start clean.
  /// @throws Error naming the file on failure.
  explicit Journal(const std::filesystem::path& path);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  Journal(Journal&& other) noexcept;
  Journal& operator=(Journal&& other) noexcept;

  /// Appends one line with one write() and fsyncs it. @throws Error for a bad record (negative
  /// or non-finite timing, extra not an object) or an I/O failure.
  void Append(const AttemptRecord& record);

  /// The journal file; valid while the Journal lives.
  const std::filesystem::path& path() const { return path_; }
  /// Bytes of a partial last line removed on open (0 when the file ended cleanly).
  size_t truncated_bytes() const { return truncated_bytes_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  size_t truncated_bytes_ = 0;
};

/// What ReadJournal found.
struct MLSPACES_API JournalContents {
  std::vector<AttemptRecord> records;
  /// True when the file ended in a partial line (a crash mid-write), which was ignored.
  bool truncated_tail = false;
};

/// Reads a journal. A last line without its newline is ignored (truncated_tail); any other bad
/// line throws. @throws Error with the file and "line N" for a bad line, or a missing file.
MLSPACES_API JournalContents ReadJournal(const std::filesystem::path& path);

/// Figures over a set of attempts.
struct MLSPACES_API JournalSummary {
  int64_t attempts = 0;
  std::array<int64_t, kOutcomeCount> counts{};  // indexed by static_cast<int>(Outcome)
  /// Distinct (scene, episode) pairs, and those with at least one successful attempt.
  int64_t episodes = 0;
  int64_t successful_episodes = 0;
  /// Per stage, in first-seen order: (name, mean seconds over the attempts that ran it, runs).
  struct Stage {
    std::string name;
    double mean_seconds = 0;
    int64_t runs = 0;
    double total_seconds = 0;
  };
  std::vector<Stage> stages;

  int64_t count(Outcome o) const { return counts[static_cast<int>(o)]; }
  /// Successful attempts / attempts (0 when there are none).
  double success_rate() const;
};

MLSPACES_API JournalSummary Summarize(const std::vector<AttemptRecord>& records);

/// A text table: one row per outcome (count and share), the success rates, one row per stage
/// (mean, runs, total). Ends with a newline.
MLSPACES_API std::string FormatSummary(const JournalSummary& summary);

}  // namespace mlspaces::datagen
