#include "mlspaces/core/files.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"

namespace mlspaces {
namespace fs = std::filesystem;

std::string ReadFileAt(int dir_fd, const char* path, const fs::path& path_for_errors) {
  int fd = ::openat(dir_fd, path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    throw Error(
        errno == ENOENT ? "file not found" : std::string("cannot open: ") + std::strerror(errno),
        path_for_errors.string());
  }
  std::string out;
  char buf[16 * 1024];
  bool sized = false;
  for (;;) {
    ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw Error(err == EISDIR ? "is a directory, expected a file"
                                : std::string("read failed: ") + std::strerror(err),
                  path_for_errors.string());
    }
    if (n == 0) break;
    out.append(buf, static_cast<size_t>(n));
    // A short first read of a regular file is the whole file: no stat for small files.
    if (!sized && static_cast<size_t>(n) < sizeof buf) break;
    if (!sized) {
      sized = true;
      struct stat st {};
      if (::fstat(fd, &st) == 0 && st.st_size > 0) out.reserve(static_cast<size_t>(st.st_size));
    }
  }
  ::close(fd);
  return out;
}

std::string ReadFile(const fs::path& path) { return ReadFileAt(AT_FDCWD, path.c_str(), path); }

bool IsFile(const fs::path& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && !S_ISDIR(st.st_mode);
}

void WriteFileAtomic(const fs::path& path, std::string_view data, bool sync) {
  std::error_code ec;
  fs::path parent = path.parent_path();
  if (!parent.empty()) {
    fs::create_directories(parent, ec);
    if (ec) throw Error("cannot create folder: " + ec.message(), parent.string());
  }
  fs::path tmp = path;
  tmp += TempSuffix();
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw Error(std::string("cannot write: ") + std::strerror(errno), path.string());
  }
  const char* p = data.data();
  size_t left = data.size();
  while (left > 0) {
    ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw Error(std::string("write failed: ") + std::strerror(err), path.string());
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  // Close even when fsync fails (a short-circuit here leaked the descriptor).
  int err = sync && ::fsync(fd) != 0 ? errno : 0;
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err != 0) {
    ::unlink(tmp.c_str());
    throw Error(std::string("write failed: ") + std::strerror(err), path.string());
  }
  CrashPoint("temp file written");  // a kill here leaves the temp file of a dead process
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    int err = errno;
    ::unlink(tmp.c_str());
    throw Error(std::string("cannot rename into place: ") + std::strerror(err), path.string());
  }
  CrashPoint("file renamed into place");
}

std::string RelativeGenericPath(const fs::path& path, const fs::path& base) {
  return path.lexically_relative(base).generic_string();
}

std::string TempSuffix() {
  static std::atomic<unsigned> counter{0};
  return ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
}

void FsyncPath(const fs::path& path, bool directory, const std::string& error_path) {
  const int fd = ::open(path.c_str(), (directory ? O_DIRECTORY : 0) | O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int err = errno;
    if (fd >= 0) ::close(fd);
    throw Error(std::string("fsync failed: ") + std::strerror(err), error_path);
  }
  ::close(fd);
}

StagingFolder::StagingFolder(const std::filesystem::path& path) {
  const std::filesystem::path parent = path.parent_path().empty() ? "." : path.parent_path();
  CreateDirectories(parent);
  RemoveDeadTempFiles(parent);
  path_ = parent / (path.filename().string() + TempSuffix());
}

StagingFolder::~StagingFolder() {
  if (path_.empty()) return;
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

size_t RemoveDeadTempFiles(const std::filesystem::path& dir) {
  size_t removed = 0;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    const size_t at = name.find(".tmp.");
    long pid = 0;
    if (at != std::string::npos && std::sscanf(name.c_str() + at, ".tmp.%ld.", &pid) == 1 &&
        pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      std::error_code rm;
      if (std::filesystem::remove_all(e.path(), rm) > 0) ++removed;
    }
  }
  return removed;
}

void SyncFileSystem(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::syncfs(fd);
  ::close(fd);
}

std::string Errno(std::string_view what) {
  const int e = errno;
  return std::string(what) + ": " + std::strerror(e);
}

bool WriteAll(int fd, std::string_view data) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data.remove_prefix(static_cast<size_t>(n));
  }
  return true;
}

void CreateDirectories(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create folder: " + ec.message(), dir.string());
}

void RenamePath(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw Error("cannot rename to " + to.string() + ": " + ec.message(), from.string());
}

void RemoveAll(const fs::path& path) {
  std::error_code ec;
  fs::remove_all(path, ec);
  if (ec) throw Error("cannot remove: " + ec.message(), path.string());
}

void RemovePath(const fs::path& path) {
  std::error_code ec;
  fs::remove(path, ec);
  if (ec) throw Error("cannot remove: " + ec.message(), path.string());
}

std::vector<fs::path> ListFolder(const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::path> out;
  fs::directory_iterator it(dir, ec), end;
  for (; !ec && it != end; it.increment(ec)) out.push_back(it->path());
  if (ec) throw Error("cannot list folder: " + ec.message(), dir.string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace mlspaces
