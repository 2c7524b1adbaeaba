#include "mlspaces/resources/file_lock.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using Clock = std::chrono::steady_clock;

/// A pipe for one-byte messages between parent and forked child.
struct Pipe {
  int fds[2] = {-1, -1};
  Pipe() { EXPECT_EQ(::pipe(fds), 0); }
  ~Pipe() {
    ::close(fds[0]);
    ::close(fds[1]);
  }
  void Send(char c = 'x') { EXPECT_EQ(::write(fds[1], &c, 1), 1); }
  /// True when a byte arrived within `ms`.
  bool Wait(int ms) {
    pollfd p{fds[0], POLLIN, 0};
    if (::poll(&p, 1, ms) != 1) return false;
    char c;
    return ::read(fds[0], &c, 1) == 1;
  }
};

/// Forks a child that runs `body` and exits with its return value (or 99 on an exception).
template <class F>
pid_t Fork(F body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    int code = 99;
    try {
      code = body();
    } catch (...) {
    }
    ::_exit(code);
  }
  EXPECT_GT(pid, 0);
  return pid;
}

int Reap(pid_t pid) {
  int status = 0;
  EXPECT_EQ(::waitpid(pid, &status, 0), pid);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

TEST(FileLock, SecondProcessBlocksWhileFirstHolds) {
  TempDir dir;
  const fs::path path = dir / "locks" / "install.lock";  // its folder is created
  // The children are forked before we lock: a child forked while we hold the lock would
  // inherit our descriptor, and with it the lock (flock semantics).
  Pipe go_impatient, go_patient, got;
  const pid_t impatient = Fork([&] {
    go_impatient.Wait(10000);
    try {
      FileLock l(path, {}, 0.2);
    } catch (const Error& e) {  // a waiter with a timeout gives up, naming the path and us
      const std::string what = e.what();
      return what.find(path.string()) != std::string::npos &&
                     what.find("pid " + std::to_string(::getppid())) != std::string::npos
                 ? 3
                 : 4;
    }
    return 0;
  });
  const pid_t patient = Fork([&] {
    go_patient.Wait(10000);
    FileLock l(path);
    got.Send();
    return 0;
  });
  {
    FileLock lock(path);
    EXPECT_EQ(Slurp(path), std::to_string(::getpid()) + "\n");
    EXPECT_TRUE(FileLock::IsHeld(path));
    go_impatient.Send();
    EXPECT_EQ(Reap(impatient), 3);
    go_patient.Send();
    EXPECT_FALSE(got.Wait(400)) << "the second process got the lock while we held it";
  }
  EXPECT_TRUE(got.Wait(5000)) << "the second process did not get the lock after release";
  EXPECT_EQ(Reap(patient), 0);
  EXPECT_FALSE(FileLock::IsHeld(path));
  EXPECT_TRUE(fs::exists(path));  // never deleted (see file_lock.cc)
}

TEST(FileLock, WaiterGetsItWhenHolderReleases) {
  TempDir dir;
  const fs::path path = dir / "a.lock";
  Pipe locked, release;
  const pid_t holder = Fork([&] {
    FileLock l(path);
    locked.Send();
    release.Wait(10000);
    return 0;
  });
  ASSERT_TRUE(locked.Wait(5000));
  std::vector<long> waits;
  std::thread releaser([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    release.Send();
  });
  const auto start = Clock::now();
  {
    FileLock lock(path, [&](long pid) { waits.push_back(pid); });
    EXPECT_GE(SecondsSince(start), 0.25);
    EXPECT_EQ(Slurp(path), std::to_string(::getpid()) + "\n");
  }
  releaser.join();
  EXPECT_THAT(waits, ::testing::ElementsAre(holder));  // once, with the holder's pid
  EXPECT_EQ(Reap(holder), 0);
}

TEST(FileLock, KilledHolderReleasesTheLock) {
  TempDir dir;
  const fs::path path = dir / "a.lock";
  Pipe locked;
  const pid_t holder = Fork([&] {
    FileLock l(path);
    locked.Send();
    for (;;) ::pause();
    return 0;
  });
  ASSERT_TRUE(locked.Wait(5000));
  EXPECT_TRUE(FileLock::IsHeld(path));
  // Still held: a short timeout fails and names the holder.
  ExpectError([&] { FileLock l(path, {}, 0.1); },
              {path.string(), "timed out", "pid " + std::to_string(holder)});

  std::vector<long> waits;
  Clock::time_point killed;
  std::thread killer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    killed = Clock::now();
    ::kill(holder, SIGKILL);
  });
  {
    FileLock lock(path, [&](long pid) { waits.push_back(pid); }, 10.0);
    killer.join();
    // The kernel released it with the dead process: no stale lock, a quick hand-over.
    EXPECT_LT(SecondsSince(killed), 1.0);
    EXPECT_EQ(Slurp(path), std::to_string(::getpid()) + "\n");
  }
  EXPECT_THAT(waits, ::testing::ElementsAre(holder));
  EXPECT_EQ(Reap(holder), 128 + SIGKILL);
  EXPECT_FALSE(FileLock::IsHeld(path));
}

TEST(FileLock, IsHeldProbes) {
  TempDir dir;
  EXPECT_FALSE(FileLock::IsHeld(dir / "never.lock"));
  EXPECT_FALSE(fs::exists(dir / "never.lock"));  // probing creates nothing
  {
    FileLock lock(dir / "x.lock");
    EXPECT_TRUE(FileLock::IsHeld(dir / "x.lock"));
  }
  EXPECT_FALSE(FileLock::IsHeld(dir / "x.lock"));
  // No lock is taken without waiting: an uncontended lock calls no on_wait.
  bool waited = false;
  FileLock again(dir / "x.lock", [&](long) { waited = true; }, 0);
  EXPECT_FALSE(waited);
}

TEST(FileLock, UnusableLockPathIsAnError) {
  TempDir dir;
  testing::WriteText(dir / "file", "x");
  ExpectError([&] { FileLock l(dir / "file" / "a.lock"); }, {(dir / "file").string()});
}

}  // namespace
}  // namespace mlspaces
