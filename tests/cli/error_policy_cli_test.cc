// One error policy (issue 14): bad input through each library path the CLI reaches ends as
// one line "mlspaces: error: ..." on stderr and exit 1, never as an "internal error" (which
// main.cc keeps for exceptions that are not mlspaces::Error: bugs).
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CliResult;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::ShellQuote;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// Exit 1 and exactly one line on stderr: "mlspaces: error: ...", naming `expect`.
void ExpectOneLineError(const CliResult& r, const std::string& expect) {
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, StartsWith("mlspaces: error: "));
  EXPECT_THAT(r.err, HasSubstr(expect));
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("internal error")));
}

// The environment of every run: no caller's install dirs, pins or remote.
std::string Env(const TempDir& tmp) {
  return "env -u MLSPACES_ASSETS_DIR -u MLSPACES_PINNED_ASSETS_FILE -u MLSPACES_REMOTE_URL "
         "MLSPACES_CACHE_DIR=" +
         ShellQuote((tmp / "cache").string()) + " HOME=" + ShellQuote(tmp.path().string()) + " ";
}

TEST(ErrorPolicyCli, PackOfAMissingLibrary) {
  TempDir tmp;
  ExpectOneLineError(RunCli({"pack", (tmp / "nope").string(), (tmp / "out").string()}, Env(tmp)),
                     (tmp / "nope").string());
}

TEST(ErrorPolicyCli, InstallFromARemoteWithoutThePackage) {
  // The remote's listing is missing and the source unknown.
  TempDir tmp;
  fs::create_directories(tmp / "remote");
  ExpectOneLineError(
      RunCli({"install", "--library", "nosuch", "--remote", (tmp / "remote").string(), "-q"},
             Env(tmp)),
      "nosuch");
}

TEST(ErrorPolicyCli, InstallFromAnUnreachableRemote) {
  // The fetch path (curl): nothing listens on port 1; retries end in one Error.
  TempDir tmp;
  ExpectOneLineError(
      RunCli({"install", "--library", "thor", "--remote", "http://127.0.0.1:1", "-q"}, Env(tmp)),
      "curl error");
}

TEST(ErrorPolicyCli, InstallWithABadPinFile) {
  TempDir tmp;
  WriteText(tmp / "pins.json", "{\"objects\": {\"thor\": 7}}");
  ExpectOneLineError(
      RunCli({"install", "x", "--pins", (tmp / "pins.json").string(), "-q"}, Env(tmp)),
      (tmp / "pins.json").string());
}

TEST(ErrorPolicyCli, IndexBuiltinWithoutAnInstall) {
  TempDir tmp;
  ExpectOneLineError(
      RunCli({"index-builtin", "--assets-dir", (tmp / "nowhere").string()}, Env(tmp)),
      "no objects folder");
}

TEST(ErrorPolicyCli, LookupWithABadLibrariesFile) {
  TempDir tmp;
  WriteText(tmp / "libs.yaml", "asset_libraries: 3\n");
  ExpectOneLineError(
      RunCli({"locate", "red_block", "--libraries", (tmp / "libs.yaml").string()}, Env(tmp)),
      (tmp / "libs.yaml").string());
}

TEST(ErrorPolicyCli, InspectOfBrokenMjcf) {
  // The MuJoCo path (sim::MujocoError is an mlspaces::Error); only where the CLI has `inspect`.
  TempDir tmp;
  if (RunCli({"inspect", "--help"}).exit_code != 0) GTEST_SKIP() << "built without sim";
  WriteText(tmp / "bad.xml", "<mujoco><worldbody><geom type=\"box\"/></worldbody>\n");
  ExpectOneLineError(RunCli({"inspect", (tmp / "bad.xml").string()}, Env(tmp)),
                     (tmp / "bad.xml").string());
}

}  // namespace
}  // namespace mlspaces

// ------------------------------------------------------------------------------------------
// The command line as users expect it (issue 29): misspelled flags, help placeholders,
// escaped error lines, and (where the CLI has datagen) the datagen run's messages.

