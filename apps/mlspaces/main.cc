// mlspaces: command-line entry point.
#include <cstdio>
#include <iostream>

#include "commands.h"
#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"

namespace mlspaces::cli {

#ifdef MLSPACES_HAVE_SIM
void AddInspect(CLI::App& app, Action& action);
#endif

void Warn(const std::string& text) {
  std::fprintf(stderr, "mlspaces: warning: %s\n", text.c_str());
}

CLI::Validator PositiveInteger() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        bool digits = !value.empty() && value.size() <= 18 &&
                      value.find_first_not_of("0123456789") == std::string::npos;
        if (digits && std::stoll(value) >= 1) return {};
        return "expected a whole number >= 1, got '" + value + "'";
      },
      "N");
}

}  // namespace mlspaces::cli

namespace {

int Run(int argc, char** argv) {
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
  cli::AddPack(app, action);
  cli::AddInstall(app, action);
  cli::AddIndexBuiltin(app, action);
  cli::AddLicense(app, action);
  cli::AddSearch(app, action);
#ifdef MLSPACES_HAVE_SIM
  cli::AddInspect(app, action);
#endif
#ifdef MLSPACES_HAVE_DATAGEN
  cli::AddConfig(app, action);
  cli::AddDatagen(app, action);
  cli::AddValidateDataset(app, action);
#endif
  if (argc >= 2 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      names += (names.empty() ? "" : ", ") + sub->get_name();
      known = known || sub->get_name() == argv[1];
    }
    if (!known) {
      std::fprintf(stderr, "mlspaces: error: unknown command '%s' (commands: %s)\n", argv[1],
                   names.c_str());
      return 2;
    }
  }
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
    CrashPointCount();  // a malformed MLSPACES_CRASH_* fails here, before any work
    return action ? action() : 2;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "mlspaces: error: %s\n", e.what());
    return 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "mlspaces: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    // The libraries throw mlspaces::Error (MuJoCo's sim::MujocoError included) for every bad
    // input; what arrives here is a bug (a std::logic_error bug check) or out of memory.
    std::fprintf(stderr, "mlspaces: internal error: %s\n", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Run reports every error itself; this catches what escapes its set-up (out of memory).
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlspaces: internal error: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "mlspaces: internal error: unknown exception\n");
  }
  return 1;
}
