// mlspaces validate: deep checks of an asset and/or grasp library folder.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/library/validate.h"

namespace mlspaces::cli {
namespace {

int Run(const std::string& dir) {
  std::vector<Problem> problems = ValidateLibrary(dir);
  for (const Problem& problem : problems) std::printf("%s\n", problem.ToString().c_str());
  if (problems.empty()) {
    std::printf("%s: OK\n", dir.c_str());
    return 0;
  }
  std::printf("%zu problems in %s\n", problems.size(), dir.c_str());
  return 1;
}

}  // namespace

void AddValidate(CLI::App& app, Action& action) {
  auto dir = std::make_shared<std::string>();
  CLI::App* sub = app.add_subcommand(
      "validate", "Check a library folder: index entries, files, metadata types, grasp poses");
  sub->add_option("LIBRARY_DIR", *dir,
                  "Library folder (with assets_index.json and/or "
                  "grasps_index.json)")
      ->required();
  sub->callback([&action, dir] { action = [dir] { return Run(*dir); }; });
}

}  // namespace mlspaces::cli
