// Downloads with libcurl's easy API: one easy handle per attempt, resumable .part files,
// size and SHA-256 checks before the rename into place.
#include "mlspaces/resources/fetch.h"

#include <curl/curl.h>
#include <fcntl.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/resources/sha256.h"

namespace mlspaces {
namespace fs = std::filesystem;
namespace {

void GlobalInit() {
  // curl_global_init is not thread-safe; call_once makes our first use of it so.
  static std::once_flag once;
  std::call_once(once, [] {
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) {
      throw Error("curl_global_init failed");
    }
  });
}

/// Where the body goes.
class Sink {
 public:
  virtual ~Sink() = default;
  /// Drops everything received so far (the server answered a Range request with 200).
  virtual bool Restart() = 0;
  virtual bool Write(const char* data, size_t size) = 0;
  std::string error;
};

class StringSink : public Sink {
 public:
  bool Restart() override {
    text.clear();
    return true;
  }
  bool Write(const char* data, size_t size) override {
    text.append(data, size);
    return true;
  }
  std::string text;
};

/// Appends to `path` from `offset` (the bytes already there).
class FileSink : public Sink {
 public:
  static constexpr uint64_t kCrashStride = 4096;

  FileSink(const fs::path& path, uint64_t offset) : pos_(offset) {
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(std::string("cannot write: ") + std::strerror(errno), path.string());
  }
  ~FileSink() override { ::close(fd_); }
  bool Restart() override {
    pos_ = 0;
    if (::ftruncate(fd_, 0) == 0) return true;
    error = std::string("cannot truncate partial file: ") + std::strerror(errno);
    return false;
  }
  bool Write(const char* data, size_t size) override {
    const uint64_t before = pos_;
    while (size > 0) {
      const ssize_t n = ::pwrite(fd_, data, size, static_cast<off_t>(pos_));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) {
        error = std::string("cannot write partial file: ") + std::strerror(errno);
        return false;
      }
      data += n;
      size -= static_cast<size_t>(n);
      pos_ += static_cast<uint64_t>(n);
    }
    // One crash point per 4 KiB boundary the partial file grew past: a count that depends
    // on the file's size, not on how the network cut it into chunks.
    for (uint64_t b = before / kCrashStride; b < pos_ / kCrashStride; ++b) {
      CrashPoint("download chunk on disk");
    }
    return true;
  }

 private:
  int fd_ = -1;
  uint64_t pos_ = 0;
};

/// State the callbacks of one attempt share.
struct Transfer {
  CURL* curl = nullptr;
  Sink* sink = nullptr;
  uint64_t offset = 0;  // bytes we asked the server to skip
  uint64_t base = 0;    // bytes before this response's first byte (offset, or 0 on restart)
  uint64_t received = 0;
  uint64_t expected_total = 0;  // for progress; 0 = unknown
  bool decided = false;         // first body byte seen: status known
  bool discard = false;         // an error page: not written
  bool bad_range = false;       // 206 that does not start where we asked
  bool sink_failed = false;
  bool stalled = false;       // no byte for options->stall_timeout_s
  std::string content_range;  // of the last response
  const FetchOptions* options = nullptr;
  curl_off_t last_now = -1;  // progress at last_change
  std::chrono::steady_clock::time_point last_change = std::chrono::steady_clock::now();
};

/// "bytes a-b/N" or "bytes */N": sets first (or -1) and total (or -1).
void ParseContentRange(const std::string& value, long long* first, long long* total) {
  *first = -1;
  *total = -1;
  if (value.rfind("bytes ", 0) != 0) return;
  const std::string spec = value.substr(6);
  const size_t slash = spec.find('/');
  if (slash == std::string::npos) return;
  if (spec[0] != '*') *first = std::atoll(spec.c_str());
  if (spec.compare(slash + 1, 1, "*") != 0) *total = std::atoll(spec.c_str() + slash + 1);
}

size_t HeaderCallback(char* data, size_t size, size_t count, void* user) {
  auto* t = static_cast<Transfer*>(user);
  std::string line(data, size * count);
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
  if (line.rfind("HTTP/", 0) == 0) {
    t->content_range.clear();  // a new response (redirect, 100-continue): forget the last
  } else if (line.size() > 14 && strncasecmp(line.c_str(), "content-range:", 14) == 0) {
    size_t start = 14;
    while (start < line.size() && line[start] == ' ') ++start;
    t->content_range = line.substr(start);
  }
  return size * count;
}

size_t WriteCallback(char* data, size_t size, size_t count, void* user) {
  auto* t = static_cast<Transfer*>(user);
  const size_t n = size * count;
  if (!t->decided) {
    t->decided = true;
    long status = 0;  // stays 0 for file://
    curl_easy_getinfo(t->curl, CURLINFO_RESPONSE_CODE, &status);
    if (status >= 300) {
      t->discard = true;
    } else if (status == 200 && t->offset > 0) {
      // The server ignored our Range: the body is the whole file, start the part over.
      t->base = 0;
      if (!t->sink->Restart()) {
        t->sink_failed = true;
        return 0;
      }
    } else if (status == 206) {
      long long first, total;
      ParseContentRange(t->content_range, &first, &total);
      if (first != static_cast<long long>(t->offset)) {
        t->bad_range = true;
        return 0;  // aborts the transfer
      }
    }
  }
  if (t->discard) return n;
  if (!t->sink->Write(data, n)) {
    t->sink_failed = true;
    return 0;
  }
  t->received += n;
  return n;
}

