// Helpers shared by the test suites: temp folders, small files, Debian's python, the CLI
// binary, the bundled example library and error strings. Include as "test_util.h".
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"

namespace mlspaces::testing {

/// A fresh folder under temp_directory_path() (mkdtemp), removed with everything in it on
/// destruction.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "mlspaces_test_XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) std::abort();
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& rel) const { return path_ / rel; }

 private:
  std::filesystem::path path_;
};

/// `n` bytes that do not compress (xorshift from `seed`): large archives, raw blocks.
inline std::string Noise(size_t n, uint64_t seed) {
  std::string out(n, '\0');
  for (char& c : out) {
    seed ^= seed << 13;
    seed ^= seed >> 7;
    seed ^= seed << 17;
    c = static_cast<char>(seed);
  }
  return out;
}

/// Writes `text` to `path` (plain write, no fsync), creating parent folders.
inline void WriteText(const std::filesystem::path& path, std::string_view text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  ASSERT_TRUE(out.good()) << path;
}

/// The whole content of `path`; "" when it cannot be read.
inline std::string Slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The bytes of every file under `dir` (recursive) whose extension is one of `extensions`
/// (".h5", ".mp4", ...), by path relative to `dir`.
inline std::map<std::string, std::string> FilesByExtension(
    const std::filesystem::path& dir, std::initializer_list<std::string_view> extensions) {
  std::map<std::string, std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    const std::string ext = e.path().extension().string();
    for (std::string_view want : extensions) {
      if (ext == want) out[e.path().lexically_relative(dir).generic_string()] = Slurp(e.path());
    }
  }
  return out;
}

/// Every file name under `dir` (recursive, relative, '/'-separated).
inline std::set<std::string> ListFiles(const std::filesystem::path& dir) {
  std::set<std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_directory()) out.insert(e.path().lexically_relative(dir).generic_string());
  }
  return out;
}

/// `s` single-quoted for /bin/sh.
inline std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

/// Runs `script` (written to `dir`/script.py) with Debian's python, which has numpy, and
/// `args` (already shell words). Returns its exit status; `output` gets its stdout. A failure
/// is reported with stdout and stderr.
inline int RunPython(const std::filesystem::path& dir, const std::string& script,
                     const std::string& args, std::string* output = nullptr) {
  const std::filesystem::path file = dir / "script.py", err = dir / "script.err";
  std::ofstream(file) << script;
  const std::string cmd = std::string(MLSPACES_PYTHON) + " " + file.string() + " " + args + " 2>" +
                          ShellQuote(err.string());
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  const int status = ::pclose(pipe);
  if (output != nullptr) *output = out;
  if (status != 0) ADD_FAILURE() << "python failed (" << status << "):\n" << out << Slurp(err);
  return status;
}

/// What a run of the mlspaces binary printed and returned.
struct CliResult {
  int exit_code = -1;
  std::string out;
  std::string err;
  bool sigkilled = false;  // ended by SIGKILL (directly, or as the shell's exit code 137)
};

/// `prefix` (shell words) followed by `program` and `args`, each quoted: one /bin/sh command.
inline std::string ShellCommand(const std::string& program, const std::vector<std::string>& args,
                                const std::string& prefix) {
  std::string cmd = prefix + ShellQuote(program);
  for (const std::string& a : args) cmd += " " + ShellQuote(a);
  return cmd;
}

/// Runs `program` with `args`; `prefix` (shell words, e.g. "env -u X") goes before it.
/// stdout and stderr go to files in a temp folder of their own.
inline CliResult RunProgram(const std::string& program, const std::vector<std::string>& args,
                            const std::string& prefix = "") {
  TempDir io;
  std::string cmd = ShellCommand(program, args, prefix);
  cmd += " >" + ShellQuote((io / "out").string()) + " 2>" + ShellQuote((io / "err").string());
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.sigkilled =
      (WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) || r.exit_code == 128 + SIGKILL;
  r.out = Slurp(io / "out");
  r.err = Slurp(io / "err");
  return r;
}

