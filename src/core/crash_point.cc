// CrashPoint (crash_point.h): a step counter in a shared file mapping and a self-SIGKILL.
#include "mlspaces/core/crash_point.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <string>

#include "mlspaces/core/error.h"

namespace mlspaces {
namespace {

constexpr const char* kAtVar = "MLSPACES_CRASH_AT";
constexpr const char* kCounterVar = "MLSPACES_CRASH_COUNTER";

struct CrashState {
  bool enabled = false;
  uint64_t at = 0;                          // 0: never
  std::atomic<uint64_t> local{0};           // the count without a counter file
  std::atomic<uint64_t>* shared = nullptr;  // in the counter file's mapping

  CrashState() {
    const char* at_text = std::getenv(kAtVar);
    const char* counter = std::getenv(kCounterVar);
    if (at_text != nullptr && *at_text != '\0') {
      const char* end = at_text + std::strlen(at_text);
      const auto [p, ec] = std::from_chars(at_text, end, at);
      if (ec != std::errc() || p != end || at == 0) {
        throw Error(std::string("expected a step number >= 1, got '") + at_text + "'", kAtVar);
      }
      enabled = true;
    }
    if (counter != nullptr && *counter != '\0') {
      const int fd = ::open(counter, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
      if (fd < 0) {
        throw Error(std::string("cannot open the crash counter: ") + std::strerror(errno), counter);
      }
      struct stat st {};
      // Every opener grows the file to 8 bytes; ftruncate to the same size is harmless when
      // two race, and the new bytes read as zero.
      if (::fstat(fd, &st) != 0 || (st.st_size < 8 && ::ftruncate(fd, 8) != 0)) {
        const int err = errno;
        ::close(fd);
        throw Error(std::string("cannot size the crash counter: ") + std::strerror(err), counter);
      }
      void* map = ::mmap(nullptr, 8, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
      const int err = errno;
      ::close(fd);  // the mapping stays
      if (map == MAP_FAILED) {
        throw Error(std::string("cannot map the crash counter: ") + std::strerror(err), counter);
      }
      static_assert(std::atomic<uint64_t>::is_always_lock_free);
      shared = static_cast<std::atomic<uint64_t>*>(map);
      enabled = true;
    }
  }
};

CrashState& State() {
  static CrashState state;
  return state;
}

}  // namespace

void CrashPoint(std::string_view step) {
  CrashState& s = State();
  if (!s.enabled) return;
  std::atomic<uint64_t>& count = s.shared != nullptr ? *s.shared : s.local;
  const uint64_t n = count.fetch_add(1, std::memory_order_acq_rel) + 1;
  if (n != s.at) return;
  // Async-signal-safe from here on: one write, then the kill. Nothing is flushed or unwound.
  std::string line = "mlspaces: crash point " + std::to_string(n) + " (";
  line.append(step);
  line += "): SIGKILL\n";
  [[maybe_unused]] const ssize_t w = ::write(STDERR_FILENO, line.data(), line.size());
  ::raise(SIGKILL);
  ::_exit(137);  // not reached
}

uint64_t CrashPointCount() {
  CrashState& s = State();
  return (s.shared != nullptr ? *s.shared : s.local).load(std::memory_order_acquire);
}

}  // namespace mlspaces
