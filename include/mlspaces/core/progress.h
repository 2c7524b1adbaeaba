// A small thread-safe progress report on stderr: a bar redrawn in place on a terminal, and
// optionally plain lines ("datagen: episodes 3/10, ...") when stderr is not a terminal.
#pragma once

#include "mlspaces/core/export.h"

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdio>
#include <exception>
#include <mutex>
#include <string>
#include <thread>

namespace mlspaces {

/// Seconds on the steady clock since `t0`.
MLSPACES_API double Since(std::chrono::steady_clock::time_point t0);

/// How a ProgressBar shows itself; the defaults draw a bar on a terminal and nothing else.
struct ProgressStyle {
  bool enabled = true;
  /// When the stream is not a terminal: print "<label>: <unit> <done>/<total>, <note>" lines
  /// (one when the count or note changed and `line_interval_s` passed since the last, and the
  /// final count) instead of nothing. The first Update always prints.
  bool lines_when_not_tty = false;
  double line_interval_s = 1.0;
  /// Lines: how long Start's line waits for a first Update (a run that fails sooner shows only
  /// its error).
  double start_line_after_s = 5.0;
  /// Words after the counts in the bar and before them in lines ("episodes"); may be empty.
  std::string unit;
  std::FILE* stream = nullptr;  ///< nullptr: stderr
  /// -1: ask isatty(stream); 0 / 1: treat the stream as not a terminal / a terminal (tests).
  int tty = -1;
};

class MLSPACES_API ProgressBar {
 public:
  /// `label` is printed before the bar; nothing is drawn when stderr is not a TTY
  /// (or when `enabled` is false).
  ProgressBar(const std::string& label, size_t total, bool enabled = true);
  ProgressBar(const std::string& label, size_t total, ProgressStyle style);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Shows that work began, with `note` ("starting"): a bar draws at once; lines print it
  /// after `start_line_after_s` unless a line or Finish came first. Call once, before Update.
  void Start(size_t done, const std::string& note);
  /// Sets the number of finished items; redraws the bar at most ~10 times a second (lines:
  /// see ProgressStyle). A non-empty `note` (e.g. "success 96%, 4,100/h, ETA 2m") replaces the
  /// default "(N/s)" rate. Control characters in label and note are escaped (Printable).
  void Update(size_t done, const std::string& note = {});
  /// Draws the final state and ends the line (idempotent); lines: prints the final state
  /// unless the last line showed it. The destructor calls it, except for lines while an
  /// exception unwinds.
  void Finish();

 private:
  void Draw(size_t done);
  void Line(size_t done);
  size_t done_ = 0;
  std::string note_;

  std::string label_;
  size_t total_;
  ProgressStyle style_;
  bool bar_ = false;    // drawing a bar (a terminal)
  bool lines_ = false;  // printing lines (not a terminal)
  bool finished_ = false;
  bool any_line_ = false;
  int exceptions_ = std::uncaught_exceptions();  // at construction
  size_t line_done_ = 0;                         // `done` of the last line
  std::string line_note_;                        // and its note
  std::mutex mu_;
  std::condition_variable wake_;  // Finish, or a line: the start line is not needed
  std::thread start_line_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace mlspaces
