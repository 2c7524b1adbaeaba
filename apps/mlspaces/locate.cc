// mlspaces locate UID: which asset library holds a UID, and its MJCF (locate_uid_package).
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/json.h"

namespace mlspaces::cli {
namespace {

struct LocateFlags {
  std::string uid;
  bool json = false;
  LibraryFlags libraries;
};

int Run(const LocateFlags& flags) {
  const Registry registry = flags.libraries.Build();
  const AssetLocation loc = registry.LocateOrThrow(flags.uid);
  if (flags.json) {
    Json out = Json::object();
    out["uid"] = flags.uid;
    out["library"] = loc.library;
    out["mjcf_path"] = loc.mjcf_path.string();
    out["shadowed"] = loc.shadowed;
    if (!loc.archive.empty()) {
      out["archive"] = loc.archive;
      out["installed"] = loc.installed;
    }
    std::printf("%s\n", DumpJsonIndent4(out).c_str());
    return 0;
  }
  std::printf("library: %s\nmjcf_path: %s\n", loc.library.c_str(), loc.mjcf_path.c_str());
  if (!loc.archive.empty()) {
    std::printf("archive: %s%s\n", loc.archive.c_str(),
                loc.installed ? "" : " (not installed: run `mlspaces install UID`)");
  }
  for (const std::string& lib : loc.shadowed) std::printf("shadows: %s\n", lib.c_str());
  return 0;
}

}  // namespace

void AddLocate(CLI::App& app, Action& action) {
  auto flags = std::make_shared<LocateFlags>();
  CLI::App* sub =
      app.add_subcommand("locate", "Print the asset library and absolute MJCF path of a UID");
  sub->add_option("UID", flags->uid, "Asset UID")->required();
  sub->add_flag("--json", flags->json, "Print a JSON object instead of text");
  flags->libraries.AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