/// Runs the mlspaces binary (see RunProgram).
inline CliResult RunCli(const std::vector<std::string>& args, const std::string& prefix = "") {
  return RunProgram(MLSPACES_CLI_PATH, args, prefix);
}

/// Starts the mlspaces binary with `args` in a child process and returns at once with its pid,
/// which is the CLI's own (the shell and `env` exec it), so a SIGKILL hits it; reap it with
/// waitpid. `prefix` as for RunProgram; stdout goes to /dev/null, stderr to `err` (or there).
inline pid_t SpawnCli(const std::vector<std::string>& args, const std::string& prefix = "",
                      const std::filesystem::path& err = {}) {
  std::string cmd = "exec " + ShellCommand(MLSPACES_CLI_PATH, args, prefix);
  cmd += " >/dev/null 2>" + (err.empty() ? std::string("/dev/null") : ShellQuote(err.string()));
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

/// Crash points for CLI runs (mlspaces/core/crash_point.h): the environment that makes a run
/// count its durable steps in a counter file, or SIGKILL itself after step N.
class CrashPoints {
 public:
  explicit CrashPoints(std::filesystem::path counter) : counter_(std::move(counter)) {}
  /// Shell words for RunCli's prefix: count steps from zero, never crash.
  std::string Counting() const { return Prefix(0); }
  /// Shell words for RunCli's prefix: count from zero, SIGKILL after step `n` (>= 1).
  std::string KillAt(uint64_t n) const { return Prefix(n); }
  /// The steps the last run counted (all its processes together).
  uint64_t Count() const {
    const std::string bytes = Slurp(counter_);
    uint64_t n = 0;
    if (bytes.size() >= sizeof n) std::memcpy(&n, bytes.data(), sizeof n);
    return n;
  }

 private:
  std::string Prefix(uint64_t at) const {
    std::filesystem::remove(counter_);
    return "env MLSPACES_CRASH_COUNTER=" + ShellQuote(counter_.string()) +
           (at > 0 ? " MLSPACES_CRASH_AT=" + std::to_string(at) : std::string()) + " ";
  }
  std::filesystem::path counter_;
};

/// Polls `done` every 10 ms until it holds: how a test waits for an event it cannot block on
/// (a file appearing, a log line). The bound is only a hang guard, far above any real wait;
/// reaching it is a test failure naming `what`. @returns whether `done` held.
template <class Done>
bool WaitUntil(const std::string& what, Done&& done, int guard_seconds = 300) {
  for (int i = 0; i < guard_seconds * 100; ++i) {
    if (done()) return true;
    ::usleep(10000);
  }
  ADD_FAILURE() << "still waiting for " << what << " after " << guard_seconds << " s";
  return false;
}

/// The what() of the mlspaces::Error `f` throws, or "<no error>".
template <class F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

/// Asserts that `fn` throws mlspaces::Error whose what() is one line containing every one of
/// `parts`.
template <typename Fn>
void ExpectError(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "expected mlspaces::Error";
  } catch (const Error& e) {
    std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    for (const std::string& p : parts) EXPECT_THAT(what, ::testing::HasSubstr(p));
  }
}

/// The example library in the source tree (examples/custom_assets/asset_library).
inline std::filesystem::path ExampleLibrary() {
  return std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "asset_library";
}

/// Copies the bundled example library into `dir`/asset_library and returns that path.
inline std::filesystem::path CopyExampleLibrary(const std::filesystem::path& dir) {
  std::filesystem::path dst = dir / "asset_library";
  std::filesystem::copy(ExampleLibrary(), dst, std::filesystem::copy_options::recursive);
  return dst;
}

/// Minimal metadata JSON for a generated asset.
inline std::string MinimalMetadata(const std::string& uid) {
  return "{\n    \"assetId\": \"" + uid +
         "\",\n    \"category\": \"block\",\n"
         "    \"synset\": \"block.n.01\"\n}";
}

}  // namespace mlspaces::testing
