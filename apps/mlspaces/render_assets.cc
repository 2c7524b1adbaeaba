// mlspaces render assets [UID...] [--library NAME]: a contact sheet of assets labelled by UID.
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/core/yaml_archive.h"
#include "render.h"

namespace mlspaces::cli {
namespace {

struct AssetsFlags {
  std::vector<std::string> uids;
  std::string library;
  size_t max = 64;
  LibraryFlags libraries;
  RenderFlags render;
};

int Run(const AssetsFlags& flags) {
  const sim::PictureOptions options = flags.render.Options();
  const Registry registry = flags.libraries.Build();
  std::vector<std::string> uids = flags.uids;
  if (uids.empty()) {
    // Every asset of the user libraries (or of --library): library by library, each sorted.
    const std::vector<std::string> libs = registry.asset_libraries();
    if (!flags.library.empty() &&
        std::find(libs.begin(), libs.end(), flags.library) == libs.end()) {
      throw UsageError("--library: no asset library '" + flags.library +
                       "' (libraries: " + JoinNames(libs) + ")");
    }
    for (const std::string& uid : registry.user_uids()) {
      if (!flags.library.empty()) {
        const std::optional<AssetLocation> loc = registry.Locate(uid);
        if (!loc || loc->library != flags.library) continue;
      }
      uids.push_back(uid);
    }
    if (uids.empty()) {
      throw UsageError(
          "no assets to render: name UIDs, or register a user library (--asset-library "
          "NAME=DIR, --libraries FILE.yaml)");
    }
  }
  if (uids.size() > flags.max) {
    Warn("rendering the first " + std::to_string(flags.max) + " of " + std::to_string(uids.size()) +
         " assets (--max)");
    uids.resize(flags.max);
  }
  try {  // a sheet too large, before any rendering, with the flags that make it smaller
    sim::GridSize(uids.size(), options.width, options.height, flags.render.columns);
  } catch (const UsageError& e) {
    throw UsageError(std::string(e.what()) + " (--max, --size, --columns)");
  }
  for (const std::string& uid : uids) registry.LocateOrThrow(uid);  // unknown UIDs before GL
  const sim::Image sheet =
      sim::AssetSheet(registry, uids, options, flags.render.columns, [&](size_t i, size_t n) {
        flags.render.Progress("asset " + std::to_string(i + 1) + "/" + std::to_string(n) + " " +
                              uids[i]);
      });
  flags.render.Write(sheet);
  return 0;
}

}  // namespace

void AddRenderAssets(CLI::App& render, Action& action) {
  auto flags = std::make_shared<AssetsFlags>();
  CLI::App* sub = render.add_subcommand(
      "assets",
      "A contact sheet of assets, each labelled with its UID (default: every asset of "
      "the registered user libraries)");
  sub->add_option("UID", flags->uids, "Assets to show (default: all, library by library)");
  sub->add_option("--library", flags->library, "Only the assets of this asset library");
  sub->add_option("--max", flags->max, "At most N assets (default 64)")->check(PositiveInteger());
  flags->libraries.AddTo(*sub);
  flags->render.AddTo(*sub, "256x256");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
