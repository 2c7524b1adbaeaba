// Shared by the fuzz targets: a scratch folder for parsers that read files, and the rule that
// a parser may reject input only with mlspaces::Error (anything else escaping is a bug the
// fuzzer reports as a crash).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace mlspaces::fuzz {

/// A private folder under $TMPDIR (or /tmp), made once per process and removed with what is in
/// it when the process exits normally (libFuzzer exits so after its runs; a crash keeps it).
inline const std::filesystem::path& ScratchDir() {
  struct Scratch {
    std::filesystem::path path;
    Scratch() {
      const char* tmp = std::getenv("TMPDIR");
      std::string pattern =
          std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") + "/mlspaces-fuzz-XXXXXX";
      if (::mkdtemp(pattern.data()) == nullptr) {
        std::perror("mkdtemp");
        std::abort();
      }
      path = pattern;
    }
    ~Scratch() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;
  };
  static const Scratch dir;
  return dir.path;
}

/// Writes bytes to a file (replacing it); aborts on an I/O error (not the parser's fault).
inline void WriteBytes(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::perror(path.c_str());
    std::abort();
  }
}

}  // namespace mlspaces::fuzz
