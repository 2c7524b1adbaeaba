// mlspaces: command-line entry point.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <iostream>
#include <string_view>
#include <vector>

#include "commands.h"
#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/core/yaml_archive.h"

namespace mlspaces::cli {

#ifdef MLSPACES_HAVE_SIM
void AddInspect(CLI::App& app, Action& action);
#endif

}  // namespace mlspaces::cli

namespace {

int Run(int argc, char** argv) {
  using namespace mlspaces;
  CLI::App app{"mlspaces: asset and grasp libraries and pick data generation for MuJoCo"};
  app.formatter(cli::MakeHelpFormatter());  // before the subcommands: they copy it
  app.set_version_flag("--version", std::string("mlspaces ") + MLSPACES_VERSION);
  app.require_subcommand(1);
  cli::Action action;
  cli::AddIndexAssets(app, action);
  cli::AddIndexGrasps(app, action);
  cli::AddLocate(app, action);
  cli::AddMeta(app, action);
  cli::AddGrasps(app, action);
  cli::AddValidate(app, action);
  cli::AddPack(app, action);
  cli::AddInstall(app, action);
  cli::AddIndexBuiltin(app, action);
  cli::AddLicense(app, action);
  cli::AddSearch(app, action);
#ifdef MLSPACES_HAVE_SIM
  cli::AddInspect(app, action);
#endif
#ifdef MLSPACES_HAVE_ROBOTS
  cli::AddInspectRobot(app, action);
#endif
#ifdef MLSPACES_HAVE_GRASPGEN
  cli::AddGenerateGrasps(app, action);
#endif
#ifdef MLSPACES_HAVE_DATAGEN
  cli::AddConfig(app, action);
  cli::AddDatagen(app, action);
  cli::AddValidateDataset(app, action);
  cli::AddRender(app, action);
#endif
#ifdef MLSPACES_HAVE_LEROBOT
  cli::AddExportLeRobot(app, action);
  cli::AddImportLeRobot(app, action);
#endif
  // The command the leading words name, nested ones included ("render scene"): an unknown
  // word, or none where a nested command needs one, is one line with the commands there are.
  const cli::ChosenCommand c = cli::FindCommand(app, argc, argv);
  std::vector<std::string> names;  // the commands the next word could name
  for (CLI::App* sub : c.scope->get_subcommands([](CLI::App*) { return true; })) {
    names.push_back(sub->get_name());
  }
  if (!names.empty() && c.next >= argc && c.scope != &app) {
    std::fprintf(stderr, "mlspaces: error: %s needs a command (%s)\n", c.path.c_str(),
                 JoinNames(names).c_str());
    return 2;
  }
  if (!names.empty() && c.next < argc && argv[c.next][0] != '-') {
    const std::string of = c.path.empty() ? "" : " of " + c.path;
    std::string hint = DidYouMean(argv[c.next], names);
    if (!hint.empty()) hint += " ";
    std::fprintf(stderr, "mlspaces: error: unknown command '%s'%s (%scommands%s: %s)\n",
                 Printable(argv[c.next]).c_str(), of.c_str(), hint.c_str(), of.c_str(),
                 JoinNames(names).c_str());
    return 2;
  }
  return cli::ParseAndRun(app, action, argc, argv);
}

}  // namespace

int main(int argc, char** argv) {
  // Run reports every error itself; this catches what escapes its set-up (out of memory).
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlspaces: internal error: %s\n", mlspaces::Printable(e.what()).c_str());
  } catch (...) {
    std::fprintf(stderr, "mlspaces: internal error: unknown exception\n");
  }
  return 1;
}
