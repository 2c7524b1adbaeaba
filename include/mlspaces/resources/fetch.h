// Downloads over http(s):// and file:// (libcurl), resumable and verified. Safe to call from
// several threads for different destinations (the installer's download workers do).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>

#include "mlspaces/core/error.h"

namespace mlspaces {

// =============================================================================================
// Errors and options

/// A download that failed after its last attempt. `not_found()` tells a plain "there is no
/// such file" (HTTP 404, a missing file:// file) from every other failure, for callers that
/// probe optional files.
class MLSPACES_API FetchError : public Error {
 public:
  FetchError(std::string message, std::string url, bool not_found)
      : Error(std::move(message), std::move(url)), not_found_(not_found) {}
  bool not_found() const { return not_found_; }

 private:
  bool not_found_;
};

struct MLSPACES_API FetchOptions {
  /// Extra attempts after a transient failure (connection refused/reset, timeout, short
  /// transfer, HTTP 5xx/429). Each retry resumes the partial file with an HTTP Range request.
  int retries = 3;
  /// Seconds between attempts (doubles each time).
  double retry_delay_s = 0.2;
  /// Abort (and retry) a transfer that receives no byte for this many seconds.
  long stall_timeout_s = 30;
  long connect_timeout_s = 10;
  /// fsync the finished file and its folder before returning. Off for downloads that are
  /// re-checked against their SHA-256 before use anyway (the installer's archives).
  bool sync = true;
  /// Called with (bytes so far, total or 0 when unknown) on the thread that called FetchFile;
  /// may be empty.
  std::function<void(uint64_t, uint64_t)> progress;
};

/// What a download is checked against: the manifest's size and SHA-256 (empty = unchecked).
struct MLSPACES_API FetchExpect {
  std::optional<uint64_t> size;
  std::string sha256;
};

// =============================================================================================
// Downloads

/// Downloads `url` into `dest`: bytes go to `dest`.part (kept between attempts and runs, so a
/// later call resumes it with a Range request; a server that ignores Range restarts it), and
/// when complete the size and SHA-256 are checked and the file is renamed to `dest`. A
/// mismatch deletes the partial file and throws. HTTP 4xx (other than 429) is not retried.
/// @throws Error naming the URL (and the HTTP status or curl error) after the last attempt.
MLSPACES_API void FetchFile(const std::string& url, const std::filesystem::path& dest,
                            const FetchExpect& expect = {}, const FetchOptions& options = {});

/// Downloads a small file into memory (manifests); same retries. @throws Error naming the URL.
MLSPACES_API std::string FetchToString(const std::string& url, const FetchOptions& options = {});

// =============================================================================================
// URLs

/// Joins a base URL and a relative path with exactly one '/'.
MLSPACES_API std::string JoinUrl(const std::string& base, const std::string& relative);

/// file:// URL of a local path (absolute, percent-encoded where needed).
MLSPACES_API std::string FileUrl(const std::filesystem::path& path);

}  // namespace mlspaces
