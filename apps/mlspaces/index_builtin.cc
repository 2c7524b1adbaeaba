// mlspaces index-builtin [NAME...]: builds our UID index for object sources installed by
// MolmoSpaces' own resource manager (tries file, no stores), so lookups never scan them, and
// converts objathor_metadata into our metadata and CLIP stores (resources/objathor.h).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/resources/legacy_source.h"
#include "mlspaces/resources/objathor.h"
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
  std::optional<fs::path> given;
  if (!flags.assets_dir.empty()) given = fs::path(flags.assets_dir);
  const fs::path assets = ResolveAssetsDir(given).dir;
  // Which sources: the NAMEs given (each must be a MolmoSpaces-format source or a package),
  // else every folder or link under <assets>/objects.
  const std::vector<ObjectSource> sources = FindObjectSources(assets, flags.names);
  for (const ObjectSource& source : sources) {
    const char* n = source.name.c_str();
    if (source.name == kObjathorLibrary) {  // annotations, not MJCFs: our metadata store
      if (std::optional<ObjathorLocation> where = FindObjathor(assets)) {
        const ObjathorReport report = ConvertObjathor(*where);
        std::printf("objects/%s: %zu annotations (%zu with CLIP features) converted from %s\n", n,
                    report.annotations, report.clip_features, report.from.c_str());
        std::fflush(stdout);
      }
    } else if (source.kind == ObjectSource::Kind::kPackage) {
      std::printf("objects/%s: already an mlspaces package, skipped\n", n);
    } else if (source.kind == ObjectSource::Kind::kOther) {
      std::printf("objects/%s: no %s (not a MolmoSpaces-format source), skipped\n", n,
                  std::string(kTriesFile).c_str());
    } else {
      const LegacyIndexReport report = BuildLegacySourceIndex(source);
      std::printf("objects/%s: %zu assets in %zu archives indexed\n", n, report.assets,
                  report.archives);
      std::fflush(stdout);
      for (const Diagnostic& w : report.warnings) {
        Warn("objects/" + source.name + ": " + LegacyWarningLine(w));
      }
    }
  }
  if (sources.empty()) std::printf("no sources under %s\n", (assets / "objects").c_str());
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
