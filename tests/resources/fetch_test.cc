#include "mlspaces/resources/fetch.h"

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "mlspaces/resources/sha256.h"
#include "resources/http_test_server.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::HttpTestServer;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::Noise;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using nlohmann::json;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

class Fetch : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = Noise(300000, 42);
    WriteText(root_ / "data" / "file.bin", data_);
    WriteText(root_ / "small.json", "{\"version\": 1}\n");
    fast_.retry_delay_s = 0.01;
    // Hang guards only: no test here waits for these to expire (a loaded machine may pause
    // a transfer for a while, and that must not fail a test).
    fast_.stall_timeout_s = 120;
    fast_.connect_timeout_s = 60;
  }
  std::string Url(const std::string& rel = "data/file.bin") const {
    return JoinUrl(server_.url(), rel);
  }
  FetchExpect Expect() const { return {data_.size(), Sha256Hex(data_)}; }
  /// The server's log as JSON objects.
  std::vector<json> Log(const HttpTestServer& server) const {
    std::vector<json> out;
    for (const std::string& line : server.LogLines()) out.push_back(json::parse(line));
    return out;
  }
  std::vector<json> Log() const { return Log(server_); }
  fs::path Part() const { return fs::path(dest_.string() + ".part"); }

  TempDir root_, out_;
  HttpTestServer server_{root_.path()};
  std::string data_;
  FetchOptions fast_;
  fs::path dest_ = out_ / "sub" / "file.bin";
};

TEST_F(Fetch, PlainDownload) {
  std::vector<std::pair<uint64_t, uint64_t>> progress;
  FetchOptions options = fast_;
  options.progress = [&](uint64_t now, uint64_t total) { progress.emplace_back(now, total); };
  FetchFile(Url(), dest_, Expect(), options);
  EXPECT_EQ(Slurp(dest_), data_);
  EXPECT_THAT(ListFiles(out_.path()), ElementsAre("sub/file.bin"));  // no .part left
  const auto log = Log();
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0]["path"], "/data/file.bin");
  EXPECT_TRUE(log[0]["range"].is_null());
  EXPECT_EQ(log[0]["status"], 200);
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.back(), std::make_pair(uint64_t{data_.size()}, uint64_t{data_.size()}));
}

TEST_F(Fetch, FileUrl) {
  WriteText(root_ / "with space & %.bin", data_);
  const std::string url = FileUrl(root_ / "with space & %.bin");
  EXPECT_EQ(url.rfind("file:///", 0), 0u) << url;
  EXPECT_THAT(url, HasSubstr("with%20space%20%26%20%25.bin"));
  FetchFile(url, dest_, Expect(), fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  // A missing local file is not worth retrying.
  const std::string missing = FileUrl(root_ / "missing.bin");
  ExpectError([&] { FetchFile(missing, out_ / "m.bin", {}, fast_); }, {missing, "curl error 37"});
}

TEST_F(Fetch, FileUrlResumesThePartFile) {
  WriteText(Part(), data_.substr(0, 1000));
  FetchFile(FileUrl(root_ / "data/file.bin"), dest_, Expect(), fast_);
  EXPECT_EQ(Slurp(dest_), data_);
}

TEST_F(Fetch, ResumesAfterTruncatedTransfer) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "truncate", "after": 100000}]})");
  FetchFile(Url(), dest_, Expect(), fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  const auto log = Log();
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[0]["fault"], "truncate");
  EXPECT_EQ(log[1]["range"], "bytes=100000-");
  EXPECT_EQ(log[1]["status"], 206);
}

TEST_F(Fetch, PartFileIsKeptForTheNextCall) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "slow_then_drop", "after": 70000}]})");
  FetchOptions once = fast_;
  once.retries = 0;
  ExpectError([&] { FetchFile(Url(), dest_, Expect(), once); }, {Url(), "curl error 18"});
  EXPECT_FALSE(fs::exists(dest_));
  EXPECT_EQ(fs::file_size(Part()), 70000u);
  FetchFile(Url(), dest_, Expect(), once);
  EXPECT_EQ(Slurp(dest_), data_);
  EXPECT_EQ(Log().back()["range"], "bytes=70000-");
}

TEST_F(Fetch, ServerIgnoringRangeRestartsThePart) {
  // The part holds junk; a 200 answer to our Range request must replace it, not extend it.
  WriteText(Part(), std::string(1000, 'j'));
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "norange"}]})");
  FetchFile(Url(), dest_, Expect(), fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  const auto log = Log();
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0]["range"], "bytes=1000-");
  EXPECT_EQ(log[0]["status"], 200);
}

