// ParallelFor and its ordered variant: one pool of std::threads over an index range.
#include "mlspaces/core/parallel.h"

#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>

namespace mlspaces {

int ParallelThreads(int requested, size_t items) {
  const size_t want = requested > 0 ? static_cast<size_t>(requested)
                                    : std::max(1u, std::thread::hardware_concurrency());
  return static_cast<int>(std::max<size_t>(1, std::min(want, items)));
}

namespace {

/// The shared state of one run: the next index, the errors by index and the stop flag.
class Pool {
 public:
  // NOLINTNEXTLINE(bugprone-throw-keyword-missing): a vector of n null exception_ptrs
  explicit Pool(size_t n) : n_(n), errors_(n) {}

  /// Runs items until none is left or a failure stopped the run. `may_start(i)` (under the
  /// lock) may hold a worker back; `done(i)` (under the lock) is called after each success.
  template <class MayStart, class Done>
  void Work(const std::function<void(size_t)>& body, MayStart&& may_start, Done&& done) {
    for (;;) {
      size_t i;
      {
        std::unique_lock<std::mutex> lock(mu_);
        cv_.wait(lock, [&] { return stopped_ || next_ >= n_ || may_start(next_); });
        if (stopped_ || next_ >= n_) return;
        i = next_++;
      }
      std::exception_ptr error;
      try {
        body(i);
      } catch (...) {
        error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(mu_);
      if (error) {
        errors_[i] = error;
        stopped_ = true;
      } else {
        done(i);
      }
      cv_.notify_all();
    }
  }

  void Stop() {
    std::lock_guard<std::mutex> lock(mu_);
    stopped_ = true;
    cv_.notify_all();
  }

  /// The exception of the lowest failed index below `end`, or null. Call after every thread
  /// stopped.
  std::exception_ptr FirstError(size_t end = SIZE_MAX) const {
    for (size_t i = 0; i < errors_.size() && i < end; ++i) {
      if (errors_[i]) return errors_[i];
    }
    return nullptr;
  }

  std::mutex mu_;
  std::condition_variable cv_;
  const size_t n_;
  size_t next_ = 0;
  bool stopped_ = false;
  std::vector<std::exception_ptr> errors_;
};

/// Joins the threads on every way out.
struct Joiner {
  std::vector<std::thread> threads;
  ~Joiner() {
    for (std::thread& t : threads) {
      if (t.joinable()) t.join();
    }
  }
};

}  // namespace

void ParallelFor(size_t n, int threads, const std::function<void(size_t)>& body) {
  if (n == 0) return;
  Pool pool(n);
  auto work = [&] {
    pool.Work(
        body, [](size_t) { return true; }, [](size_t) {});
  };
  {
    Joiner joiner;
    const int count = ParallelThreads(threads, n);
    for (int t = 1; t < count; ++t) joiner.threads.emplace_back(work);
    work();
  }
  if (std::exception_ptr e = pool.FirstError()) std::rethrow_exception(e);
}

namespace parallel_internal {

void RunOrdered(size_t n, int threads, size_t window, const std::function<void(size_t)>& produce,
                const std::function<bool(size_t)>& consume) {
  if (n == 0) return;
  Pool pool(n);
  std::vector<char> produced(n, 0);
  size_t consumed = 0;  // items handed to consume; guarded by pool.mu_
  window = std::max<size_t>(window, 1);
  auto work = [&] {
    pool.Work(
        produce, [&](size_t i) { return i < consumed + window; },
        [&](size_t i) { produced[i] = 1; });
  };
  std::exception_ptr consume_error;
  size_t end = n;  // consume ended the run before this item: later failures do not count
  {
    Joiner joiner;
    const int count = ParallelThreads(threads, n);
    for (int t = 0; t < count; ++t) joiner.threads.emplace_back(work);
    for (size_t i = 0; i < n; ++i) {
      {
        std::unique_lock<std::mutex> lock(pool.mu_);
        // After a failure, an item that a worker already took still finishes (produced or
        // failed): wait for it, so every item before the lowest failed one is consumed. Stop
        // at the first item that failed or that no worker will take.
        pool.cv_.wait(lock, [&] {
          return produced[i] || pool.errors_[i] || (pool.stopped_ && i >= pool.next_);
        });
        if (!produced[i]) break;
        consumed = i + 1;
        pool.cv_.notify_all();
      }
      try {
        if (!consume(i)) {  // done early: pool.Stop() below ends the workers
          end = i + 1;
          break;
        }
      } catch (...) {
        consume_error = std::current_exception();
        pool.Stop();
        break;
      }
    }
    pool.Stop();  // wakes workers held back by the window
  }
  if (consume_error) std::rethrow_exception(consume_error);
  if (std::exception_ptr e = pool.FirstError(end)) std::rethrow_exception(e);
}

}  // namespace parallel_internal
}  // namespace mlspaces
