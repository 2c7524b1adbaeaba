// Crash points: deterministic fault injection for kill-and-resume tests.
//
// Code that makes work durable (a file renamed into place, a flag written, a download chunk
// on disk, an episode or journal line written) calls `CrashPoint("what")` right after the
// step. Normally that is one relaxed load and a branch. Two environment variables, meant for
// tests, turn it into a counter and a kill switch:
//
//   MLSPACES_CRASH_COUNTER=FILE   count steps in FILE (8 bytes, created when missing), shared
//                                 by every process and thread that opens it: a run's forked
//                                 workers and a CLI's threads add to one count. Without it
//                                 each process counts for itself.
//   MLSPACES_CRASH_AT=N           the process that completes step N (1-based) SIGKILLs itself
//                                 right after it, as a power cut or the OOM killer would,
//                                 after one line on stderr naming the step.
//
// A test first runs the work uninterrupted with a counter file to learn its number of steps
// T, then reruns it with N drawn from [1, T] by a seeded generator: the kill lands inside the
// work by construction, whatever the machine's load, and never by a clock.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <string_view>

namespace mlspaces {

/// Marks one durable step done; see the file comment. Thread- and fork-safe.
/// @throws Error when MLSPACES_CRASH_AT or MLSPACES_CRASH_COUNTER is malformed or the
///         counter file cannot be opened (checked once, at the first call).
MLSPACES_API void CrashPoint(std::string_view step);

/// Steps counted so far (the shared count when a counter file is used); for tests.
MLSPACES_API uint64_t CrashPointCount();

}  // namespace mlspaces