// Also the stall detector. CURLOPT_LOW_SPEED_TIME would do, but curl averages the speed over
// a window of several seconds, so a transfer that stops dead after a burst is noticed only
// seconds late; here the clock restarts at each byte.
int ProgressCallback(void* user, curl_off_t dltotal, curl_off_t dlnow, curl_off_t, curl_off_t) {
  auto* t = static_cast<Transfer*>(user);
  const auto now = std::chrono::steady_clock::now();
  if (dlnow != t->last_now) {
    t->last_now = dlnow;
    t->last_change = now;
  } else if (now - t->last_change > std::chrono::seconds(t->options->stall_timeout_s)) {
    t->stalled = true;
    return 1;  // aborts with CURLE_ABORTED_BY_CALLBACK
  }
  if (t->discard || !t->options->progress) return 0;
  uint64_t total = t->expected_total;
  if (total == 0 && dltotal > 0) total = t->base + static_cast<uint64_t>(dltotal);
  t->options->progress(t->base + static_cast<uint64_t>(dlnow), total);
  return 0;
}

/// What one attempt ended with.
struct Attempt {
  CURLcode code = CURLE_OK;
  long status = 0;  // HTTP status; 0 for file://
  std::string curl_error;
  std::string content_range;
  bool bad_range = false;
  bool sink_failed = false;
  bool stalled = false;
  uint64_t received = 0;

  bool http_error() const { return status >= 400; }
  bool ok() const { return code == CURLE_OK && !http_error(); }
  /// The file is not there: HTTP 404, or a file:// path that cannot be read.
  bool not_found() const { return status == 404 || code == CURLE_FILE_COULDNT_READ_FILE; }
  /// Worth another attempt: the network or the server may do better next time.
  bool transient() const {
    if (sink_failed) return false;
    if (bad_range || stalled) return true;
    if (http_error()) return status >= 500 || status == 429 || status == 408;
    switch (code) {
      case CURLE_COULDNT_RESOLVE_HOST:
      case CURLE_COULDNT_RESOLVE_PROXY:
      case CURLE_COULDNT_CONNECT:
      case CURLE_OPERATION_TIMEDOUT:
      case CURLE_PARTIAL_FILE:
      case CURLE_RECV_ERROR:
      case CURLE_SEND_ERROR:
      case CURLE_GOT_NOTHING:
      case CURLE_HTTP2:
      case CURLE_HTTP2_STREAM:
      case CURLE_SSL_CONNECT_ERROR:
        return true;
      default:
        return false;
    }
  }
  std::string Describe(const std::string& sink_error) const {
    if (sink_failed) return sink_error;
    if (bad_range) return "server answered a Range request with '" + content_range + "'";
    if (stalled) return "transfer stalled: " + curl_error;
    if (http_error()) return "HTTP " + std::to_string(status);
    return "curl error " + std::to_string(code) + ": " + curl_error;
  }
};

Attempt RunOnce(const std::string& url, uint64_t offset, uint64_t expected_total, Sink& sink,
                const FetchOptions& options) {
  GlobalInit();
  std::unique_ptr<CURL, void (*)(CURL*)> curl(curl_easy_init(), curl_easy_cleanup);
  if (!curl) throw Error("curl_easy_init failed");
  CURL* c = curl.get();
  Transfer t;
  t.curl = c;
  t.sink = &sink;
  t.offset = t.base = offset;
  t.expected_total = expected_total;
  t.options = &options;
  char errbuf[CURL_ERROR_SIZE] = {};
  curl_easy_setopt(c, CURLOPT_URL, url.c_str());
  curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https,file");
  curl_easy_setopt(c, CURLOPT_REDIR_PROTOCOLS_STR, "http,https");  // never redirect to file://
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L);
  curl_easy_setopt(c, CURLOPT_MAXREDIRS, 10L);
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);  // no SIGALRM for timeouts: we may run in threads
  curl_easy_setopt(c, CURLOPT_USERAGENT, "mlspaces");
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, errbuf);
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT, options.connect_timeout_s);
  curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, HeaderCallback);
  curl_easy_setopt(c, CURLOPT_HEADERDATA, &t);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, WriteCallback);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &t);
  curl_easy_setopt(c, CURLOPT_XFERINFOFUNCTION, ProgressCallback);
  curl_easy_setopt(c, CURLOPT_XFERINFODATA, &t);
  curl_easy_setopt(c, CURLOPT_NOPROGRESS, 0L);
  // CURLOPT_RANGE rather than CURLOPT_RESUME_FROM_LARGE: with the latter curl fails a 200
  // answer outright (CURLE_RANGE_ERROR), costing a request; we take the 200 body instead and
  // restart the part file in WriteCallback.
  const std::string range = std::to_string(offset) + "-";
  if (offset > 0) curl_easy_setopt(c, CURLOPT_RANGE, range.c_str());

  Attempt a;
  a.code = curl_easy_perform(c);
  curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &a.status);
  a.curl_error = errbuf[0] != '\0' ? errbuf : curl_easy_strerror(a.code);
  a.content_range = t.content_range;
  a.bad_range = t.bad_range;
  a.sink_failed = t.sink_failed;
  a.stalled = t.stalled;
  if (a.stalled) a.curl_error = "no data for " + std::to_string(options.stall_timeout_s) + " s";
  a.received = t.received;
  return a;
}

