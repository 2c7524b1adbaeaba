// Links mlspaces::library alone: registers an asset library and locates a UID.
#include <iostream>

#include "mlspaces/core/error.h"
#include "mlspaces/library/registry.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: consumer_library ASSET_LIBRARY_DIR UID\n";
    return 2;
  }
  try {
    mlspaces::Registry registry;
    registry.RegisterAssetLibrary("lib", argv[1]);
    const mlspaces::AssetLocation where = registry.LocateOrThrow(argv[2]);
    std::cout << "located " << argv[2] << " in " << where.library << ": "
              << where.mjcf_path.filename().string() << "\n";
  } catch (const mlspaces::Error& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
