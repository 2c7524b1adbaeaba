// SHA-256 (OpenSSL's libcrypto) for package manifests and download checks. A Sha256 object
// is used from one thread at a time; the free functions are safe from several threads.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace mlspaces {

/// Incremental SHA-256.
class MLSPACES_API Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(const void* data, size_t size);
  void Update(std::string_view data) { Update(data.data(), data.size()); }
  /// Lowercase hex of the digest; the object cannot be updated afterwards.
  std::string HexDigest();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Hex SHA-256 of bytes.
MLSPACES_API std::string Sha256Hex(std::string_view data);

/// The hex SHA-256 and size of a file.
struct MLSPACES_API FileDigest {
  std::string sha256;
  uint64_t size = 0;
};
/// Hex SHA-256 and size of a file, read in large blocks. @throws Error naming the file.
MLSPACES_API FileDigest Sha256File(const std::filesystem::path& path);

}  // namespace mlspaces
