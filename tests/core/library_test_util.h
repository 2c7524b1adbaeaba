// Helpers for the library index / validate tests: temp folders and small files.
#pragma once

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace mlspaces::testing {

/// A fresh folder under temp_directory_path(), removed with everything in it on destruction.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("mlspaces_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
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

/// Writes `text` to `path`, creating parent folders.
inline void WriteText(const std::filesystem::path& path, std::string_view text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  ASSERT_TRUE(out.good()) << path;
}

/// Every file name under `dir` (recursive, relative, '/'-separated).
inline std::set<std::string> ListFiles(const std::filesystem::path& dir) {
  std::set<std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_directory()) out.insert(e.path().lexically_relative(dir).generic_string());
  }
  return out;
}

/// Copies the bundled example library (examples/custom_assets/asset_library) into `dir`.
inline std::filesystem::path CopyExampleLibrary(const std::filesystem::path& dir) {
  std::filesystem::path dst = dir / "asset_library";
  std::filesystem::copy(std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" /
                            "asset_library",
                        dst, std::filesystem::copy_options::recursive);
  return dst;
}

/// The example library in the source tree.
inline std::filesystem::path ExampleLibrary() {
  return std::filesystem::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "asset_library";
}

/// Minimal metadata JSON for a generated asset.
inline std::string MinimalMetadata(const std::string& uid) {
  return "{\n    \"assetId\": \"" + uid + "\",\n    \"category\": \"block\",\n"
         "    \"synset\": \"block.n.01\"\n}";
}

}  // namespace mlspaces::testing
