// flock(2)-based lock. The lock file is never deleted: unlinking it while another process
// waits on its descriptor would let a third process lock a fresh file of the same name, and
// two "holders" would run at once.
#include "mlspaces/core/file_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "mlspaces/core/error.h"

namespace mlspaces {
namespace {

/// The pid the holder wrote into the lock file; 0 when unreadable (it may be mid-write).
long ReadHolderPid(int fd) {
  char buf[32] = {};
  const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  if (n <= 0) return 0;
  return std::strtol(buf, nullptr, 10);
}

}  // namespace

FileLock::FileLock(const std::filesystem::path& path, const std::function<void(long)>& on_wait,
                   double timeout_s)
    : path_(path) {
  const std::string name = path.string();
  if (path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) throw Error("cannot create folder for lock: " + ec.message(), name);
  }
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(std::string("cannot open lock: ") + std::strerror(errno), name);

  auto fail = [&](const std::string& message) {
    ::close(fd_);
    fd_ = -1;
    throw Error(message, name);
  };
  int r;
  do r = ::flock(fd_, LOCK_EX | LOCK_NB);
  while (r != 0 && errno == EINTR);
  if (r != 0) {
    if (errno != EWOULDBLOCK) fail(std::string("cannot lock: ") + std::strerror(errno));
    // The holder writes its pid right after locking; give it a moment if we came in between.
    long holder = ReadHolderPid(fd_);
    for (int i = 0; holder == 0 && i < 5; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      holder = ReadHolderPid(fd_);
    }
    if (on_wait) on_wait(holder);
    if (timeout_s < 0) {
      do r = ::flock(fd_, LOCK_EX);
      while (r != 0 && errno == EINTR);
      if (r != 0) fail(std::string("cannot lock: ") + std::strerror(errno));
    } else {
      // flock has no timeout; poll with LOCK_NB. The holder's death releases the lock at
      // once, so a short interval keeps the hand-over quick.
      const auto deadline =
          std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
      for (;;) {
        if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) break;
        if (errno != EWOULDBLOCK && errno != EINTR) {
          fail(std::string("cannot lock: ") + std::strerror(errno));
        }
        if (std::chrono::steady_clock::now() >= deadline) {
          const long now_holder = ReadHolderPid(fd_);
          char seconds[32];
          std::snprintf(seconds, sizeof seconds, "%g", timeout_s);
          fail(std::string("timed out after ") + seconds + " s waiting for the lock held by pid " +
               std::to_string(now_holder != 0 ? now_holder : holder));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
  }
  // Ours now: record our pid for whoever waits next (diagnostics only).
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 ||
      ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    fail(std::string("cannot write pid into lock: ") + std::strerror(errno));
  }
}

FileLock::~FileLock() {
  if (fd_ < 0) return;
  // Clear the pid so nobody blames us afterwards; closing the descriptor releases the lock.
  [[maybe_unused]] const int r = ::ftruncate(fd_, 0);
  ::close(fd_);
}

bool FileLock::IsHeld(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;  // no lock file: nobody ever locked it
  // A shared lock conflicts exactly with an exclusive holder; release it straight away.
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return held;
}

}  // namespace mlspaces
