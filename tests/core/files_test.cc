// POSIX helpers of src/core/files.cc: Errno and WriteAll.
#include "mlspaces/core/files.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include <gtest/gtest.h>

namespace mlspaces {
namespace {

TEST(FilesTest, ErrnoNamesWhatFailedAndWhy) {
  errno = ENOENT;
  EXPECT_EQ(Errno("cannot open"), std::string("cannot open: ") + std::strerror(ENOENT));
  ASSERT_LT(::open("/nonexistent-mlspaces-dir/x", O_RDONLY), 0);
  EXPECT_EQ(Errno("open"), std::string("open: ") + std::strerror(ENOENT));
}

TEST(FilesTest, WriteAllWritesEverythingThroughAPipe) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  // Within the default 64 KiB pipe buffer, so no reader thread is needed.
  std::string data(60000, '\0');
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>(i * 7);
  ASSERT_TRUE(WriteAll(fds[1], data));
  ASSERT_TRUE(WriteAll(fds[1], ""));
  ::close(fds[1]);
  std::string got;
  char buf[4096];
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) got.append(buf, n);
  ::close(fds[0]);
  EXPECT_EQ(got, data);
}

TEST(FilesTest, WriteAllReportsAFailedWrite) {
  // A pipe whose reader is gone: write fails with EPIPE (SIGPIPE ignored here).
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ::close(fds[0]);
  struct sigaction ignore {
  }, old{};
  ignore.sa_handler = SIG_IGN;
  ASSERT_EQ(::sigaction(SIGPIPE, &ignore, &old), 0);
  EXPECT_FALSE(WriteAll(fds[1], "x"));
  EXPECT_EQ(errno, EPIPE);
  ::sigaction(SIGPIPE, &old, nullptr);
  ::close(fds[1]);
  // A closed descriptor.
  EXPECT_FALSE(WriteAll(fds[1], "x"));
  EXPECT_EQ(errno, EBADF);
}

}  // namespace
}  // namespace mlspaces
