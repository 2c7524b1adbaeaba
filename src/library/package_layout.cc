// Names of the files in an installed package folder (include/mlspaces/library/package_layout.h).
#include "mlspaces/library/package_layout.h"

#include <filesystem>

namespace mlspaces {
namespace fs = std::filesystem;

std::string ArchiveStem(const std::string& archive) {
  constexpr std::string_view kTarZst = ".tar.zst";
  if (archive.size() > kTarZst.size() && archive.ends_with(kTarZst)) {
    return archive.substr(0, archive.size() - kTarZst.size());
  }
  return fs::path(archive).stem().string();
}

std::string GraspShardMember(const std::string& archive) {
  return std::string(kGraspShardDir) + "/" + ArchiveStem(archive) +
         std::string(kGraspShardExtension);
}

std::string ExtractFlagName(const std::string& archive) {
  std::string name = archive;
  for (size_t pos = 0; (pos = name.find('/', pos)) != std::string::npos; pos += 2) {
    name.replace(pos, 1, "__");
  }
  return "." + name + "_complete_extract";
}

}  // namespace mlspaces
