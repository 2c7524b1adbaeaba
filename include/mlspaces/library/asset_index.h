// Asset libraries: assets_index.json and building it from a folder. How the schema and the
// bytes written match MolmoSpaces': docs/formats.md ("Files we match exactly").
#pragma once

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/export.h"

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/json.h"

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
/// @throws Error for a missing metadata JSON (unless suppressed), a duplicate UID (naming
/// both files), or a `<uid>.xml` that is a broken symbolic link.
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

// ---- What a computed metadata file was computed from (docs/formats.md) --------------------

/// The key of the record in each <uid>_computed.json mlspaces writes:
/// {"hash": "xxh128", "files": {source path relative to the computed file's folder: digest}}.
/// A computed file with this key was written by mlspaces; one without it (the original's,
/// or hand-made) has no record to check.
inline constexpr std::string_view kComputedFromKey = "computed_from";

/// XXH3-128 of a file's bytes as 32 lowercase hex digits (what `xxh128sum` prints).
/// @throws Error naming the file when it cannot be read.
MLSPACES_API std::string SourceFileHash(const std::filesystem::path& file);

/// The record for `sources` (absolute paths), relative to `computed_file`'s folder, sorted.
/// @throws Error naming a source that cannot be read.
MLSPACES_API Json ComputedFromRecord(const std::filesystem::path& computed_file,
                                     const std::vector<std::filesystem::path>& sources);

/// Checks the record of `computed` (the parsed `computed_file`) against the files now: one
/// problem per source changed or missing, or for a malformed record (path = computed_file,
/// field = the record's JSON pointer). nullopt when there is no record (nothing to check).
MLSPACES_API std::optional<std::vector<Diagnostic>> CheckComputedFrom(
    const std::filesystem::path& computed_file, const Json& computed);

}  // namespace mlspaces
