// `mlspaces index-assets DIR --compute-metadata`: per asset, compile the object alone and write
// <uid>_computed.json (mass, boundingBox, aabb, and what it was computed from), then write the
// index pointing at them; and `mlspaces validate`'s compile check of every indexed asset.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/sim/asset_facts.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::sim {

/// One asset that failed (it is left out of the index): uid, and the file, field ("line N,
/// element <tag>", a JSON pointer, ...) and message of the error; ToString() is its one line.
using AssetFailure = Diagnostic;

struct MLSPACES_API ComputeMetadataReport {
  IndexReport index;                   ///< the index written (count, output, warnings)
  size_t computed = 0;                 ///< <uid>_computed.json files written now
  size_t reused = 0;                   ///< existing computed files kept (no --overwrite)
  std::vector<AssetFailure> failures;  ///< sorted by UID; non-empty -> exit code 1
  /// Computed files of failed assets that mlspaces had written earlier, deleted (sorted).
  std::vector<std::filesystem::path> removed;
};

struct MLSPACES_API ComputeMetadataOptions {
  int threads = 0;  ///< worker threads; 0 = all cores
  /// Called after each asset with (done, total), from worker threads (serialised).
  std::function<void(size_t, size_t)> progress;
};

/// The computed metadata: `source` in its key order, plus "mass" and "boundingBox"
/// ({"x","y","z"}) only when absent, plus "aabb" ({"min":[x,y,z],"max":[x,y,z]}, always set).
MLSPACES_API Json MakeComputedMetadata(const Json& source, const AssetFacts& facts);

/// The files a composed asset's physics depends on: its MJCF, the files it <include>s and its
/// <model> files (read again with pugixml), and the mesh and height-field files of its spec
/// that exist; absolute, sorted, without duplicates.
MLSPACES_API std::vector<std::filesystem::path> AssetSourceFiles(MjcfComposer& composer);

/// Refuses to replace an existing index unless options.overwrite (Error "<output> already
/// exists. Use --overwrite to overwrite."); scans `dir` like BuildAssetIndex (duplicate UIDs
/// and missing metadata are errors before any work). Then, in parallel, per asset:
/// - no <uid>_computed.json, or options.overwrite, or one whose kComputedFromKey record no
///   longer matches its sources: composes and compiles the asset alone (physics only),
///   computes its facts and writes the computed JSON (MakeComputedMetadata plus the record of
///   AssetSourceFiles and the metadata JSON) atomically;
/// - a computed file whose record matches: reused as it is, without compiling;
/// - a computed file without a record (the original's, hand-made): compiled to check the
///   asset, and reused unchanged when it compiles.
/// An asset that fails (bad XML or mesh, not one body, metadata JSON malformed or not an
/// object, computed file unreadable) is recorded in `failures` and left out of the index; its
/// computed file is deleted when it carries a record (mlspaces wrote it), else left alone.
/// Finally writes the index of the other assets, each pointing at its computed file.
/// @throws Error for the index-level problems above.
MLSPACES_API ComputeMetadataReport ComputeAssetMetadata(const std::filesystem::path& dir,
                                                        const AssetIndexOptions& options,
                                                        const ComputeMetadataOptions& compute = {});

/// `mlspaces validate`'s compile check: composes and compiles (fully, textures included) the
/// MJCF of every entry of `dir`/assets_index.json whose object_path is a file, in parallel.
/// One problem per asset that fails, in UID order: path and field of MuJoCo's error (the
/// file and line at fault), message "asset '<uid>' does not compile: <MuJoCo's message>".
/// No problems when the index is missing or unreadable (ValidateLibrary reports that).
MLSPACES_API std::vector<Diagnostic> CompileLibraryAssets(
    const std::filesystem::path& dir, const ComputeMetadataOptions& compute = {});

}  // namespace mlspaces::sim
