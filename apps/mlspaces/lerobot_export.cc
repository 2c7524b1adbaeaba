// mlspaces export-lerobot DATASET_DIR OUT_DIR [--fps F] [--repo-id NAME] [--codec copy|h264|av1]
// [-q]: an mlspaces dataset as a LeRobot v3.0 dataset (datagen/lerobot/export.h,
// docs/lerobot.md).
//
// Built twice: into `mlspaces`, where the command execs `mlspaces-lerobot` beside it, and, with
// MLSPACES_LEROBOT_HELPER, into that helper, which does the export and is the only program
// that links Arrow C++ (so `mlspaces` runs where the pyarrow wheel is not installed).
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#ifdef MLSPACES_LEROBOT_HELPER
#include "mlspaces/core/progress.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/datagen/lerobot/export.h"
#endif

namespace mlspaces::cli {

#ifndef MLSPACES_LEROBOT_HELPER
namespace {
// The helper beside this program (the LeRobot commands run there: it links Arrow C++).
std::filesystem::path Helper() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  std::filesystem::path helper = self.parent_path() / "mlspaces-lerobot";
  if (ec || ::access(helper.c_str(), X_OK) != 0) {
    throw Error(
        "this mlspaces was built without Arrow C++ (no mlspaces-lerobot beside it); "
        "see docs/lerobot.md",
        helper.string());
  }
  return helper;
}

std::vector<char*> Argv(const std::filesystem::path& helper, std::vector<std::string>& args) {
  args.insert(args.begin(), helper.string());
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  return argv;
}
}  // namespace

void ExecLeRobotHelper(std::vector<std::string> args) {
  const std::filesystem::path helper = Helper();
  std::vector<char*> argv = Argv(helper, args);
  std::fflush(nullptr);
  ::execv(helper.c_str(), argv.data());
  throw Error("cannot run the LeRobot helper", helper.string());
}

int RunLeRobotHelper(std::vector<std::string> args) {
  const std::filesystem::path helper = Helper();
  std::vector<char*> argv = Argv(helper, args);
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw Error("cannot fork for the LeRobot helper", helper.string());
  if (pid == 0) {
    ::execv(helper.c_str(), argv.data());
    std::_Exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw Error("cannot wait for the LeRobot helper", helper.string());
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}
#endif

namespace {

struct Flags {
  std::string dataset, out, repo_id, codec = "copy";
  double fps = 0;
  bool quiet = false;
  bool no_mlspaces_meta = false;
  bool records = false;  // DATASET_DIR is datagen --format lerobot's staging run folder
};

#ifndef MLSPACES_LEROBOT_HELPER
int Run(const Flags& flags) {
  std::vector<std::string> args = {"export-lerobot", flags.dataset, flags.out, "--codec",
                                   flags.codec};
  if (flags.fps > 0) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", flags.fps);
    args.insert(args.end(), {"--fps", buf});
  }
  if (!flags.repo_id.empty()) args.insert(args.end(), {"--repo-id", flags.repo_id});
  if (flags.quiet) args.emplace_back("-q");
  if (flags.no_mlspaces_meta) args.emplace_back("--no-mlspaces-meta");
  if (flags.records) args.emplace_back("--episode-records");
  ExecLeRobotHelper(args);
}
#else
int Run(const Flags& flags) {
  using namespace datagen::lerobot;
  ExportOptions options;
  options.fps = flags.fps;
  options.repo_id = flags.repo_id;
  options.mlspaces_meta = !flags.no_mlspaces_meta;
  options.codec = flags.codec == "h264"  ? VideoCodec::kH264
                  : flags.codec == "av1" ? VideoCodec::kAv1
                                         : VideoCodec::kCopy;
  ProgressStyle style;
  style.enabled = !flags.quiet;
  style.lines_when_not_tty = true;
  style.unit = "episodes";
  std::unique_ptr<ProgressBar> bar;
  options.progress = [&](int64_t done, int64_t total) {
    if (!bar) {
      bar = std::make_unique<ProgressBar>("export-lerobot", static_cast<size_t>(total), style);
      bar->Start(0, "starting");
    }
    bar->Update(static_cast<size_t>(done));
  };
  const ExportReport r = flags.records ? ExportLeRobotRecords(flags.dataset, flags.out, options)
                                       : ExportLeRobot(flags.dataset, flags.out, options);
  if (bar) bar->Finish();
  for (const std::string& s : r.skipped) std::fprintf(stderr, "left out: %s\n", s.c_str());
  std::string cams;
  for (const std::string& c : r.cameras) cams += (cams.empty() ? "" : ", ") + c;
  const std::string repo = flags.repo_id.empty() ? "<repo_id>" : flags.repo_id;
  std::printf(
      "%s: LeRobot v3.0, %lld episodes (%zu left out), %lld frames, %lld tasks, %.4g fps, "
      "cameras: %s\nload: LeRobotDataset(\"%s\", root=\"%s\")\n",
      flags.out.c_str(), static_cast<long long>(r.episodes), r.skipped.size(),
      static_cast<long long>(r.frames), static_cast<long long>(r.tasks), r.fps,
      cams.empty() ? "none" : cams.c_str(), repo.c_str(), flags.out.c_str());
  return 0;
}
#endif

}  // namespace

