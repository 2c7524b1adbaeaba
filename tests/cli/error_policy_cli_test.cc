// One error policy (issue 14): bad input through each library path the CLI reaches ends as
// one line "mlspaces: error: ..." on stderr and exit 1, never as an "internal error" (which
// main.cc keeps for exceptions that are not mlspaces::Error: bugs).
#include <filesystem>
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
