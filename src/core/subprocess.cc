// Forked children with a pipe back: Start, ReadAll, ReadChildLines (poll), Wait.
#include "mlspaces/core/subprocess.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

#include "mlspaces/core/error.h"

namespace mlspaces {

Child Child::Start(const std::function<int(int write_fd)>& body) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    throw Error(std::string("cannot create a pipe: ") + std::strerror(errno));
  }
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(std::string("cannot start a child process: ") + std::strerror(err));
  }
  if (pid == 0) {
    ::close(fds[0]);
    int status = kBodyThrew;
    try {
      status = body(fds[1]);
    } catch (...) {
      status = kBodyThrew;
    }
    ::close(fds[1]);
    ::_exit(status);
  }
  ::close(fds[1]);
  return Child(pid, fds[0]);
}

Child::Child(Child&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)),
      fd_(std::exchange(other.fd_, -1)),
      waited_(std::exchange(other.waited_, false)),
      buffer_(std::move(other.buffer_)) {}

Child& Child::operator=(Child&& other) noexcept {
  if (this != &other) {
    if (pid_ > 0 && !waited_) {
      Kill();
      Wait();
    }
    CloseFd();
    pid_ = std::exchange(other.pid_, -1);
    fd_ = std::exchange(other.fd_, -1);
    waited_ = std::exchange(other.waited_, false);
    buffer_ = std::move(other.buffer_);
  }
  return *this;
}

Child::~Child() {
  if (pid_ > 0 && !waited_) {
    Kill();
    Wait();
  }
  CloseFd();
}

void Child::CloseFd() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

std::string Child::ReadAll() {
  std::string data;
  char buf[65536];
  while (fd_ >= 0) {
    const ssize_t r = ::read(fd_, buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    data.append(buf, static_cast<size_t>(r));
  }
  CloseFd();
  return data;
}

void Child::Kill() {
  if (pid_ > 0 && !waited_) ::kill(pid_, SIGKILL);
}

ChildExit Child::Wait() {
  CloseFd();
  ChildExit exit;
  if (pid_ <= 0 || waited_) return exit;
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {}
  waited_ = true;
  if (WIFSIGNALED(status)) {
    exit.signaled = true;
    exit.number = WTERMSIG(status);
  } else {
    exit.number = WEXITSTATUS(status);
  }
  return exit;
}

ChildResult RunInChild(const std::function<int(int write_fd)>& body) {
  Child child = Child::Start(body);
  ChildResult result;
  result.output = child.ReadAll();
  result.exit = child.Wait();
  return result;
}

void ReadChildLines(std::vector<Child>& children,
                    const std::function<void(size_t, std::string_view)>& on_line) {
  try {
    for (;;) {
      std::vector<pollfd> fds;
      std::vector<size_t> which;
      for (size_t i = 0; i < children.size(); ++i) {
        if (children[i].fd_ >= 0) {
          fds.push_back({children[i].fd_, POLLIN, 0});
          which.push_back(i);
        }
      }
      if (fds.empty()) return;
      if (::poll(fds.data(), fds.size(), -1) < 0) {
        if (errno == EINTR) continue;
        throw Error(std::string("poll failed: ") + std::strerror(errno));
      }
      for (size_t j = 0; j < fds.size(); ++j) {
        if (fds[j].revents == 0) continue;
        Child& c = children[which[j]];
        char chunk[65536];
        const ssize_t n = ::read(c.fd_, chunk, sizeof chunk);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
          c.CloseFd();
          continue;
        }
        c.buffer_.append(chunk, static_cast<size_t>(n));
        for (size_t nl; (nl = c.buffer_.find('\n')) != std::string::npos;) {
          const std::string line = c.buffer_.substr(0, nl);
          c.buffer_.erase(0, nl + 1);
          on_line(which[j], line);
        }
      }
    }
  } catch (...) {
    for (Child& c : children) c.Kill();
    for (Child& c : children) c.Wait();
    throw;
  }
}

}  // namespace mlspaces
