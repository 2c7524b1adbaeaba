// mlspaces: command-line entry point.
#include <cstdio>
#include <iostream>

#include "commands.h"
#include "mlspaces/core/error.h"

namespace mlspaces::cli {

#ifdef MLSPACES_HAVE_SIM
void AddInspect(CLI::App& app, Action& action);
#endif

void Warn(const std::string& text) { std::fprintf(stderr, "mlspaces: warning: %s\n", text.c_str()); }

}  // namespace mlspaces::cli

int main(int argc, char** argv) {
  using namespace mlspaces;
  CLI::App app{"mlspaces: asset and grasp libraries and pick data generation for MuJoCo"};
  app.set_version_flag("--version", std::string("mlspaces ") + MLSPACES_VERSION);
  app.require_subcommand(1);
  cli::Action action;
  cli::AddIndexAssets(app, action);
  cli::AddIndexGrasps(app, action);
  cli::AddLocate(app, action);
  cli::AddMeta(app, action);
  cli::AddGrasps(app, action);
  cli::AddValidate(app, action);
#ifdef MLSPACES_HAVE_SIM
  cli::AddInspect(app, action);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "mlspaces: error: %s (see --help)\n", e.what());
    return 2;
  }
  try {
    return action ? action() : 2;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "mlspaces: error: %s\n", e.what());
    return 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "mlspaces: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlspaces: internal error: %s\n", e.what());
    return 1;
  }
}
