// Asset libraries: assets_index.json and building it from a folder. How the schema and the
// bytes written match MolmoSpaces': docs/formats.md ("Files we match exactly").
#pragma once

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/export.h"

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace mlspaces {

/// One entry of assets_index.json. Paths are relative to the library root, '/'-separated.
struct MLSPACES_API AssetEntry {
  std::string uid;
  std::string object_path;
  std::string metadata_path;
  std::optional<std::string> metadata_npz_path;  ///< null in the file when absent
  bool operator==(const AssetEntry&) const = default;
};

/// A parsed assets_index.json: UID (the dict key) -> entry, sorted by UID.
struct MLSPACES_API AssetIndex {
  std::map<std::string, AssetEntry> entries;

  /// Parses assets_index.json: an object of object entries, string paths,
  /// `metadata_npz_path` present and string-or-null; extra keys in an entry are ignored.
  /// Lookups use the dict key; an entry whose `uid` differs from its key is accepted and
  /// reported by validate.
  /// @throws Error with the file and JSON pointer of the bad field.
  static AssetIndex Load(const std::filesystem::path& index_file);
  /// Keys sorted, indent 4, no trailing newline (byte-identical to MolmoSpaces').
  std::string Serialize() const;
};

struct MLSPACES_API AssetIndexOptions {
  std::filesystem::path output;            ///< default: <dir>/assets_index.json
  bool overwrite = false;                  ///< replace an existing output
  bool suppress_missing_metadata = false;  ///< skip XMLs without <uid>.json, with a warning
};

/// What building an index found and wrote.
struct MLSPACES_API IndexReport {
  /// Files skipped, one warning each (severity kWarning): path = the skipped file, uid = its
  /// UID, message = what is wrong. `index-assets` prints each as IndexWarningLine.
  std::vector<Diagnostic> warnings;
  size_t count = 0;   ///< assets (or grasp files) written
  size_t robots = 0;  ///< index-grasps: robots with pickup grasps
  std::filesystem::path output;
};

/// A warning of IndexReport as `index-assets` prints it: "Warning: <message> Skipping."
/// (the message names the files, so the line is the same text as before Diagnostic).
MLSPACES_API std::string IndexWarningLine(const Diagnostic& warning);

/// Scans `dir` recursively (sorted, symlinked folders not followed) for `<uid>.xml` with a
/// sibling `<uid>.json` (and optional `<uid>.npz`), and builds the index in memory.
/// When `<uid>_computed.json` exists and `use_computed` is set, the entry points at it.
/// @throws Error for a missing metadata JSON (unless suppressed) or a duplicate UID,
/// naming both files.
MLSPACES_API AssetIndex BuildAssetIndex(const std::filesystem::path& dir,
                                        const AssetIndexOptions& options, IndexReport* report,
                                        bool use_computed = false);

/// The index file `index-assets` writes: options.output resolved, or <dir>/assets_index.json.
/// @throws Error "<output> already exists. Use --overwrite to overwrite." when it exists and
/// options.overwrite is false (checked before any work).
MLSPACES_API std::filesystem::path AssetIndexOutputPath(const std::filesystem::path& dir,
                                                        const AssetIndexOptions& options);

/// `mlspaces index-assets` without --compute-metadata: refuses to replace an existing output
/// unless `overwrite`, builds, and writes atomically. @throws Error.
MLSPACES_API IndexReport WriteAssetIndex(const std::filesystem::path& dir,
                                         const AssetIndexOptions& options);

}  // namespace mlspaces