namespace mlspaces {
namespace {

using ::testing::Not;

// Exit 2 and one line "mlspaces: error: ... (see --help)" saying `says`.
void ExpectUsageLine(const CliResult& r, const std::string& says) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_THAT(r.err, StartsWith("mlspaces: error: "));
  EXPECT_THAT(r.err, HasSubstr(says));
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
}

TEST(UsageCli, MisspelledFlagsGetDidYouMeanForTheFirstTyped) {
  ExpectUsageLine(RunCli({"grasps", "red_block", "--sed", "1", "--nmu", "2"}),
                  "--sed: unknown flag of grasps (did you mean '--seed'?)");
  ExpectUsageLine(RunCli({"grasps", "red_block", "--nmu", "2", "--sed", "1"}),
                  "--nmu: unknown flag of grasps (did you mean '--num'?)");
  // "--flag=value", a negative number, short flags, the top level's flags.
  ExpectUsageLine(RunCli({"locate", "--asset-libary=a=b", "red_block"}),
                  "--asset-libary: unknown flag of locate (did you mean '--asset-library'?)");
  ExpectUsageLine(RunCli({"grasps", "red_block", "--seed", "-1", "--jiont", "j"}),
                  "--jiont: unknown flag of grasps (did you mean '--joint'?)");
  ExpectUsageLine(RunCli({"pack", "a", "b", "-Q"}),
                  "-Q: unknown flag of pack (did you mean '-q'?)");
  ExpectUsageLine(RunCli({"pack", "a", "b", "-quiet"}),
                  "-quiet: unknown flag of pack (did you mean '--quiet'?)");
  ExpectUsageLine(RunCli({"--verison"}), "--verison: unknown flag (did you mean '--version'?)");
  // Nothing close: no guess.
  const CliResult far = RunCli({"locate", "red_block", "--zzzzzzzz"});
  ExpectUsageLine(far, "--zzzzzzzz: unknown flag of locate");
  EXPECT_THAT(far.err, Not(HasSubstr("did you mean")));
  // A misspelled command.
  ExpectUsageLine(RunCli({"locaet", "red_block"}),
                  "unknown command 'locaet' (did you mean 'locate'?");
}

// A nested command ("render scene") is named in full: its misspelled flags, a misspelled or
// missing command under "render".
TEST(UsageCli, NestedCommandsAreNamedInTheirErrors) {
  if (RunCli({"render", "--help"}).exit_code != 0) GTEST_SKIP() << "built without datagen";
  const std::string config =
      (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/datagen.yaml").string();
  TempDir tmp;  // where a picture would go, were a flag wrongly accepted
  const std::string png = (tmp / "x.png").string();
  ExpectUsageLine(RunCli({"render", "scene", config, "--episdoe", "3", "-o", png}),
                  "--episdoe: unknown flag of render scene (did you mean '--episode'?)");
  ExpectUsageLine(RunCli({"render", "assets", "--colums", "3", "-o", png}),
                  "--colums: unknown flag of render assets (did you mean '--columns'?)");
  ExpectUsageLine(RunCli({"render", "episdoe", "run"}),
                  "unknown command 'episdoe' of render (did you mean 'episode'? commands of "
                  "render: assets, grasps, scene, episode)");
  ExpectUsageLine(RunCli({"render"}), "render needs a command (assets, grasps, scene, episode)");
  // A known flag with a bad value is that value's error, not an unknown flag.
  ExpectUsageLine(RunCli({"render", "scene", config, "--house", "x", "-o", png}), "--house");
  EXPECT_THAT(RunCli({"render", "scene", config, "--house", "x", "-o", png}).err,
              Not(HasSubstr("unknown flag")));
}

// Every --seed is a whole number in [0, 2^64): CLI11 alone would wrap "-3" around to
// 2^64 - 3. Episode, house and view counts are whole numbers >= 0.
TEST(UsageCli, SeedsAndIndicesAreWholeNumbers) {
  std::vector<std::vector<std::string>> commands = {{"grasps", "red_block"}};
  const std::string config =
      (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/datagen.yaml").string();
  TempDir tmp;  // where a picture would go, were a flag wrongly accepted
  const std::string png = (tmp / "x.png").string();
  if (RunCli({"generate-grasps", "--help"}).exit_code == 0) {
    commands.push_back({"generate-grasps", "lib"});
  }
  const bool datagen = RunCli({"render", "--help"}).exit_code == 0;
  if (datagen) {
    commands.push_back({"render", "grasps", "red_block", "-o", png});
    commands.push_back({"render", "scene", config, "-o", png});
    commands.push_back({"datagen", config});
    commands.push_back({"config", config});
  }
  for (const std::vector<std::string>& command : commands) {
    for (const std::string seed : {"-3", "1e3", "abc", "18446744073709551616", "+1", ""}) {
      std::vector<std::string> args = command;
      args.insert(args.end(), {"--seed", seed});
      ExpectUsageLine(RunCli(args), "--seed: expected a whole number >= 0, got '" + seed + "'");
    }
  }
  if (!datagen) return;
  // The largest seed is a seed.
  const CliResult largest = RunCli({"config", config, "--seed", "18446744073709551615"});
  EXPECT_EQ(largest.exit_code, 0) << largest.err;
  EXPECT_THAT(largest.out, HasSubstr("seed: 18446744073709551615"));
  for (const std::string flag : {"--episode", "--house"}) {
    ExpectUsageLine(RunCli({"render", "scene", config, flag, "-1", "-o", png}),
                    flag + ": expected a whole number >= 0, got '-1'");
  }
  ExpectUsageLine(RunCli({"render", "scene", config, "--overviews", "-1", "-o", png}),
                  "--overviews: expected a whole number in [0, 16], got '-1'");
  ExpectUsageLine(RunCli({"render", "episode", "run", "--episode", "-1", "-o", png}),
                  "--episode: expected a whole number >= 0, got '-1'");
}

// A value no flag can mean is refused at the flag, before any work: an empty value (a file,
// name or choice is never ""; "--gl ''" meant the default, "-o ''" failed after rendering,
// an empty OUT_DIR was an internal error), counts that wrapped around or meant "none", NaN, and
// more views than a picture sheet holds.
TEST(UsageCli, ValuesNoFlagCanMeanAreRefusedAtTheFlag) {
  TempDir tmp;
  const std::string png = (tmp / "x.png").string();
  ExpectUsageLine(RunCli({"locate", ""}), "UID: empty value");
  ExpectUsageLine(RunCli({"grasps", "red_block", "--out", ""}), "--out: empty value");
  ExpectUsageLine(RunCli({"search", "--text", "block", "--top-k", "-1"}),
                  "--top-k: expected a whole number >= 1, got '-1'");
  ExpectUsageLine(RunCli({"search", "--text", "block", "--top-k", "0"}),
                  "--top-k: expected a whole number >= 1, got '0'");
  for (const std::string bad : {"nan", "inf", "0.5x"}) {
    ExpectUsageLine(RunCli({"search", "--text", "block", "--threshold", bad}),
                    "--threshold: expected a finite number, got '" + bad + "'");
  }
  if (RunCli({"render", "--help"}).exit_code != 0) return;  // built without datagen
  const std::string config =
      (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/datagen.yaml").string();
  ExpectUsageLine(RunCli({"render", "assets", "-o", ""}), "--out: empty value");
  ExpectUsageLine(RunCli({"datagen", config, "--gl", ""}), "--gl: empty value");
  ExpectUsageLine(RunCli({"datagen", config, "--gl", "vulkan", "--output", tmp.path().string()}),
                  "--gl: unknown GL backend 'vulkan' (expected osmesa or egl)");
  ExpectUsageLine(RunCli({"config", config, "--output", ""}), "--output: empty value");
  ExpectUsageLine(RunCli({"config", ""}), "CONFIG: empty value");
  for (const std::string size : {"4294967328x64", "64x 64", "+64x64", "64x64x", "7x64"}) {
    const CliResult r = RunCli({"render", "assets", "-o", png, "--size", size});
    EXPECT_EQ(r.exit_code, 2) << size << ": " << r.err;
    EXPECT_EQ(r.err,
              "mlspaces: error: --size: expected WxH with each in [8, 8192], got '" + size + "'\n");
  }
  {
    // A contact sheet over 16384 pixels a side is refused before anything is rendered.
    std::vector<std::string> args{"render", "assets", "-o", png, "--max", "4000"};
    args.insert(args.end(), 58 * 58, "no_such_uid");
    ExpectUsageLine(RunCli(args),
                    "3364 tiles of 256x256 in 58 columns make a 15084x16476 picture, over the "
                    "16384 pixels a side it may have: fewer or smaller tiles, or other columns "
                    "(--max, --size, --columns)");
  }
  ExpectUsageLine(RunCli({"render", "grasps", "red_block", "--views", "65", "-o", png}),
                  "--views: expected a whole number in [1, 64], got '65'");
  ExpectUsageLine(RunCli({"render", "grasps", "red_block", "--gripper", "franka_drod", "-o", png}),
                  "--gripper: unknown robot 'franka_drod' (mlspaces has: franka_droid, xarm7; or "
                  "give the path of a robot.yaml); did you mean 'franka_droid'?");
  ExpectUsageLine(
      RunCli(
          {"render", "grasps", "red_block", "--gripper", (tmp / "none.yaml").string(), "-o", png}),
      "--gripper: no robot description (robot.yaml) at " + (tmp / "none.yaml").string());
  ExpectUsageLine(RunCli({"render", "scene", config, "--overviews", "17", "-o", png}),
                  "--overviews: expected a whole number in [0, 16], got '17'");
  for (const std::string width : {"1", "100000"}) {
    ExpectUsageLine(RunCli({"render", "episode", "run", "--width", width, "-o", png}),
                    "--width: expected a whole number in [8, 8192], got '" + width + "'");
  }
  EXPECT_FALSE(fs::exists(png));
}

// export-lerobot --fps checks the dataset's rate: a value that can be no rate is an error, not
// a check left out (any value <= 0 was).
TEST(UsageCli, ARateToCheckIsAPositiveNumber) {
  if (RunCli({"export-lerobot", "--help"}).exit_code != 0) GTEST_SKIP() << "built without lerobot";
  TempDir tmp;
  for (const std::string fps : {"-5", "0", "nan", "inf", "15fps", ""}) {
    ExpectUsageLine(
        RunCli({"export-lerobot", tmp.path().string(), (tmp / "out").string(), "--fps", fps}),
        "--fps: expected a number > 0, got '" + fps + "'");
  }
  // A rate passes the flag: the error is then the dataset's.
  const CliResult r =
      RunCli({"export-lerobot", (tmp / "nope").string(), (tmp / "out").string(), "--fps", "15"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("nope"));
}

// The commands, from the unknown-command error's list.
std::vector<std::string> Commands() {
  const std::string err = RunCli({"no-such-command"}).err;
  const size_t at = err.find("commands: ");
  EXPECT_NE(at, std::string::npos) << err;
  std::vector<std::string> out;
  std::string list = err.substr(at + 10, err.rfind(')') - at - 10);
  for (size_t start = 0; start < list.size();) {
    const size_t end = std::min(list.find(", ", start), list.size());
    out.push_back(list.substr(start, end - start));
    start = end + 2;
  }
  return out;
}

TEST(UsageCli, HelpShowsPlaceholdersNotTypes) {
  const std::vector<std::string> commands = Commands();
  ASSERT_GE(commands.size(), 10u);
  for (const std::string& command : commands) {
    const CliResult r = RunCli({command, "--help"});
    EXPECT_EQ(r.exit_code, 0) << command;
    // CLI11's defaults in the flags' column: a validator's description after the type name
    // ("N:N", "UINT:N", "TEXT:{...}") and C++ type names ("CONFIG TEXT REQUIRED").
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
      if (!line.starts_with("  ") || line.starts_with("   ")) continue;
      const std::string flags = line.substr(0, line.find("  ", 2)) + " ";
      for (const char* bad : {"N:N", ":N ", " TEXT:", " TEXT ", " UINT", " INT", " FLOAT"}) {
        if (flags.starts_with("  --text TEXT ") && std::string(bad) == " TEXT ") continue;
        EXPECT_THAT(flags, Not(HasSubstr(bad))) << command << " --help: " << line;
      }
    }
  }
  EXPECT_THAT(RunCli({"grasps", "--help"}).out, HasSubstr("--num N "));
  EXPECT_THAT(RunCli({"license", "--help"}).out,
              HasSubstr("--type {objects,scenes,grasps,robots}"));
  EXPECT_THAT(RunCli({"pack", "--help"}).out, HasSubstr("--zstd-level N in [1 - 19]"));
  EXPECT_THAT(RunCli({"search", "--help"}).out, HasSubstr("--top-k N=50 "));
}

// Exactly one line on stderr, with no control character but its final newline.
void ExpectEscapedLine(const CliResult& r, const std::string& escaped) {
  EXPECT_THAT(r.err, HasSubstr(escaped));
  ASSERT_FALSE(r.err.empty());
  for (size_t i = 0; i + 1 < r.err.size(); ++i) {
    EXPECT_GE(static_cast<unsigned char>(r.err[i]), 0x20) << "byte " << i << " of " << r.err;
  }
  EXPECT_EQ(r.err.back(), '\n');
}

TEST(UsageCli, ControlCharactersFromInputAreEscapedInErrorLines) {
  TempDir tmp;
  // A UID (mlspaces::Error), a flag value (a CLI11 parse error), an unknown flag, a file name.
  CliResult r = RunCli({"locate", "red\x1b[2J\nblock"}, Env(tmp));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  ExpectEscapedLine(r, "red\\x1b[2J\\x0ablock");
  r = RunCli({"grasps", "red_block", "--num", "\x1b]0;x\x07\n"}, Env(tmp));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  ExpectEscapedLine(r, "got '\\x1b]0;x\\x07\\x0a'");
  r = RunCli({"locate", "red_block", "--li\x1b[1mbraries", "x"}, Env(tmp));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  ExpectEscapedLine(r, "--li\\x1b[1mbraries: unknown flag");
  const std::string file = (tmp / "libs\x1b[31m\n.yaml").string();
  r = RunCli({"locate", "red_block", "--libraries", file}, Env(tmp));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  ExpectEscapedLine(r, "libs\\x1b[31m\\x0a.yaml");
}

// The tutorial's datagen command, cameras off; nothing when the CLI has no datagen.
std::vector<std::string> Datagen(const fs::path& output, const std::string& episodes,
                                 const std::string& seed) {
  return {"datagen",    (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/datagen.yaml").string(),
          "--output",   output.string(),
          "--episodes", episodes,
          "--seed",     seed,
          "--set",      "task_config.enable_rendering=false"};
}

TEST(UsageCli, DatagenProgressRefusalWorkersAndOneFileValidation) {
  if (RunCli({"datagen", "--help"}).exit_code != 0) GTEST_SKIP() << "built without datagen";
  TempDir tmp;
  // Progress without a terminal (stderr is a file here): plain lines per episode (not per
  // work item: one after the first episode), the last with the final count; none on stdout.
  // ("datagen: episodes 0/2, starting" comes first when the first episode takes over 5 s.)
  const CliResult run = RunCli(Datagen(tmp / "run", "2", "0"), Env(tmp));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.err, HasSubstr("datagen: episodes 1/2, 1 attempt, success 100.0%, "));
  EXPECT_THAT(run.err, HasSubstr("\ndatagen: episodes 2/2, 2 attempts, success 100.0%"));
  std::istringstream lines(run.err);
  for (std::string line; std::getline(lines, line);) {
    EXPECT_TRUE(line.starts_with("datagen: episodes ") || line.starts_with("mlspaces: wrote "))
        << line;
  }
  EXPECT_THAT(run.out, Not(HasSubstr("datagen: episodes")));

  // The same command with another seed and episode count: which fields changed.
  const CliResult again = RunCli(Datagen(tmp / "run", "3", "1"), Env(tmp));
  ExpectOneLineError(again, "seed 0 -> 1, task_sampler_config.samples_per_house 2 -> 3");
  EXPECT_THAT(again.err, HasSubstr((tmp / "run/config.yaml").string()));
  EXPECT_THAT(again.err, HasSubstr("--output"));

  // validate-dataset FILE.h5 checks that file (and its videos) alone: a broken file beside it
  // fails the folder, not the file.
  const fs::path h5 = tmp / "run/house_0/trajectories_batch_1_of_1.h5";
  WriteText(tmp / "run/house_0/broken.h5", "not HDF5");
  CliResult check = RunCli({"validate-dataset", h5.string()}, Env(tmp));
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  EXPECT_EQ(check.out, "2 trajectories in 1 file, 0 videos: ok\n");
  check = RunCli({"validate-dataset", (tmp / "run/house_0/broken.h5").string()}, Env(tmp));
  EXPECT_EQ(check.exit_code, 1);
  EXPECT_THAT(check.out, HasSubstr("broken.h5"));
  EXPECT_THAT(check.out, HasSubstr("0 trajectories in 1 file"));
  check = RunCli({"validate-dataset", (tmp / "run").string()}, Env(tmp));
  EXPECT_EQ(check.exit_code, 1);
  ExpectOneLineError(RunCli({"validate-dataset", (tmp / "nope.h5").string()}, Env(tmp)),
                     (tmp / "nope.h5").string() + ": no such file");

  // --workers more than the work items: one line saying why it cannot help, and the knob; the
  // split (so the dataset) is left as it is.
  std::vector<std::string> args = Datagen(tmp / "workers", "2", "0");
  args.insert(args.end(), {"--workers", "2", "-q"});
  const CliResult workers = RunCli(args, Env(tmp));
  EXPECT_EQ(workers.exit_code, 0) << workers.err;
  EXPECT_EQ(workers.err,
            "mlspaces: warning: all 2 episodes are in 1 work item; --workers 2 cannot run them "
            "in parallel (a work item is a batch of up to task_sampler_config.episodes_per_batch "
            "= 4 episodes of one scene; --set task_sampler_config.episodes_per_batch=1 splits "
            "them, into other batch files)\n");
  EXPECT_TRUE(testing::Slurp(tmp / "workers/house_0/trajectories_batch_1_of_1.h5") ==
              testing::Slurp(h5));
}

}  // namespace
}  // namespace mlspaces
