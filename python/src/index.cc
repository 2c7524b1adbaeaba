// The index generators of the mlspaces CLI as Python modules
// (python -m mlspaces.resources.generate_user_{asset,grasp}_library_index): the subcommands of
// apps/mlspaces/index_assets.cc and index_grasps.cc, compiled into this extension, parse the
// arguments and run, with the CLI's help, messages and exit codes (cli_app.cc, as main.cc).
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <nanobind/stl/vector.h>
#include <CLI/CLI.hpp>

#include "bindings.h"
#include "commands.h"
#include "mlspaces/core/error.h"

namespace mlspaces::python {

namespace {

/// Runs `command` (index-assets, index-grasps or generate-grasps) on `args` as the CLI does, with
/// `prog` as the name in --help; returns the exit code (0 ok, 1 error, 2 usage error). Output and
/// error lines go to the process's stdout and stderr.
int RunIndexCommand(const std::string& command, const std::string& prog,
                    std::vector<std::string> args) {
  CLI::App app{"", ""};
  app.formatter(cli::MakeHelpFormatter());  // before the subcommand: it copies it
  cli::Action action;
  if (command == "index-assets") {
    cli::AddIndexAssets(app, action);
  } else if (command == "index-grasps") {
    cli::AddIndexGrasps(app, action);
#ifdef MLSPACES_HAVE_GRASPGEN
  } else if (command == "generate-grasps") {
    cli::AddGenerateGrasps(app, action);
#endif
  } else {
    throw UsageError("unknown index command '" + command + "'");
  }
  app.require_subcommand(1);
  // --help names the module: the app's name is empty, so the usage line is the subcommand's.
  app.get_subcommand(command)->name(prog);
  // argv as main() gets it: the program, the subcommand, then its arguments.
  std::vector<std::string> words = {"mlspaces", prog};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  argv.reserve(words.size() + 1);
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  const int code = cli::ParseAndRun(app, action, static_cast<int>(words.size()), argv.data());
  std::cout.flush();
  std::fflush(stdout);
  std::fflush(stderr);
  return code;
}

}  // namespace

void BindIndex(nb::module_& m) {
  m.def(
      "run_index_command",
      [](const std::string& command, const std::string& prog, std::vector<std::string> args) {
        nb::gil_scoped_release release;
        return RunIndexCommand(command, prog, std::move(args));
      },
      nb::arg("command"), nb::arg("prog"), nb::arg("args"),
      "Runs `mlspaces index-assets` / `index-grasps` / `generate-grasps` with `args` (argv after "
      "the command); "
      "prints as the CLI does and returns its exit code.");
}

}  // namespace mlspaces::python
