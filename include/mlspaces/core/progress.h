// A small thread-safe progress bar on stderr, drawn only when stderr is a terminal.
#pragma once

#include "mlspaces/core/export.h"

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace mlspaces {

/// Seconds on the steady clock since `t0`.
MLSPACES_API double Since(std::chrono::steady_clock::time_point t0);

class MLSPACES_API ProgressBar {
 public:
  /// `label` is printed before the bar; nothing is drawn when stderr is not a TTY
  /// (or when `enabled` is false).
  ProgressBar(std::string label, size_t total, bool enabled = true);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Sets the number of finished items; redraws at most ~10 times a second. A non-empty
  /// `note` (e.g. "success 96%, 4,100/h, ETA 2m") replaces the default "(N/s)" rate.
  void Update(size_t done, std::string note = {});
  /// Draws the final state and ends the line (idempotent).
  void Finish();

 private:
  void Draw(size_t done);
  size_t done_ = 0;
  std::string note_;

  std::string label_;
  size_t total_;
  bool enabled_;
  bool finished_ = false;
  std::mutex mu_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace mlspaces
