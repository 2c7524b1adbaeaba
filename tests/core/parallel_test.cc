// ParallelFor / ParallelForOrdered: every item runs once, the lowest failed index's error is
// rethrown after all threads stop, ordered consumption, the window bounds how far workers run.
#include "mlspaces/core/parallel.h"

#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace mlspaces {
namespace {

TEST(ParallelTest, ThreadCount) {
  EXPECT_EQ(ParallelThreads(4, 2), 2);
  EXPECT_EQ(ParallelThreads(4, 0), 1);
  EXPECT_EQ(ParallelThreads(3, 100), 3);
  EXPECT_GE(ParallelThreads(0, 100), 1);
}

TEST(ParallelTest, RunsEveryItemOnce) {
  for (int threads : {1, 3, 8}) {
    std::vector<std::atomic<int>> hits(1000);
    ParallelFor(hits.size(), threads, [&](size_t i) { hits[i]++; });
    for (size_t i = 0; i < hits.size(); ++i) EXPECT_EQ(hits[i].load(), 1) << i;
  }
  ParallelFor(0, 4, [](size_t) { FAIL(); });
}

TEST(ParallelTest, LowestFailedIndexWinsAndNewItemsStop) {
  for (int threads : {1, 4}) {
    std::atomic<size_t> ran{0};
    try {
      ParallelFor(10000, threads, [&](size_t i) {
        ran++;
        if (i == 7 || i == 9) throw std::runtime_error("item " + std::to_string(i));
      });
      FAIL() << "no exception";
    } catch (const std::runtime_error& e) {
      // Items start in index order, so 7 started before 9 and fails too.
      EXPECT_STREQ(e.what(), "item 7");
    }
    // One thread: nothing starts after the failure (the stop flag every worker checks before
    // it takes an item). With several, the others may finish every item while the failing
    // thread is descheduled (a 2-core machine running 4 threads): no count is certain there.
    if (threads == 1) {
      EXPECT_EQ(ran.load(), 8u);
    }
  }
}

TEST(ParallelTest, OrderedConsumeEndsTheRunEarly) {
  // consume returning false at item 50: nothing after it is consumed, and the workers, held
  // to `window` items ahead, produced at most 50 + window + 1 items.
  for (int threads : {1, 4}) {
    std::atomic<size_t> produced{0};
    std::vector<size_t> consumed;
    ParallelForOrdered<size_t>(
        100000, threads, 8,
        [&](size_t i) {
          ++produced;
          return i;
        },
        [&](size_t i, size_t&& v) {
          EXPECT_EQ(i, v);
          consumed.push_back(i);
          return i < 50;
        });
    ASSERT_EQ(consumed.size(), 51u);
    EXPECT_EQ(consumed.back(), 50u);
    EXPECT_LE(produced.load(), 59u);
  }
}

TEST(ParallelTest, OrderedConsumesInIndexOrder) {
  std::vector<size_t> order;
  std::vector<int> values;
  ParallelForOrdered<int>(
      200, 4, 8, [](size_t i) { return static_cast<int>(i * i); },
      [&](size_t i, int&& v) {
        order.push_back(i);
        values.push_back(v);
      });
  ASSERT_EQ(order.size(), 200u);
  for (size_t i = 0; i < order.size(); ++i) {
    EXPECT_EQ(order[i], i);
    EXPECT_EQ(values[i], static_cast<int>(i * i));
  }
}

TEST(ParallelTest, OrderedWindowBoundsWorkAhead) {
  std::atomic<size_t> consumed{0};
  std::atomic<size_t> max_ahead{0};
  ParallelForOrdered<size_t>(
      300, 4, 5,
      [&](size_t i) {
        const size_t ahead = i - std::min(i, consumed.load());
        size_t m = max_ahead.load();
        while (ahead > m && !max_ahead.compare_exchange_weak(m, ahead)) {}
        return i;
      },
      [&](size_t i, size_t&&) { consumed = i + 1; });
  // A worker may take item i only while i < consumed + window.
  EXPECT_LE(max_ahead.load(), 5u);  // consume(i) may still run while i + 5 starts
}

// Item 8 is still being produced when item 10 fails: it finishes and is consumed, as is 9;
// the run stops at 10. (Item 8 waits for 10's failure and then a while, so that a consumer
// that gave up on items in flight at the failure would stop at 8: CI once saw that.)
TEST(ParallelTest, OrderedConsumesItemsInFlightWhenALaterOneFails) {
  std::atomic<bool> ten_failed{false};
  std::vector<size_t> consumed;
  EXPECT_THROW(ParallelForOrdered<size_t>(
                   100, 3, 4,
                   [&](size_t i) -> size_t {
                     if (i == 8) {
                       while (!ten_failed) std::this_thread::yield();
                       std::this_thread::sleep_for(std::chrono::milliseconds(50));
                     }
                     if (i == 10) {
                       ten_failed = true;
                       throw std::runtime_error("produce 10");
                     }
                     return i;
                   },
                   [&](size_t i, size_t&&) { consumed.push_back(i); }),
               std::runtime_error);
  EXPECT_EQ(consumed, (std::vector<size_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
}

TEST(ParallelTest, OrderedStopsAtTheFirstFailure) {
  std::vector<size_t> consumed;
  try {
    ParallelForOrdered<size_t>(
        100, 3, 4,
        [](size_t i) -> size_t {
          if (i == 10) throw std::runtime_error("produce 10");
          return i;
        },
        [&](size_t i, size_t&&) { consumed.push_back(i); });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "produce 10");
  }
  ASSERT_EQ(consumed.size(), 10u);  // 0..9, nothing after the failed item
  EXPECT_EQ(consumed.back(), 9u);

  EXPECT_THROW(ParallelForOrdered<size_t>(
                   50, 3, 4, [](size_t i) { return i; },
                   [](size_t i, size_t&&) {
                     if (i == 3) throw std::logic_error("consume 3");
                   }),
               std::logic_error);
}

}  // namespace
}  // namespace mlspaces