TEST_F(Fetch, CompletePartAnswered416IsVerifiedAndKept) {
  WriteText(Part(), data_);  // complete, but the size was not given: the server tells (416)
  FetchExpect sha_only;
  sha_only.sha256 = Sha256Hex(data_);
  FetchFile(Url(), dest_, sha_only, fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  ASSERT_EQ(Log().size(), 1u);
  EXPECT_EQ(Log()[0]["status"], 416);
}

TEST_F(Fetch, OverlongPartAnswered416IsRestarted) {
  WriteText(Part(), data_ + "extra junk");
  FetchFile(Url(), dest_, {}, fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  const auto log = Log();
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[0]["status"], 416);
  EXPECT_TRUE(log[1]["range"].is_null());
}

TEST_F(Fetch, FlippedByteIsAShaMismatch) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "flip", "after": 5000}]})");
  ExpectError([&] { FetchFile(Url(), dest_, Expect(), fast_); },
              {Url(), "SHA-256 mismatch", Sha256Hex(data_)});
  EXPECT_FALSE(fs::exists(dest_));
  EXPECT_FALSE(fs::exists(Part()));
  // The next call starts over (and the fault is used up).
  FetchFile(Url(), dest_, Expect(), fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  EXPECT_TRUE(Log().back()["range"].is_null());
}

TEST_F(Fetch, SizeMismatch) {
  FetchExpect wrong = Expect();
  wrong.size = data_.size() + 10;
  ExpectError([&] { FetchFile(Url(), dest_, wrong, fast_); },
              {Url(), "size mismatch", std::to_string(data_.size() + 10)});
  EXPECT_FALSE(fs::exists(dest_));
  EXPECT_FALSE(fs::exists(Part()));
  wrong.size = data_.size() - 10;
  ExpectError([&] { FetchFile(Url(), dest_, wrong, fast_); }, {Url(), "size mismatch"});
  EXPECT_FALSE(fs::exists(Part()));
}

TEST_F(Fetch, Error500OnceIsRetried) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "500"}]})");
  FetchFile(Url(), dest_, Expect(), fast_);
  EXPECT_EQ(Slurp(dest_), data_);
  const auto log = Log();
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[0]["status"], 500);
  EXPECT_EQ(log[1]["status"], 200);
}

TEST_F(Fetch, Error500ForeverGivesUp) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "500"}, {"mode": "500"}, {"mode": "500"},
                                          {"mode": "500"}, {"mode": "500"}]})");
  FetchOptions options = fast_;
  options.retries = 2;
  ExpectError([&] { FetchFile(Url(), dest_, Expect(), options); },
              {Url(), "HTTP 500", "after 3 attempts"});
  EXPECT_EQ(Log().size(), 3u);
  EXPECT_FALSE(fs::exists(dest_));
}

TEST_F(Fetch, NotFoundIsNotRetried) {
  ExpectError([&] { FetchFile(Url("nope.bin"), dest_, {}, fast_); }, {Url("nope.bin"), "HTTP 404"});
  EXPECT_EQ(Log().size(), 1u);
  // A 404 body (an error page) is never written as data.
  EXPECT_FALSE(fs::exists(dest_));
  EXPECT_TRUE(!fs::exists(Part()) || fs::file_size(Part()) == 0);
  server_.SetFaults(R"({"/small.json": [{"mode": "404"}]})");
  ExpectError([&] { FetchToString(Url("small.json"), fast_); }, {Url("small.json"), "HTTP 404"});
  EXPECT_EQ(Log().size(), 2u);
  // The test server keeps to its root.
  const std::string escape = server_.url() + "/%2e%2e/%2e%2e/%2e%2e/etc/passwd";
  ExpectError([&] { FetchToString(escape, fast_); }, {escape, "HTTP 403"});
}

