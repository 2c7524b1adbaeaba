// Child / RunInChild / ReadChildLines: output comes back whole or line by line, exit statuses
// and signals are reported, a throwing body exits with kBodyThrew, kills are reaped.
#include "mlspaces/core/subprocess.h"
#include "mlspaces/core/files.h"

#include <signal.h>
#include <unistd.h>

#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace mlspaces {
namespace {

TEST(SubprocessTest, OutputAndExitStatus) {
  const ChildResult r = RunInChild([](int fd) {
    std::string big(200000, 'x');  // more than a pipe holds: the parent must read meanwhile
    return WriteAll(fd, "hello " + big) ? 7 : 1;
  });
  EXPECT_EQ(r.output.size(), 6u + 200000u);
  EXPECT_EQ(r.output.substr(0, 6), "hello ");
  EXPECT_FALSE(r.exit.signaled);
  EXPECT_EQ(r.exit.number, 7);
  EXPECT_FALSE(r.exit.ok());
  EXPECT_TRUE(RunInChild([](int) { return 0; }).exit.ok());
}

TEST(SubprocessTest, ThrowingBodyAndSignals) {
  const ChildResult threw = RunInChild([](int) -> int { throw std::runtime_error("x"); });
  EXPECT_FALSE(threw.exit.signaled);
  EXPECT_EQ(threw.exit.number, Child::kBodyThrew);

  const ChildResult killed = RunInChild([](int fd) {
    WriteAll(fd, "partial");
    // What a crashed reader looks like. SIGKILL, not SIGSEGV: under AddressSanitizer a
    // SIGSEGV is caught and turned into exit code 1.
    ::raise(SIGKILL);
    return 0;
  });
  EXPECT_TRUE(killed.exit.signaled);
  EXPECT_EQ(killed.exit.number, SIGKILL);
  EXPECT_EQ(killed.output, "partial");
}

TEST(SubprocessTest, LinesFromSeveralChildren) {
  std::vector<Child> children;
  children.reserve(3);
  for (int c = 0; c < 3; ++c) {
    children.push_back(Child::Start([c](int fd) {
      for (int i = 0; i < 50; ++i) {
        WriteAll(fd, std::to_string(c) + ":" + std::to_string(i) + "\n");
      }
      WriteAll(fd, "no newline");  // dropped
      return c;
    }));
  }
  std::vector<std::vector<std::string>> lines(3);
  ReadChildLines(children, [&](size_t i, std::string_view line) { lines[i].emplace_back(line); });
  for (int c = 0; c < 3; ++c) {
    ASSERT_EQ(lines[c].size(), 50u);
    EXPECT_EQ(lines[c][0], std::to_string(c) + ":0");
    EXPECT_EQ(lines[c][49], std::to_string(c) + ":49");
    const ChildExit e = children[c].Wait();
    EXPECT_FALSE(e.signaled);
    EXPECT_EQ(e.number, c);
  }
}

TEST(SubprocessTest, KillAndThrowingHandler) {
  std::vector<Child> children;
  children.push_back(Child::Start([](int fd) {
    WriteAll(fd, "ready\n");
    for (;;) ::pause();
    return 0;
  }));
  // The handler kills the child; reading ends when its pipe closes.
  ReadChildLines(children, [&](size_t, std::string_view) { children[0].Kill(); });
  const ChildExit e = children[0].Wait();
  EXPECT_TRUE(e.signaled);
  EXPECT_EQ(e.number, SIGKILL);

  std::vector<Child> more;
  more.push_back(Child::Start([](int fd) {
    WriteAll(fd, "line\n");
    for (;;) ::pause();
    return 0;
  }));
  EXPECT_THROW(
      ReadChildLines(more, [](size_t, std::string_view) { throw std::runtime_error("handler"); }),
      std::runtime_error);
  // The child was killed and reaped: waiting again reports nothing new.
  EXPECT_TRUE(more[0].Wait().ok());
}

}  // namespace
}  // namespace mlspaces
