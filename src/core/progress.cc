#include "mlspaces/core/progress.h"

#include <unistd.h>

#include <cstdio>
#include <exception>

#include "mlspaces/core/strings.h"

namespace mlspaces {

double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

namespace {

ProgressStyle Enabled(bool enabled) {
  ProgressStyle style;
  style.enabled = enabled;
  return style;
}

}  // namespace

ProgressBar::ProgressBar(const std::string& label, size_t total, bool enabled)
    : ProgressBar(label, total, Enabled(enabled)) {}

ProgressBar::ProgressBar(const std::string& label, size_t total, ProgressStyle style)
    : label_(Printable(label)),
      total_(total),
      style_(std::move(style)),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {
  if (style_.stream == nullptr) style_.stream = stderr;
  const bool tty = style_.tty >= 0 ? style_.tty == 1 : isatty(fileno(style_.stream)) == 1;
  bar_ = style_.enabled && tty;
  lines_ = style_.enabled && !tty && style_.lines_when_not_tty;
}

ProgressBar::~ProgressBar() {
  // Lines: an error on its way out says what went wrong; no final count before it.
  if (lines_ && std::uncaught_exceptions() > exceptions_) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      finished_ = true;
    }
    wake_.notify_all();
  } else {
    Finish();
  }
  if (start_line_.joinable()) start_line_.join();
}

void ProgressBar::Start(size_t done, const std::string& note) {
  if (bar_) {
    Update(done, note);
    return;
  }
  if (!lines_) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (start_line_.joinable() || any_line_ || finished_) return;
  done_ = done;
  note_ = Printable(note);
  start_line_ = std::thread([this] {
    std::unique_lock<std::mutex> lock(mu_);
    const auto wait = std::chrono::duration<double>(style_.start_line_after_s);
    if (!wake_.wait_for(lock, wait, [this] { return finished_ || any_line_; })) Line(done_);
  });
}

void ProgressBar::Update(size_t done, const std::string& note) {
  if (!bar_ && !lines_) return;
  std::lock_guard<std::mutex> lock(mu_);
  done_ = done;
  note_ = Printable(note);
  if (finished_) return;
  const auto now = std::chrono::steady_clock::now();
  if (lines_) {
    // A new count or note (attempts, rates), at most once per interval.
    const bool due = !any_line_ || ((done != line_done_ || note_ != line_note_) &&
                                    std::chrono::duration<double>(now - last_draw_).count() >=
                                        style_.line_interval_s);
    if (!due) return;
    last_draw_ = now;
    Line(done);
    return;
  }
  if (now - last_draw_ < std::chrono::milliseconds(100) && done < total_) return;
  last_draw_ = now;
  Draw(done);
}

void ProgressBar::Finish() {
  if (!bar_ && !lines_) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (finished_) return;
  finished_ = true;
  if (lines_) {
    if (!any_line_ || line_done_ != done_) Line(done_);
    wake_.notify_all();
    return;
  }
  Draw(done_);
  std::fputc('\n', style_.stream);
}

void ProgressBar::Line(size_t done) {
  std::string text = label_ + ":";
  if (!style_.unit.empty()) text += " " + style_.unit;
  text += " " + std::to_string(done) + "/" + std::to_string(total_);
  if (!note_.empty()) text += ", " + note_;
  std::fprintf(style_.stream, "%s\n", text.c_str());
  std::fflush(style_.stream);
  any_line_ = true;
  line_done_ = done;
  line_note_ = note_;
  wake_.notify_all();
}

void ProgressBar::Draw(size_t done) {
  constexpr int kWidth = 30;
  double frac = total_ ? static_cast<double>(done) / total_ : 1.0;
  int fill = static_cast<int>(frac * kWidth);
  std::string bar(fill, '#');
  bar.resize(kWidth, '.');
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  double rate = secs > 0 ? done / secs : 0;
  const std::string unit = style_.unit.empty() ? "" : " " + style_.unit;
  // "\x1b[K" clears what a longer previous draw left behind.
  if (note_.empty()) {
    std::fprintf(style_.stream, "\r%s [%s] %zu/%zu%s (%.0f/s)\x1b[K", label_.c_str(), bar.c_str(),
                 done, total_, unit.c_str(), rate);
  } else {
    std::fprintf(style_.stream, "\r%s [%s] %zu/%zu%s, %s\x1b[K", label_.c_str(), bar.c_str(), done,
                 total_, unit.c_str(), note_.c_str());
  }
  std::fflush(style_.stream);
}

}  // namespace mlspaces
