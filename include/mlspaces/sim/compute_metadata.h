// `mlspaces index-assets DIR --compute-metadata`: per asset, compile the object alone and write
// <uid>_computed.json (mass, boundingBox, aabb), then write the index pointing at them.
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

namespace mlspaces::sim {

/// One asset that could not be computed (the run goes on without it): uid, and message, one
/// line: "<file>: line N, element <tag>: <message>" (path and field empty).
using AssetFailure = Diagnostic;

struct MLSPACES_API ComputeMetadataReport {
  IndexReport index;                   ///< the index written (count, output, warnings)
  size_t computed = 0;                 ///< <uid>_computed.json files written now
  size_t reused = 0;                   ///< existing computed files kept (no --overwrite)
  std::vector<AssetFailure> failures;  ///< sorted by UID; non-empty -> exit code 1
};

struct MLSPACES_API ComputeMetadataOptions {
  int threads = 0;  ///< worker threads; 0 = all cores
  /// Called after each asset with (done, total), from worker threads (serialised).
  std::function<void(size_t, size_t)> progress;
};

/// The computed metadata: `source` in its key order, plus "mass" and "boundingBox"
/// ({"x","y","z"}) only when absent, plus "aabb" ({"min":[x,y,z],"max":[x,y,z]}, always set).
MLSPACES_API Json MakeComputedMetadata(const Json& source, const AssetFacts& facts);

/// Refuses to replace an existing index unless options.overwrite (Error "<output> already
/// exists. Use --overwrite to overwrite."); scans `dir` like BuildAssetIndex (duplicate UIDs
/// and missing metadata are errors before any work). Then, in parallel, for each asset whose
/// <uid>_computed.json is missing (or every asset with options.overwrite): composes and
/// compiles the asset alone, computes its facts and writes the computed JSON atomically. An
/// asset that fails (bad XML, missing mesh, not one body, bad metadata JSON) is recorded in
/// `failures` and skipped. Finally writes the index with use_computed = true, so every
/// computed file present, old or new, is referenced. @throws Error for the index-level
/// problems above.
MLSPACES_API ComputeMetadataReport ComputeAssetMetadata(const std::filesystem::path& dir,
                                                        const AssetIndexOptions& options,
                                                        const ComputeMetadataOptions& compute = {});

}  // namespace mlspaces::sim
