// The install (assets) dir: MLSPACES_ASSETS_DIR and its default.
#include "mlspaces/library/assets_dir.h"

#include <cstdlib>
#include <string>

namespace mlspaces {
namespace fs = std::filesystem;

fs::path DefaultAssetsDir() {
  const char* home = std::getenv("HOME");
  const fs::path dir = home == nullptr || *home == 0 ? fs::path("/tmp") : fs::path(home);
  return dir / ".cache" / "mlspaces" / "assets";
}

AssetsDirChoice ResolveAssetsDir(const std::optional<fs::path>& given) {
  if (given) return {*given, AssetsDirOrigin::kGiven};
  const char* env = std::getenv("MLSPACES_ASSETS_DIR");
  if (env != nullptr && *env != 0) return {fs::path(env), AssetsDirOrigin::kEnvironment};
  return {DefaultAssetsDir(), AssetsDirOrigin::kDefault};
}

}  // namespace mlspaces
