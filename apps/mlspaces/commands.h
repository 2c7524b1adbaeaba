// The subcommands of the mlspaces CLI. Each lives in its own <name>.cc and only parses flags,
// calls the libraries and prints; main.cc maps exceptions to exit codes
// (mlspaces::UsageError and CLI11 parse errors -> 2, mlspaces::Error -> 1).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mlspaces/library/library_config.h"
#include "mlspaces/library/registry.h"
#ifdef MLSPACES_HAVE_DATAGEN
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/run.h"
#endif

namespace mlspaces::cli {

/// A subcommand's action, run after parsing; returns the process exit code.
using Action = std::function<int()>;

/// Flags that say which libraries to register, shared by lookup commands:
/// --asset-library NAME=DIR, --grasp-library NAME=DIR:ASSET_LIBRARY (repeatable),
/// --libraries FILE.yaml; MLSPACES_ASSETS_DIR supplies the built-in data dir.
struct LibraryFlags {
  std::vector<std::string> asset_flags;
  std::vector<std::string> grasp_flags;
  std::string yaml_file;
  /// Convert the assets dir's objathor metadata first when its store is missing
  /// (EnsureObjathorStore; `meta`, `search`).
  bool objathor = false;

  void AddTo(CLI::App& app);
  /// Builds the registry (YAML libraries first, then flags in order). Prints one warning
  /// line per UID found in two libraries. @throws Error / UsageError.
  Registry Build() const;
  /// The assets dir these flags select: the YAML's assets_dir, else MLSPACES_ASSETS_DIR, else
  /// the default (ResolveAssetsDir; may not exist). @throws Error / UsageError for a bad YAML.
  std::filesystem::path AssetsDir() const;
};

/// A UID's grasps as `grasps` and `render grasps` find them: the file of the first grasp
/// library that has one for (uid, joint), among the libraries of `robot` when it is not empty,
/// and `num` of its grasps drawn with `seed` (all when num is SIZE_MAX). Defined in grasps.cc.
/// @throws Error naming the UID when no library (of `robot`) has a file.
struct FoundGrasps {
  GraspFileLocation file;
  GraspSet grasps;
};
FoundGrasps FindAndLoadGrasps(const Registry& registry, const std::string& uid,
                              const std::string& joint, const std::string& robot, size_t num,
                              uint64_t seed);

// Each Add* registers one subcommand on `app` and sets `action` when it is chosen.
void AddIndexAssets(CLI::App& app, Action& action);
void AddIndexGrasps(CLI::App& app, Action& action);
void AddLocate(CLI::App& app, Action& action);
void AddMeta(CLI::App& app, Action& action);
void AddGrasps(CLI::App& app, Action& action);
void AddValidate(CLI::App& app, Action& action);
void AddPack(CLI::App& app, Action& action);
/// `install` and `verify`.
void AddInstall(CLI::App& app, Action& action);
/// `index-builtin`: UID indexes for MolmoSpaces-format sources (index_builtin.cc).
void AddIndexBuiltin(CLI::App& app, Action& action);
/// `license`: licences of assets, scenes, grasps and robots (license.cc).
void AddLicense(CLI::App& app, Action& action);
/// `search`: CLIP and word search over the asset libraries (search.cc).
void AddSearch(CLI::App& app, Action& action);

#ifdef MLSPACES_HAVE_ROBOTS
/// `inspect-robot`: checks a robot description and measures it (robots_inspect.cc).
void AddInspectRobot(CLI::App& app, Action& action);
#endif

#ifdef MLSPACES_HAVE_GRASPGEN
/// `generate-grasps`: grasps for an asset library's objects (graspgen_generate.cc).
void AddGenerateGrasps(CLI::App& app, Action& action);
#endif

#ifdef MLSPACES_HAVE_DATAGEN
/// The flags that choose and adjust a datagen config, shared by `config` and `datagen`:
/// CONFIG (a YAML file, or a registered config name) [--set KEY=VALUE]... [--seed S]
/// [--episodes N] [--output DIR]. Defined in datagen_config.cc.
struct DatagenConfigFlags {
  std::string config;
  std::vector<std::string> sets;
  std::optional<uint64_t> seed;
  std::optional<int64_t> episodes;
  std::string output;

