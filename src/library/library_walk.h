// Sorted recursive folder walk shared by the index builders (internal to mlspaces_core).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace mlspaces::internal {

/// One folder entry, typed from readdir's d_type where possible (no stat per file).
struct WalkEntry {
  enum class Kind : uint8_t { kFile, kDir, kSymlink, kOther };
  std::string name;
  Kind kind = Kind::kOther;
};

/// A folder being walked: its path relative to the root ('/'-separated, "" for the root),
/// its absolute path and its entries sorted by name (code point order).
class WalkDir {
 public:
  std::string rel;
  std::string abs;
  std::vector<WalkEntry> entries;

  /// The path of a child relative to the walk root.
  std::string RelChild(std::string_view name) const;
  /// The absolute path of a child.
  std::string AbsChild(std::string_view name) const;
  /// Whether `name` is in this folder and is a file or a symlink to one (Python's exists()
  /// for files, without stat-ing every entry).
  bool HasFile(std::string_view name) const;
};

/// Visits every non-folder entry under `root` in the order Python's sorted(rglob()) gives
/// (component-wise code point order). Symlinked folders are neither followed nor visited.
/// `visit(dir, entry)`. @throws Error if `root` is missing, not a folder, or unreadable.
void WalkSorted(const std::filesystem::path& root,
                const std::function<void(const WalkDir&, const WalkEntry&)>& visit);

/// Escapes a string as a JSON string literal the way pydantic (serde_json) writes it:
/// UTF-8 kept as is, '"', '\\' and control characters escaped.
void AppendJsonString(std::string& out, std::string_view s);

/// Resolves a path as the original's Path.resolve() does: absolute, symlinks resolved as far
/// as the path exists.
std::filesystem::path ResolvePath(const std::filesystem::path& p);

/// Where an index writer writes: `output` resolved, or `root`/`default_name` when `output` is
/// empty. @throws Error if that file exists and `overwrite` is false.
std::filesystem::path IndexOutputPath(const std::filesystem::path& root,
                                      const std::filesystem::path& output,
                                      std::string_view default_name, bool overwrite);

}  // namespace mlspaces::internal
