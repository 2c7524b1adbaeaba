// Links mlspaces::mlspaces: locates a UID, compiles it with MuJoCo (the sim layer) and finds
// the installed robot model (the datagen layer).
#include <filesystem>
#include <iostream>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/asset_facts.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: consumer ASSET_LIBRARY_DIR UID\n";
    return 2;
  }
  try {
    mlspaces::Registry registry;
    registry.RegisterAssetLibrary("lib", argv[1]);
    const mlspaces::AssetLocation where = registry.LocateOrThrow(argv[2]);
    const mlspaces::sim::AssetFacts facts = mlspaces::sim::ComputeAssetFacts(where.mjcf_path);
    std::cout << "mass " << facts.mass << "\n";
    const std::filesystem::path robot =
        mlspaces::datagen::RobotsDir() / "franka_droid" / "franka_droid.xml";
    std::cout << "robot " << (std::filesystem::is_regular_file(robot) ? "found" : "missing")
              << " at " << robot.string() << "\n";
  } catch (const mlspaces::Error& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
