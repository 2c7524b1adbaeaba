// An inter-process lock on a file (flock): released by the kernel when its holder dies, so a
// crashed installer never leaves a lock behind that needs manual clean-up. As with any flock,
// a child forked while the lock is held inherits it: the lock is released when the last of
// them closes the descriptor (exec closes it: O_CLOEXEC).
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <functional>
#include <string>

namespace mlspaces {

class MLSPACES_API FileLock {
 public:
  /// Takes an exclusive lock on `path` (created if missing, with its folder), waiting for
  /// other holders. The holder's pid is written into the file for diagnostics. While waiting,
  /// `on_wait(holder_pid)` is called once (may be empty), e.g. to print "waiting for pid N".
  /// `timeout_s` < 0 waits forever. @throws Error naming the path on timeout or I/O failure.
  explicit FileLock(const std::filesystem::path& path,
                    const std::function<void(long holder_pid)>& on_wait = {},
                    double timeout_s = -1);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

  /// True when another live process holds the lock on `path` (probes without waiting).
  static bool IsHeld(const std::filesystem::path& path);

 private:
  int fd_ = -1;
  std::filesystem::path path_;
};

}  // namespace mlspaces
