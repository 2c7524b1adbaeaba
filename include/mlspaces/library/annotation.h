// Asset annotations: a library's per-asset metadata JSON merged with its optional NPZ arrays.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/core/npy.h"

namespace mlspaces {

/// The metadata of one asset. `json` is the metadata file as written (key order kept).
/// `arrays` are the NPZ's arrays, each at the JSON pointer its '/'-delimited key names
/// ("description_short/clip" -> "/description_short/clip"); they are not copied into `json`.
// NOLINTNEXTLINE(bugprone-exception-escape): flags the implicit special members
struct MLSPACES_API Annotation {
  std::string uid;
  std::string library;
  Json json;
  std::vector<std::pair<std::string, NpyArray>> arrays;  ///< (JSON pointer, array)

  /// The array at a JSON pointer, or nullptr.
  const NpyArray* FindArray(std::string_view pointer) const;
  /// `json` with every array merged in as nested JSON lists (what `mlspaces meta` prints).
  Json ToJson() const;
};

/// Loads an annotation from a metadata JSON file and an optional NPZ. The NPZ's keys are
/// '/'-paths into the tree; intermediate objects are created as needed; a key whose final
/// name already exists, or whose path crosses a non-object, is an error ("Key {k} from npz
/// metadata already exists in metadata for uid={uid}"). @throws Error naming the file.
MLSPACES_API Annotation LoadAnnotation(const std::string& uid, const std::string& library,
                                       const std::filesystem::path& metadata_json,
                                       const std::filesystem::path* metadata_npz);

}  // namespace mlspaces
