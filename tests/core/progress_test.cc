// Since and ProgressBar (src/core/progress.cc): seconds on the steady clock; the bar on a
// terminal, plain lines elsewhere.
#include "mlspaces/core/progress.h"

#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace mlspaces {
namespace {

TEST(ProgressTest, SinceCountsSecondsFromAPastTimePoint) {
  // A time point an hour back: the result is at least an hour, whatever this machine's speed.
  const auto t0 = std::chrono::steady_clock::now() - std::chrono::hours(1);
  const double s = Since(t0);
  EXPECT_GE(s, 3600.0);
  EXPECT_LT(s, 2 * 3600.0);
  // A time point ahead gives a negative count (no clamping).
  EXPECT_LT(Since(std::chrono::steady_clock::now() + std::chrono::hours(1)), 0.0);
}

// What `use` writes to a ProgressBar stream that is (tty = 1) or is not (tty = 0) a terminal.
template <typename F>
std::string Written(int tty, bool lines, double interval, F use) {
  std::FILE* f = std::tmpfile();
  EXPECT_NE(f, nullptr);
  {
    ProgressStyle style;
    style.lines_when_not_tty = lines;
    style.line_interval_s = interval;
    style.unit = "episodes";
    style.stream = f;
    style.tty = tty;
    ProgressBar bar("datagen", 3, style);
    use(bar);
  }
  std::string out(static_cast<size_t>(std::ftell(f)), '\0');
  std::rewind(f);
  EXPECT_EQ(std::fread(out.data(), 1, out.size(), f), out.size());
  std::fclose(f);
  return out;
}

TEST(ProgressTest, PlainLinesWhenNotATerminal) {
  // No interval: a line per change of the count (none for a repeated count), the final one
  // only once; the note's control characters escaped.
  EXPECT_EQ(Written(0, true, 0.0,
                    [](ProgressBar& bar) {
                      bar.Update(0);
                      bar.Update(1, "1 ok");
                      bar.Update(1, "1 ok");
                      bar.Update(3, "2 ok\x1b[2J");
                      bar.Finish();
                    }),
            "datagen: episodes 0/3\ndatagen: episodes 1/3, 1 ok\n"
            "datagen: episodes 3/3, 2 ok\\x1b[2J\n");
  // An interval no test outlives: the first line, then only the final state at Finish.
  EXPECT_EQ(Written(0, true, 1e9,
                    [](ProgressBar& bar) {
                      bar.Update(0);
                      bar.Update(1);
                      bar.Update(2, "2 ok");
                    }),
            "datagen: episodes 0/3\ndatagen: episodes 2/3, 2 ok\n");
  // Without lines_when_not_tty (the default), nothing.
  EXPECT_EQ(Written(0, false, 0.0, [](ProgressBar& bar) { bar.Update(2, "x"); }), "");
}

TEST(ProgressTest, StartLineWaitsForTheFirstUpdate) {
  // An Update before the wait is over: no start line.
  auto started = [](double after, bool update) {
    std::FILE* f = std::tmpfile();
    EXPECT_NE(f, nullptr);
    {
      ProgressStyle style;
      style.lines_when_not_tty = true;
      style.start_line_after_s = after;
      style.stream = f;
      style.tty = 0;
      ProgressBar bar("datagen", 3, style);
      bar.Start(0, "starting");
      if (update) bar.Update(1, "1 ok");
    }
    std::string out(static_cast<size_t>(std::ftell(f)), '\0');
    std::rewind(f);
    EXPECT_EQ(std::fread(out.data(), 1, out.size(), f), out.size());
    std::fclose(f);
    return out;
  };
  EXPECT_EQ(started(1e9, true), "datagen: 1/3, 1 ok\n");
  // No wait: the start line once (from the waiting thread or from Finish, whichever is first).
  EXPECT_EQ(started(0.0, false), "datagen: 0/3, starting\n");
}

TEST(ProgressTest, LinesAddNothingWhileAnErrorUnwinds) {
  // The error line alone says why the run stopped (the bar on a terminal still ends its line).
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  try {
    ProgressStyle style;
    style.lines_when_not_tty = true;
    style.stream = f;
    style.tty = 0;
    ProgressBar bar("datagen", 3, style);
    bar.Start(0, "starting");  // waits the default 5 s: the error comes first
    throw std::runtime_error("bad input");
  } catch (const std::runtime_error&) {}
  EXPECT_EQ(std::ftell(f), 0);
  std::fclose(f);
}

TEST(ProgressTest, BarOnATerminal) {
  // Start draws at once.
  EXPECT_EQ(Written(1, true, 0.0, [](ProgressBar& bar) { bar.Start(0, "starting"); }),
            "\rdatagen [" + std::string(30, '.') + "] 0/3 episodes, starting\x1b[K" +
                "\rdatagen [" + std::string(30, '.') + "] 0/3 episodes, starting\x1b[K\n");
  const std::string out = Written(1, true, 0.0, [](ProgressBar& bar) { bar.Update(3, "done"); });
  // Drawn in place (the final state again at Finish), then the line ends.
  const std::string draw = "\rdatagen [" + std::string(30, '#') + "] 3/3 episodes, done\x1b[K";
  EXPECT_EQ(out, draw + draw + "\n");
}

}  // namespace
}  // namespace mlspaces
