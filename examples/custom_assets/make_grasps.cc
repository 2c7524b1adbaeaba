// Writes the example's grasp file (STORED .npz, like np.savez) with mlspaces' own writer.
//
//   make_example_grasps OUT.npz          write it
//   make_example_grasps --check FILE     regenerate into a temp file and compare bytes with
//                                        FILE; exit 1 when they differ
#include <unistd.h>
#include <cstdio>
#include <filesystem>
#include <string>

#include "example_grasps.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/npz.h"

namespace {

int Usage() {
  std::fprintf(stderr, "usage: make_example_grasps OUT.npz | --check FILE\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  try {
    if (argc == 2 && std::string(argv[1]) != "--check") {
      mlspaces::WriteNpz(argv[1], mlspaces::examples::RedBlockGrasps());
      std::printf("Wrote %s\n", argv[1]);
      return 0;
    }
    if (argc != 3 || std::string(argv[1]) != "--check") return Usage();
    fs::path tmp = fs::temp_directory_path() /
                   ("mlspaces_example_grasps_" + std::to_string(::getpid()) + ".npz");
    mlspaces::WriteNpz(tmp, mlspaces::examples::RedBlockGrasps());
    std::string fresh = mlspaces::ReadFile(tmp);
    std::error_code ec;
    fs::remove(tmp, ec);
    if (fresh != mlspaces::ReadFile(argv[2])) {
      std::fprintf(stderr, "%s is out of date: regenerate it with make_example_grasps\n", argv[2]);
      return 1;
    }
    std::printf("%s: up to date\n", argv[2]);
    return 0;
  } catch (const mlspaces::Error& e) {
    std::fprintf(stderr, "make_example_grasps: error: %s\n", e.what());
    return 1;
  }
}
