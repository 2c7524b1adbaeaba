// Helpers of src/core/files.cc: Errno, WriteAll and StagingFolder.
#include "mlspaces/core/files.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;

TEST(FilesTest, StagingFolderIsRemovedUnlessKept) {
  testing::TempDir dir;
  const fs::path out = dir / "sub" / "dataset";
  fs::path dropped;
  {
    StagingFolder staging(out);
    dropped = staging.path();
    EXPECT_EQ(dropped.parent_path(), dir / "sub");  // the parent is made, the folder is not
    EXPECT_TRUE(fs::is_directory(dir / "sub"));
    EXPECT_FALSE(fs::exists(dropped));
    EXPECT_TRUE(dropped.filename().string().starts_with("dataset.tmp."));
    WriteFileAtomic(dropped / "a" / "file", "x");
  }
  EXPECT_FALSE(fs::exists(dropped));  // removed with its contents
  {
    StagingFolder staging(out);
    WriteFileAtomic(staging.path() / "file", "y");
    fs::rename(staging.path(), out);
    staging.Keep();
  }
  EXPECT_EQ(testing::Slurp(out / "file"), "y");
}

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

TEST(FilesTest, FileSystemEditsThrowErrorNamingThePath) {
  // std::filesystem's own calls would throw filesystem_error, which the CLI reports as an
  // internal error; these wrappers throw mlspaces::Error with the path.
  testing::TempDir dir;
  testing::WriteText(dir / "file", "x");
  const std::string under_file = (dir / "file" / "sub").string();
  testing::ExpectError([&] { CreateDirectories(dir / "file" / "sub"); },
                       {under_file, "cannot create folder"});
  testing::ExpectError([&] { RenamePath(dir / "missing", dir / "to"); },
                       {(dir / "missing").string(), "cannot rename to " + (dir / "to").string()});
  testing::ExpectError([&] { RemovePath(dir / "file" / "sub"); }, {under_file, "cannot remove"});
  testing::ExpectError([&] { RemoveAll(dir / "file" / "sub"); }, {under_file, "cannot remove"});
  testing::ExpectError([&] { ListFolder(dir / "file"); },
                       {(dir / "file").string(), "cannot list folder"});
  testing::ExpectError([&] { ListFolder(dir / "missing"); }, {"cannot list folder"});

  // And they do their work.
  CreateDirectories(dir / "a" / "b");
  testing::WriteText(dir / "a" / "z", "z");
  RenamePath(dir / "file", dir / "a" / "y");
  EXPECT_EQ(ListFolder(dir / "a"), (std::vector<std::filesystem::path>{
                                       dir / "a" / "b", dir / "a" / "y", dir / "a" / "z"}));
  RemovePath(dir / "a" / "y");
  RemovePath(dir / "a" / "y");  // gone already: no error
  RemoveAll(dir / "a");
  RemoveAll(dir / "a");
  EXPECT_FALSE(std::filesystem::exists(dir / "a"));
}

}  // namespace
}  // namespace mlspaces
