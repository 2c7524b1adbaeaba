// mlspaces validate-dataset DIR|FILE.h5: deep checks of a generated trajectory dataset, or of
// one trajectory file (HDF5 schema, JSON rows, flags, provenance, videos); see
// datagen/dataset_validate.h.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/datagen/dataset_validate.h"

namespace mlspaces::cli {
namespace {

std::string Count(int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

int Run(const std::string& dir) {
#ifdef MLSPACES_HAVE_LEROBOT
  // A LeRobot dataset (export-lerobot, datagen --format lerobot): checked by the helper.
  if (std::filesystem::is_regular_file(std::filesystem::path(dir) / "meta" / "info.json")) {
    ExecLeRobotHelper({"validate-lerobot", dir});
  }
#endif
  const datagen::DatasetReport report = datagen::ValidateDataset(dir);
  for (const datagen::DatasetProblem& p : report.problems) {
    std::printf("%s\n", p.ToString().c_str());
  }
  const std::string counts = Count(report.trajectories, "trajectory", "trajectories") + " in " +
                             Count(report.files, "file", "files") + ", " +
                             Count(report.videos, "video", "videos");
  if (report.ok()) {
    std::printf("%s: ok\n", counts.c_str());
    return 0;
  }
  std::printf("%s: %s\n", counts.c_str(),
              Count(static_cast<int64_t>(report.problems.size()), "problem", "problems").c_str());
  return 1;
}

}  // namespace

void AddValidateDataset(CLI::App& app, Action& action) {
  auto dir = std::make_shared<std::string>();
  CLI::App* sub = app.add_subcommand(
      "validate-dataset",
      "Check a generated dataset or one trajectory file: HDF5 schema, JSON rows, flags, "
      "provenance, videos");
  sub->add_option("PATH", *dir,
                  "A datagen run folder, any folder of trajectory files, or one trajectory "
                  "file (FILE.h5: that file and the videos it names)")
      ->required();
  sub->callback([&action, dir] { action = [dir] { return Run(*dir); }; });
}

}  // namespace mlspaces::cli
