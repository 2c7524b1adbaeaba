#include "mlspaces/core/file_lock.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;

// Hang guard for waits on pipes: far above any real wait. A test here never decides by time;
// it waits for events (a byte on a pipe, the lock's on_wait call, a child's exit).
constexpr int kGuardMs = 300000;

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
    } catch (...) {}
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

TEST(FileLock, SecondProcessBlocksWhileFirstHolds) {
  TempDir dir;
  const fs::path path = dir / "locks" / "install.lock";  // its folder is created
  // The children are forked before we lock: a child forked while we hold the lock would
  // inherit our descriptor, and with it the lock (flock semantics).
  Pipe go_impatient, go_patient, waiting, got;
  const pid_t impatient = Fork([&] {
    go_impatient.Wait(kGuardMs);
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
    go_patient.Wait(kGuardMs);
    FileLock l(path, [&](long) { waiting.Send(); });
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
    // It found the lock held and is waiting; it must not have it while we do.
    ASSERT_TRUE(waiting.Wait(kGuardMs)) << "the second process never waited";
    EXPECT_FALSE(got.Wait(0)) << "the second process got the lock while we held it";
  }
  EXPECT_TRUE(got.Wait(kGuardMs)) << "the second process did not get the lock after release";
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
    release.Wait(kGuardMs);
    return 0;
  });
  ASSERT_TRUE(locked.Wait(kGuardMs));
  std::vector<long> waits;
  {
    // The holder is told to release only once we are waiting: the lock cannot be ours early.
    FileLock lock(path, [&](long pid) {
      waits.push_back(pid);
      release.Send();
    });
    EXPECT_EQ(Slurp(path), std::to_string(::getpid()) + "\n");
  }
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
  ASSERT_TRUE(locked.Wait(kGuardMs));
  EXPECT_TRUE(FileLock::IsHeld(path));
  // Still held: a short timeout fails and names the holder.
  ExpectError([&] { FileLock l(path, {}, 0.1); },
              {path.string(), "timed out", "pid " + std::to_string(holder)});

  std::vector<long> waits;
  {
    // Killed once we wait; the kernel releases the lock with the dead process, so we get it
    // with no stale-lock clean-up (the timeout is a hang guard).
    FileLock lock(
        path,
        [&](long pid) {
          waits.push_back(pid);
          ::kill(holder, SIGKILL);
        },
        kGuardMs / 1000.0);
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
  FileLock again(
      dir / "x.lock", [&](long) { waited = true; }, 0);
  EXPECT_FALSE(waited);
}

TEST(FileLock, UnusableLockPathIsAnError) {
  TempDir dir;
  testing::WriteText(dir / "file", "x");
  ExpectError([&] { FileLock l(dir / "file" / "a.lock"); }, {(dir / "file").string()});
}

}  // namespace
}  // namespace mlspaces
