// mlspaces license UID...: the licence of assets, scenes, grasps and robots, as the original's
// print_license_info prints it (resources/license.h, docs/licenses.md).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/resources/license.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::cli {
namespace {

struct LicenseFlags {
  std::vector<std::string> ids;
  std::string type = "objects";
  std::string source;
  bool json = false;
  bool list_all = false;
  LibraryFlags libraries;
};

/// Python's json.dumps(indent=2): ASCII only, non-ASCII as \uXXXX.
std::string Dump(const Json& value) { return value.dump(2, ' ', true); }

int Run(const LicenseFlags& flags) {
  const Registry registry = flags.libraries.Build();
  const ResourceSettings settings = ResourceSettings::FromEnvironment();
  LicenseContext context{&registry, settings.assets_dir, settings.cache_dir};
  if (flags.list_all) {
    if (flags.source.empty()) throw UsageError("--list-all needs --source");
    Json ids = Json::array();
    std::vector<std::string> sorted;
    for (const std::string& a : SourceArchiveNames(context, flags.type, flags.source)) {
      sorted.push_back(ArchiveIdentifier(a, flags.source));
    }
    std::sort(sorted.begin(), sorted.end());
    for (const std::string& id : sorted) ids.push_back(id);
    std::printf("%s\n", flags.json ? ids.dump().c_str() : Dump(ids).c_str());
    return 0;
  }
  if (flags.ids.empty()) throw UsageError("give at least one UID or identifier (or --list-all)");
  if (flags.source.empty() && flags.type != "objects" && flags.type != "robots") {
    throw UsageError("--type " + flags.type +
                     " needs --source (e.g. scenes: ithor, grasps: droid)");
  }
  Json all = Json::array();
  for (const std::string& id : flags.ids) {
    std::string source = flags.source;
    if (source.empty() && flags.type == "robots") source = id;
    if (source.empty()) {
      const std::optional<std::string> found = DefaultObjectSource(registry, id);
      if (!found) {
        throw Error(
            id + " not found in asset libraries " +
                [&] {
                  std::string names;
                  for (const std::string& n : registry.asset_libraries())
                    names += (names.empty() ? "" : ", ") + n;
                  return "[" + names + "]";
                }() +
                "; give --source",
            "", "", id);
      }
      source = *found;
    }
    Json record = ResolveLicense(context, flags.type, source, id);
    if (flags.json) {
      all.push_back(std::move(record));
    } else {
      std::printf("%s\n", Dump(record).c_str());
    }
  }
  if (flags.json) std::printf("%s\n", Dump(all).c_str());
  return 0;
}

}  // namespace

void AddLicense(CLI::App& app, Action& action) {
  auto flags = std::make_shared<LicenseFlags>();
  CLI::App* sub = app.add_subcommand(
      "license",
      "Print the licence of assets (default), scenes, grasps or robots as the original's "
      "print_license_info does: one JSON record per UID");
  sub->add_option("UID", flags->ids, "Asset UIDs, or archive identifiers / scene indices");
  sub->add_option("--type", flags->type, "objects, scenes, grasps or robots (default objects)")
      ->check(CLI::IsMember({"objects", "scenes", "grasps", "robots"}));
  sub->add_option("--source", flags->source,
                  "The data source (thor, objaverse, objathor_metadata, a user library, a scene "
                  "or grasp source, a robot); objects default to the UID's library");
  sub->add_flag("--json", flags->json, "Print one JSON array of all records");
  sub->add_flag("--list-all", flags->list_all,
                "Print every identifier of --source (the original's '--list_all')");
  flags->libraries.AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