void Backoff(const FetchOptions& options, int attempt) {
  const double seconds = options.retry_delay_s * static_cast<double>(1u << std::min(attempt, 20));
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
}

std::string AfterAttempts(const std::string& message, int attempts) {
  return attempts > 1 ? message + " (after " + std::to_string(attempts) + " attempts)" : message;
}

uint64_t SizeOr0(const fs::path& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0;
}

}  // namespace

void FetchFile(const std::string& url, const fs::path& dest, const FetchExpect& expect,
               const FetchOptions& options) {
  fs::path part = dest;
  part += ".part";
  if (dest.has_parent_path()) CreateDirectories(dest.parent_path());
  bool retried_416 = false;
  for (int attempt = 0;; ++attempt) {
    uint64_t offset = SizeOr0(part);
    if (expect.size && offset > *expect.size) {  // a leftover of something else
      RemovePath(part);
      offset = 0;
    }
    if (expect.size && offset == *expect.size && offset > 0) break;  // complete: just verify
    Attempt a;
    std::string sink_error;
    {
      FileSink sink(part, offset);
      a = RunOnce(url, offset, expect.size.value_or(0), sink, options);
      sink_error = sink.error;
    }
    if (a.ok() && a.status == 206) {
      // A server may send less than the rest of the file; resume from there next time.
      long long first, total;
      ParseContentRange(a.content_range, &first, &total);
      if (total >= 0 && offset + a.received < static_cast<uint64_t>(total)) {
        a.code = CURLE_PARTIAL_FILE;
        a.curl_error = "server sent a shorter range than asked";
      }
    }
    if (a.ok()) break;
    if (a.status == 416) {
      // Nothing left to send from `offset`: the part is either complete or longer than the
      // file (a leftover of another version); decide from the total in "bytes */N".
      long long first, total;
      ParseContentRange(a.content_range, &first, &total);
      if (total >= 0 && static_cast<uint64_t>(total) == offset) break;
      RemovePath(part);
      if (!retried_416) {
        retried_416 = true;
        --attempt;  // a restart from 0, not a failure
        continue;
      }
    }
    if (a.bad_range) RemovePath(part);
    if (!a.transient() || attempt >= options.retries) {
      throw FetchError(AfterAttempts(a.Describe(sink_error), attempt + 1), url, a.not_found());
    }
    Backoff(options, attempt);
  }

  const FileDigest digest = Sha256File(part);
  if (expect.size && digest.size != *expect.size) {
    RemovePath(part);
    throw Error("size mismatch: downloaded " + std::to_string(digest.size) + " bytes, expected " +
                    std::to_string(*expect.size),
                url);
  }
  if (!expect.sha256.empty() && digest.sha256 != expect.sha256) {
    RemovePath(part);
    throw Error("SHA-256 mismatch: downloaded " + digest.sha256 + ", expected " + expect.sha256,
                url);
  }
  if (options.sync) FsyncPath(part, false, part.string());
  if (::rename(part.c_str(), dest.c_str()) != 0) {
    throw Error(std::string("cannot rename into place: ") + std::strerror(errno), dest.string());
  }
  CrashPoint("download renamed into place");
  if (options.sync) {
    FsyncPath(dest.has_parent_path() ? dest.parent_path() : fs::path("."), true, dest.string());
  }
}

std::string FetchToString(const std::string& url, const FetchOptions& options) {
  for (int attempt = 0;; ++attempt) {
    StringSink sink;
    const Attempt a = RunOnce(url, 0, 0, sink, options);
    if (a.ok()) return std::move(sink.text);
    if (!a.transient() || attempt >= options.retries) {
      throw FetchError(AfterAttempts(a.Describe(sink.error), attempt + 1), url, a.not_found());
    }
    Backoff(options, attempt);
  }
}

std::string JoinUrl(const std::string& base, const std::string& relative) {
  size_t end = base.size();
  while (end > 0 && base[end - 1] == '/') --end;
  size_t start = 0;
  while (start < relative.size() && relative[start] == '/') ++start;
  return base.substr(0, end) + "/" + relative.substr(start);
}

std::string FileUrl(const fs::path& path) {
  const std::string abs = fs::absolute(path).lexically_normal().generic_string();
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out = "file://";
  for (unsigned char ch : abs) {
    if ((ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
        ch == '/' || ch == '-' || ch == '.' || ch == '_' || ch == '~') {
      out += static_cast<char>(ch);
    } else {
      out += '%';
      out += kHex[ch >> 4];
      out += kHex[ch & 15];
    }
  }
  return out;
}

}  // namespace mlspaces
