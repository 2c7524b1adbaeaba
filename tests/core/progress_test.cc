// Since (src/core/progress.cc): seconds on the steady clock.
#include "mlspaces/core/progress.h"

#include <chrono>

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

}  // namespace
}  // namespace mlspaces
