// A real HTTP server on 127.0.0.1 for download tests: testdata/http_server.py (Range requests,
// scripted faults, a JSON request log) run as a child process. Include as
// "resources/http_test_server.h".
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "test_util.h"

namespace mlspaces::testing {

class HttpTestServer {
 public:
  /// Starts the server on `root` and waits until it listens (it writes its port file then);
  /// the 300 s bound is a hang guard, not an expectation.
  /// @throws std::runtime_error when it does not come up.
  explicit HttpTestServer(std::filesystem::path root) : root_(std::move(root)) {
    const std::string script = std::string(MLSPACES_TESTDATA_DIR) + "/http_server.py";
    const std::string port_file = (dir_ / "port").string(), faults = faults_file().string(),
                      log = log_file().string(), root_arg = root_.string();
    std::vector<const char*> argv = {MLSPACES_PYTHON,  script.c_str(), "--root",
                                     root_arg.c_str(), "--port-file",  port_file.c_str(),
                                     "--faults",       faults.c_str(), "--log",
                                     log.c_str(),      nullptr};
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      // Dies with the test process, even when that one is killed. (PDEATHSIG follows the
      // creating thread: create the server on a thread that outlives it.)
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(127);
      ::execv(argv[0], const_cast<char* const*>(argv.data()));
      ::_exit(127);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(300);
    for (;;) {
      std::ifstream in(port_file);
      int port = 0;
      if (in >> port && port > 0) {
        url_ = "http://127.0.0.1:" + std::to_string(port);
        return;
      }
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("http_server.py exited before listening");
      }
      if (std::chrono::steady_clock::now() > deadline) {
        Kill();
        throw std::runtime_error("http_server.py did not listen within 300 s");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~HttpTestServer() { Kill(); }
  HttpTestServer(const HttpTestServer&) = delete;
  HttpTestServer& operator=(const HttpTestServer&) = delete;

  /// "http://127.0.0.1:PORT" (no trailing '/').
  std::string url() const { return url_; }

  /// Replaces the faults file (see http_server.py); the server's per-path fault counters
  /// restart when its content changes. Written to a temp file and renamed, so a request
  /// never sees half of it.
  void SetFaults(const std::string& json) {
    const std::filesystem::path tmp = dir_ / "faults.json.tmp";
    std::ofstream(tmp, std::ios::binary | std::ios::trunc) << json;
    std::filesystem::rename(tmp, faults_file());
  }

  /// The request log so far, one JSON object per line.
  std::vector<std::string> LogLines() const {
    std::vector<std::string> lines;
    std::ifstream in(log_file());
    for (std::string line; std::getline(in, line);) {
      if (!line.empty()) lines.push_back(line);
    }
    return lines;
  }

  /// SIGKILLs the server (connections drop as in a crash) and reaps it; idempotent.
  void Kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {}
    pid_ = -1;
  }

 private:
  std::filesystem::path faults_file() const { return dir_ / "faults.json"; }
  std::filesystem::path log_file() const { return dir_ / "log.jsonl"; }

  std::filesystem::path root_;
  TempDir dir_;
  pid_t pid_ = -1;
  std::string url_;
};

}  // namespace mlspaces::testing