TEST_F(Fetch, NotFoundIsToldApartFromOtherFailures) {
  auto not_found = [&](const std::string& url) {
    try {
      FetchToString(url, fast_);
    } catch (const FetchError& e) {
      return e.not_found();
    }
    ADD_FAILURE() << "no FetchError for " << url;
    return false;
  };
  EXPECT_TRUE(not_found(Url("nope.bin")));                        // HTTP 404
  EXPECT_TRUE(not_found(FileUrl(out_.path() / "missing.json")));  // file:// without the file
  EXPECT_FALSE(not_found(server_.url() + "/%2e%2e/etc/passwd"));  // HTTP 403
  server_.SetFaults(R"({"/small.json": [{"mode": "500"}, {"mode": "500"}, {"mode": "500"},
                                         {"mode": "500"}]})");
  EXPECT_FALSE(not_found(Url("small.json")));  // HTTP 500, retried
}

TEST_F(Fetch, StalledTransferTimesOutAndResumes) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "hang", "after": 40000},
                                          {"mode": "hang", "after": 60000}]})");
  FetchOptions options = fast_;
  // The server hangs forever: only the stall timeout can end these transfers. (How long a
  // stall takes to be noticed is a figure for a benchmark, not a test's verdict.)
  options.stall_timeout_s = 2;
  options.retries = 0;
  ExpectError([&] { FetchFile(Url(), dest_, Expect(), options); }, {Url(), "stalled", "2 s"});
  EXPECT_EQ(fs::file_size(Part()), 40000u);
  options.retries = 1;
  FetchFile(Url(), dest_, Expect(), options);
  EXPECT_EQ(Slurp(dest_), data_);
  const auto log = Log();
  ASSERT_EQ(log.size(), 3u);
  EXPECT_EQ(log[1]["range"], "bytes=40000-");
  EXPECT_EQ(log[2]["range"], "bytes=100000-");
}

TEST_F(Fetch, ServerKilledMidDownloadThenResumedFromPart) {
  server_.SetFaults(R"({"/data/file.bin": [{"mode": "hang", "after": 50000}]})");
  FetchOptions options = fast_;
  options.retries = 0;
  options.stall_timeout_s = 30;  // the kill, not the stall timeout, ends the transfer
  // Killed once the 50,000 bytes before the hang are on disk: an event, not a delay.
  std::thread killer([&] {
    ::mlspaces::testing::WaitUntil("50000 bytes in the partial file", [&] {
      std::error_code ec;
      return fs::file_size(Part(), ec) == 50000u;
    });
    server_.Kill();
  });
  const std::string url = Url();
  try {
    FetchFile(url, dest_, Expect(), options);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(url));
    EXPECT_THAT(e.what(), HasSubstr("curl error"));
  }
  killer.join();
  EXPECT_FALSE(fs::exists(dest_));
  EXPECT_EQ(fs::file_size(Part()), 50000u);
  // Nobody listens there now: connection refused, retried, then an error naming it.
  options.retries = 1;
  ExpectError([&] { FetchFile(url, dest_, Expect(), options); }, {url, "curl error 7"});

  HttpTestServer restarted(root_.path());
  FetchFile(JoinUrl(restarted.url(), "data/file.bin"), dest_, Expect(), options);
  EXPECT_EQ(Slurp(dest_), data_);
  const auto log = Log(restarted);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0]["range"], "bytes=50000-");
  EXPECT_EQ(log[0]["status"], 206);
}

TEST_F(Fetch, FetchToString) {
  server_.SetFaults(R"({"/small.json": [{"mode": "500"}, {"mode": "truncate", "after": 3}]})");
  EXPECT_EQ(FetchToString(Url("small.json"), fast_), "{\"version\": 1}\n");
  EXPECT_EQ(Log().size(), 3u);
  EXPECT_EQ(FetchToString(FileUrl(root_ / "small.json"), fast_), "{\"version\": 1}\n");
  FetchOptions once = fast_;
  once.retries = 0;
  server_.SetFaults(R"({"/small.json": [{"mode": "500"}]})");
  ExpectError([&] { FetchToString(Url("small.json"), once); }, {Url("small.json"), "HTTP 500"});
}

TEST_F(Fetch, BadUrls) {
  ExpectError([&] { FetchToString("ftp://example.com/x", fast_); },
              {"ftp://example.com/x", "curl error"});
  ExpectError([&] { FetchToString("not a url", fast_); }, {"not a url", "curl error"});
}

TEST(FetchUrls, JoinUrl) {
  EXPECT_EQ(JoinUrl("http://h/a", "b/c"), "http://h/a/b/c");
  EXPECT_EQ(JoinUrl("http://h/a/", "/b"), "http://h/a/b");
  EXPECT_EQ(JoinUrl("http://h/a//", "b"), "http://h/a/b");
}

}  // namespace
}  // namespace mlspaces
