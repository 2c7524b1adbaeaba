// `mlspaces validate`: deep checks of a library folder.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/core/diagnostics.h"

namespace mlspaces {

/// One problem: path = the file, field = a JSON pointer, zip member or "line N" (may be
/// empty); printed as "file: /json/pointer: message".
using Problem = Diagnostic;

/// Validates the asset index and/or grasp index in `dir` (at least one must exist):
/// every entry resolves to a file; index `uid` equals its key; metadata JSON parses and its
/// known fields have the right types; NPZ metadata loads and does not collide with JSON
/// keys; a computed metadata file's kComputedFromKey record (asset_index.h) matches its source
/// files; grasp files are (N,4,4) with finite values, orthonormal right-handed rotations and a
/// last row of 0 0 0 1; grasp UIDs exist in a sibling asset index when there is one.
/// Never throws for bad content: every problem is returned. (Compiling each asset is the sim
/// layer's CompileLibraryAssets, sim/compute_metadata.h.)
MLSPACES_API std::vector<Problem> ValidateLibrary(const std::filesystem::path& dir);

}  // namespace mlspaces
