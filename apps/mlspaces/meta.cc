// mlspaces meta UID: the annotation of a UID (metadata JSON with NPZ arrays merged in), from
// the union: objathor metadata (converted on first use), packed, then user libraries.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"

namespace mlspaces::cli {
namespace {

struct MetaFlags {
  std::string uid;
  LibraryFlags libraries;
};

int Run(const MetaFlags& flags) {
  const Registry registry = flags.libraries.Build();
  std::shared_ptr<const Annotation> annotation = registry.GetAnnotation(flags.uid);
  if (annotation == nullptr) {
    // Unknown UID: the locate error names every library.
    const AssetLocation loc = registry.LocateOrThrow(flags.uid);
    throw Error(
        "no metadata for " + flags.uid + " in library " + loc.library +
            (registry.objathor_store() ? std::string() : " (objathor metadata is not installed)"),
        "", "", flags.uid);
  }
  std::printf("%s\n", DumpJsonIndent4(annotation->ToJson()).c_str());
  return 0;
}

}  // namespace

void AddMeta(CLI::App& app, Action& action) {
  auto flags = std::make_shared<MetaFlags>();
  flags->libraries.objathor = true;
  CLI::App* sub = app.add_subcommand(
      "meta",
      "Print the metadata of a UID as JSON (NPZ arrays merged in as lists): the objathor "
      "metadata first (converted into our store on first use), then packed and user libraries");
  sub->add_option("UID", flags->uid, "Asset UID")->required();
  flags->libraries.AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
