// The install (assets) dir of built-in data: where `mlspaces install` puts MolmoSpaces' data
// (<assets>/<type>/<source>, spec section 2.3) and where every reader looks for it. It lives
// in the library layer so that the layers above resources (datagen's robots) find it too.
//
// Everything here returns values; nothing keeps a reference to its arguments.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <optional>

namespace mlspaces {

/// The default install dir when MLSPACES_ASSETS_DIR is unset: ~/.cache/mlspaces/assets.
MLSPACES_API std::filesystem::path DefaultAssetsDir();

/// Where an assets dir came from.
enum class AssetsDirOrigin { kGiven, kEnvironment, kDefault };

struct MLSPACES_API AssetsDirChoice {
  std::filesystem::path dir;
  AssetsDirOrigin origin = AssetsDirOrigin::kDefault;
};

/// The one order for the install (assets) dir, used by every command and library: `given`
/// when it has a value (a --assets-dir flag, a libraries YAML's assets_dir), else
/// MLSPACES_ASSETS_DIR when set and non-empty, else DefaultAssetsDir(). The path is returned
/// as it was given (not made absolute).
MLSPACES_API AssetsDirChoice
ResolveAssetsDir(const std::optional<std::filesystem::path>& given = {});

}  // namespace mlspaces
