// Internal to the packed-store reader: read-only file mappings and header checks.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace mlspaces::packed {

/// A whole file mapped read-only (MAP_SHARED), unmapped on destruction.
class Mapping {
 public:
  Mapping() = default;
  ~Mapping();
  Mapping(const Mapping&) = delete;
  Mapping& operator=(const Mapping&) = delete;

  /// Maps a whole file read-only. `missing` is the message for a file that does not exist;
  /// `advice` is passed to madvise (MADV_NORMAL: none). @throws Error naming the path for a
  /// file that cannot be opened or mapped, is not a regular file, or is shorter than a
  /// 64-byte header.
  void Open(const std::filesystem::path& path, const std::string& missing, int advice);

  const uint8_t* data() const { return data_; }
  uint64_t size() const { return size_; }

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

/// Checks the magic and format version of a 64-byte header. @throws Error naming `path`.
void CheckMagic(const uint8_t* p, const char (&magic)[8], const std::filesystem::path& path);

}  // namespace mlspaces::packed
