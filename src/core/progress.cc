#include "mlspaces/core/progress.h"

#include <unistd.h>

#include <cstdio>

namespace mlspaces {

double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ProgressBar::ProgressBar(std::string label, size_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled && isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(size_t done, std::string note) {
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mu_);
  done_ = done;
  note_ = std::move(note);
  auto now = std::chrono::steady_clock::now();
  if (finished_ || (now - last_draw_ < std::chrono::milliseconds(100) && done < total_)) return;
  last_draw_ = now;
  Draw(done);
}

void ProgressBar::Finish() {
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (finished_) return;
  finished_ = true;
  Draw(done_);
  std::fputc('\n', stderr);
}

void ProgressBar::Draw(size_t done) {
  constexpr int kWidth = 30;
  double frac = total_ ? static_cast<double>(done) / total_ : 1.0;
  int fill = static_cast<int>(frac * kWidth);
  std::string bar(fill, '#');
  bar.resize(kWidth, '.');
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  double rate = secs > 0 ? done / secs : 0;
  // "\x1b[K" clears what a longer previous draw left behind.
  if (note_.empty()) {
    std::fprintf(stderr, "\r%s [%s] %zu/%zu (%.0f/s)\x1b[K", label_.c_str(), bar.c_str(), done,
                 total_, rate);
  } else {
    std::fprintf(stderr, "\r%s [%s] %zu/%zu %s\x1b[K", label_.c_str(), bar.c_str(), done, total_,
                 note_.c_str());
  }
  std::fflush(stderr);
}

}  // namespace mlspaces