  void AddTo(CLI::App& app);
  /// Loads CONFIG, applies the --set overrides in order, then --seed / --episodes /
  /// --output, and validates. @throws Error (bad config: exit 1) / UsageError (bad flag).
  datagen::ExperimentConfig Resolve(const datagen::ConfigRegistry& registry) const;
};

void AddConfig(CLI::App& app, Action& action);
void AddDatagen(CLI::App& app, Action& action);
void AddValidateDataset(CLI::App& app, Action& action);
/// `render`: PNG pictures of assets, grasps, scenes and episodes (render*.cc).
void AddRender(CLI::App& app, Action& action);
#endif

#ifdef MLSPACES_HAVE_LEROBOT
/// `export-lerobot`: an mlspaces dataset as a LeRobot v3.0 dataset (lerobot_export.cc).
void AddExportLeRobot(CLI::App& app, Action& action);
/// `import-lerobot`: an mlspaces-made LeRobot dataset back into HDF5 + MP4 (lerobot_import.cc).
void AddImportLeRobot(CLI::App& app, Action& action);
#ifdef MLSPACES_LEROBOT_HELPER
/// `validate-lerobot` (helper only; `validate-dataset` of a LeRobot folder runs it).
void AddValidateLeRobot(CLI::App& app, Action& action);
#else
/// Replaces this process with `mlspaces-lerobot ARGS...` (beside this program), the helper that
/// links Arrow C++. @throws Error when there is none (a build without Arrow C++).
[[noreturn]] void ExecLeRobotHelper(std::vector<std::string> args);
/// Runs `mlspaces-lerobot ARGS...` and @returns its exit status. @throws Error as above.
int RunLeRobotHelper(std::vector<std::string> args);
#ifdef MLSPACES_HAVE_DATAGEN
/// datagen --format lerobot (lerobot_datagen.cc): the staging folder of OUTPUT's run (episode
/// records and MP4s, no HDF5).
std::filesystem::path LeRobotStaging(const std::filesystem::path& out, const datagen::Shard& shard);
/// Points `config` at the staging folder and @returns OUTPUT; empty when OUTPUT is already a
/// finished dataset and `resume`. @throws Error for an OUTPUT holding anything else.
std::filesystem::path PrepareLeRobotRun(datagen::ExperimentConfig& config,
                                        const datagen::Shard& shard, bool resume);
/// Writes the finished run in `staging` as the LeRobot dataset `out` and removes `staging`.
void FinishLeRobotRun(const std::filesystem::path& staging, const std::filesystem::path& out);
/// `merge` of LeRobot datasets: imports, merges, exports. @returns false when no input is one.
bool MergeLeRobot(const std::string& output, const std::vector<std::string>& inputs, bool partial);
#endif
#endif
#endif

/// The help formatter of every command (cli_app.cc): `--episodes N`, never `N:N` or a C++
/// type name. Set it on the top app before adding subcommands (they copy it).
std::shared_ptr<CLI::Formatter> MakeHelpFormatter();

/// The command that argv's leading words name, nested ones included: `scope` (the app itself
/// when none), `path` ("render scene"; empty for the app) and `next`, the index of the first
/// word after them (argc when none is left).
struct ChosenCommand {
  CLI::App* scope = nullptr;
  std::string path;
  int next = 1;
};
ChosenCommand FindCommand(CLI::App& app, int argc, char** argv);

/// Parses argv (argv[0] the program, argv[1] the subcommand) and runs the chosen action, mapping
/// errors to exit codes: 0 ok; 2 usage (CLI11 parse errors, with the first misspelled flag
/// typed and "did you mean"; mlspaces::UsageError); 1 mlspaces::Error and anything else. Each
/// error is one "mlspaces: error: ..." line on stderr with control characters escaped
/// (Printable). --help / --version print and return 0.
int ParseAndRun(CLI::App& app, const Action& action, int argc, char** argv);

/// Checks a flag value is a whole number >= 1, with a short message ("expected a whole
/// number >= 1, got '-3'") instead of CLI11's range dump.
CLI::Validator PositiveInteger();
/// As PositiveInteger, for a whole number >= 0 ("expected a whole number >= 0, got '-1'").
CLI::Validator NonNegativeInteger();
/// As PositiveInteger, for a whole number in [minimum, maximum] ("expected a whole number in
/// [1, 64], got '2000'"): a bound on what one run can be asked to draw.
CLI::Validator WholeNumberIn(long long minimum, long long maximum);
/// Checks a flag value is a finite number > 0 ("expected a number > 0, got 'nan'"): CLI11's
/// PositiveNumber and Range let NaN through.
CLI::Validator PositiveNumber();
/// Checks a flag value is a finite number ("expected a finite number, got 'nan'").
CLI::Validator FiniteNumber();
/// Checks a flag value is a number in [minimum, maximum] ("expected a number in [0, 1], got
/// 'nan'"; CLI11's Range lets NaN through); --help shows the range.
CLI::Validator NumberIn(double minimum, double maximum);

/// Adds `--seed S` to `app`: a whole number in [0, 2^64), given to `store` when typed; anything
/// else ("-3", "1e3", "abc") is a usage error naming the flag, where CLI11's own conversion
/// would wrap a negative number around. `help` is the flag's line in --help.
CLI::Option* AddSeedOption(CLI::App& app, std::function<void(uint64_t)> store,
                           const std::string& help);

/// Prints "mlspaces: warning: <text>" to stderr.
void Warn(const std::string& text);

}  // namespace mlspaces::cli
