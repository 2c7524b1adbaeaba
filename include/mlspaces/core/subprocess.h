// Running a function in a forked child: the child writes its result to a pipe, the parent
// reads it (whole, or line by line from several children at once) and learns how the child
// ended (exit status or signal). Used to isolate crash-prone readers and to run workers.
#pragma once

#include "mlspaces/core/export.h"

#include <sys/types.h>

#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace mlspaces {

/// How a child process ended.
struct MLSPACES_API ChildExit {
  bool signaled = false;  ///< killed by a signal (else it exited)
  int number = 0;         ///< the signal number, or the exit status
  bool ok() const { return !signaled && number == 0; }
};

/// A forked child process with a pipe from it. Move-only; a child never waited for is killed
/// (SIGKILL) and reaped by the destructor.
class MLSPACES_API Child {
 public:
  /// The exit status of a child whose body threw.
  static constexpr int kBodyThrew = 4;

  // ===========================================================================================
  // Construction

  /// Forks (after flushing stdio). The child runs body(write_fd), closes the pipe and leaves
  /// with _exit(status) (no atexit handlers, no stdio flush); the status is body's result,
  /// or kBodyThrew when it throws. Both pipe ends are close-on-exec.
  /// @throws Error when the pipe or the fork fails.
  static Child Start(const std::function<int(int write_fd)>& body);

  Child(Child&& other) noexcept;
  Child& operator=(Child&& other) noexcept;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child();

  // ===========================================================================================
  // The child and its pipe

  pid_t pid() const { return pid_; }
  /// The read end of the pipe, owned by this Child (do not close it); -1 once it was closed
  /// (end of the child's output).
  int fd() const { return fd_; }

  /// Reads the rest of the child's output (until the pipe closes).
  std::string ReadAll();
  /// Sends SIGKILL if the child was not waited for yet.
  void Kill();
  /// Closes the pipe and waits for the child (retrying on EINTR).
  ChildExit Wait();

 private:
  Child(pid_t pid, int fd) : pid_(pid), fd_(fd) {}
  void CloseFd();
  friend void ReadChildLines(std::vector<Child>& children,
                             const std::function<void(size_t, std::string_view)>& on_line);

  pid_t pid_ = -1;
  int fd_ = -1;
  bool waited_ = false;
  std::string buffer_;  // a partial line (ReadChildLines)
};

/// Runs body in a child and returns its output and how it ended. @throws Error as Start.
struct MLSPACES_API ChildResult {
  std::string output;
  ChildExit exit;
};
MLSPACES_API ChildResult RunInChild(const std::function<int(int write_fd)>& body);

/// Reads the outputs of `children` as they come until every pipe is closed, calling
/// on_line(i, line) for each complete '\n'-terminated line of child i (without the '\n'); a
/// partial last line is dropped. When on_line or a read throws, every child is killed and
/// waited for, and the exception propagates.
MLSPACES_API void ReadChildLines(std::vector<Child>& children,
                                 const std::function<void(size_t, std::string_view)>& on_line);

}  // namespace mlspaces
