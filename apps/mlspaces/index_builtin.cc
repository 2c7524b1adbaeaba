// mlspaces index-builtin [NAME...]: builds our UID index for object sources installed by
// MolmoSpaces' own resource manager (tries file, no stores), so lookups never scan them.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/legacy_source.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::cli {
namespace {
namespace fs = std::filesystem;

struct IndexBuiltinFlags {
  std::vector<std::string> names;
  std::string assets_dir;
};

int Run(const IndexBuiltinFlags& flags) {
  fs::path assets;
  if (!flags.assets_dir.empty()) {
    assets = flags.assets_dir;
  } else if (auto env = Registry::AssetsDirFromEnv()) {
    assets = *env;
  } else {
    assets = DefaultAssetsDir();
  }
  const fs::path objects = assets / "objects";
  const std::string tries_file(kOriginalTriesFile);

  // Which sources: the NAMEs given (each must be a MolmoSpaces-format source or a package),
  // else every folder or link under <assets>/objects.
  std::vector<std::string> names;
  const bool named = !flags.names.empty();
  if (named) {
    for (const std::string& n : flags.names) {
      if (n.empty() || n == "." || n == ".." || n.find('/') != std::string::npos) {
        throw UsageError("bad source name '" + n + "' (a folder name under <assets>/objects)");
      }
      const fs::path root = objects / n;
      std::error_code ec;
      if (!fs::is_directory(root, ec)) {
        throw Error("no such source (not a folder, or a dangling link)", root.string());
      }
      if (!IsFile(root / std::string(kUidIndexFile)) && !IsFile(root / tries_file)) {
        throw Error("not a MolmoSpaces-format source: no " + tries_file, root.string());
      }
      names.push_back(n);
    }
  } else {
    std::error_code ec;
    if (!fs::is_directory(objects, ec)) {
      throw Error("no objects folder: nothing is installed here (set --assets-dir or "
                  "MLSPACES_ASSETS_DIR)",
                  objects.string());
    }
    for (const auto& entry : fs::directory_iterator(objects, ec)) {
      std::error_code dir_ec;
      if (fs::is_directory(entry.path(), dir_ec)) names.push_back(entry.path().filename().string());
    }
    if (ec) throw Error("cannot list: " + ec.message(), objects.string());
    std::sort(names.begin(), names.end());
  }

  for (const std::string& n : names) {
    const fs::path root = objects / n;
    if (IsFile(root / std::string(kUidIndexFile))) {
      std::printf("objects/%s: already an mlspaces package, skipped\n", n.c_str());
      continue;
    }
    if (!IsFile(root / tries_file)) {
      std::printf("objects/%s: no %s (not a MolmoSpaces-format source), skipped\n", n.c_str(),
                  tries_file.c_str());
      continue;
    }
    std::error_code ec;
    const fs::path version_dir = fs::canonical(root, ec);
    if (ec) throw Error("cannot resolve: " + ec.message(), root.string());
    const LegacyIndexReport report = BuildLegacyIndex(version_dir, n);
    std::printf("objects/%s: %zu assets in %zu archives indexed\n", n.c_str(), report.assets,
                report.archives);
    std::fflush(stdout);
    for (const std::string& w : report.warnings) Warn("objects/" + n + ": " + w);
  }
  if (names.empty()) std::printf("no sources under %s\n", objects.c_str());
  return 0;
}

}  // namespace

void AddIndexBuiltin(CLI::App& app, Action& action) {
  auto flags = std::make_shared<IndexBuiltinFlags>();
  CLI::App* sub = app.add_subcommand(
      "index-builtin",
      "Build the UID index of object sources installed by MolmoSpaces' own resource manager "
      "(from their tries file), so lookups on them never scan folders");
  sub->add_option("NAME", flags->names,
                  "Sources under <assets>/objects (default: every one with a tries file)");
  sub->add_option("--assets-dir", flags->assets_dir,
                  "Install dir (default MLSPACES_ASSETS_DIR, else ~/.cache/mlspaces/assets)");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
