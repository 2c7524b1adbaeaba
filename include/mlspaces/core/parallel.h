// ParallelFor: the one thread pool. Items [0, n) are handed out in increasing index order to
// a few threads; the first failure stops new items from starting and, once the running ones
// have finished, the exception of the lowest failed index is rethrown (deterministic for a
// deterministic body). Callers that want per-item errors catch them in the body.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <functional>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

namespace mlspaces {

/// The number of threads to use for `items` items: `requested` (<= 0: the hardware's
/// concurrency), at most `items`, at least 1.
MLSPACES_API int ParallelThreads(int requested, size_t items);

/// Runs body(i) for every i in [0, n) on ParallelThreads(threads, n) threads, the calling
/// thread among them. @throws the lowest-index exception of body, after every thread stopped.
MLSPACES_API void ParallelFor(size_t n, int threads, const std::function<void(size_t)>& body);

namespace parallel_internal {
/// produce(i) on worker threads, consume(i) on the calling thread in index order, each once
/// produce(i) returned; workers stay at most `window` items ahead of consume. consume
/// returning false ends the run (no later item is consumed; workers stop after their item).
MLSPACES_API void RunOrdered(size_t n, int threads, size_t window,
                             const std::function<void(size_t)>& produce,
                             const std::function<bool(size_t)>& consume);
}  // namespace parallel_internal

/// Runs produce(i) -> T for every i in [0, n) on ParallelThreads(threads, n) worker threads
/// and consume(i, T&&) on the calling thread in index order (so what consume builds does not
/// depend on scheduling); workers stay at most `window` items ahead of consume, bounding the
/// results held. A consume that returns bool ends the run early by returning false: no later
/// item is consumed, and at most `window` items past it were produced for nothing. Errors: as
/// ParallelFor, for produce (items after the lowest failed one are not consumed) and consume
/// (the workers stop and its exception propagates).
template <class T, class Produce, class Consume>
void ParallelForOrdered(size_t n, int threads, size_t window, Produce&& produce,
                        Consume&& consume) {
  std::vector<std::optional<T>> results(n);
  parallel_internal::RunOrdered(
      n, threads, window, [&](size_t i) { results[i].emplace(produce(i)); },
      [&](size_t i) {
        T r = std::move(*results[i]);
        results[i].reset();
        if constexpr (std::is_same_v<decltype(consume(i, std::move(r))), bool>) {
          return consume(i, std::move(r));
        } else {
          consume(i, std::move(r));
          return true;
        }
      });
}

}  // namespace mlspaces