void AddExportLeRobot(CLI::App& app, Action& action) {
  auto flags = std::make_shared<Flags>();
  CLI::App* sub = app.add_subcommand(
      "export-lerobot",
      "Write a dataset as a LeRobot v3.0 dataset (parquet + one MP4 per camera); failed and "
      "truncated episodes are left out");
  sub->add_option("DATASET_DIR", flags->dataset, "A datagen run folder (or a house folder)")
      ->required();
  sub->add_option("OUT_DIR", flags->out, "The LeRobot dataset folder to create (must not exist)")
      ->required();
  sub->add_option("--fps", flags->fps,
                  "Check the dataset's frame rate is this (1000 / policy_dt_ms); error if not")
      ->type_name("F")
      ->check(PositiveNumber());
  sub->add_option("--repo-id", flags->repo_id,
                  "The repo_id to load it with (printed; LeRobot takes it from the caller)")
      ->type_name("NAME");
  sub->add_option("--codec", flags->codec,
                  "copy: re-mux the episodes' H.264 videos (default); h264 or av1: re-encode")
      ->check(CLI::IsMember({"copy", "h264", "av1"}));
  sub->add_flag("-q,--quiet", flags->quiet, "No progress bar");
  sub->add_flag("--no-mlspaces-meta", flags->no_mlspaces_meta,
                "Leave out meta/mlspaces/ (a copy of the HDF5 episodes that import-lerobot "
                "needs; import-lerobot then refuses the dataset)");
  // datagen --format lerobot's last step (lerobot_datagen.cc): not for users, so not listed.
  sub->add_flag("--episode-records", flags->records,
                "DATASET_DIR is the staging folder of a datagen --format lerobot run")
      ->group("");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli

#ifdef MLSPACES_LEROBOT_HELPER
int main(int argc, char** argv) {
  using namespace mlspaces;
  // ParseAndRun reports every error itself; this catches what escapes the set-up, as
  // mlspaces' main does.
  try {
    CLI::App app{"mlspaces-lerobot: the export-lerobot command of mlspaces (run it as mlspaces)"};
    app.formatter(cli::MakeHelpFormatter());
    app.require_subcommand(1);
    cli::Action action;
    cli::AddExportLeRobot(app, action);
    cli::AddImportLeRobot(app, action);
    cli::AddValidateLeRobot(app, action);
    return cli::ParseAndRun(app, action, argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlspaces: internal error: %s\n", Printable(e.what()).c_str());
  } catch (...) {
    std::fprintf(stderr, "mlspaces: internal error: unknown exception\n");
  }
  return 1;
}
#endif
