// mlspaces-lerobot validate-lerobot DIR: `mlspaces validate-dataset DIR` of a LeRobot v3.0
// folder (meta/info.json) runs this in the helper, which links Arrow C++
// (datagen/lerobot/validate.h).
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/datagen/lerobot/validate.h"

namespace mlspaces::cli {
namespace {

std::string Count(int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

int Run(const std::string& dir) {
  const datagen::lerobot::LeRobotReport r = datagen::lerobot::ValidateLeRobot(dir);
  for (const std::string& p : r.problems) std::printf("%s\n", p.c_str());
  const std::string counts = "LeRobot v3.0: " + Count(r.episodes, "episode", "episodes") + ", " +
                             Count(r.frames, "frame", "frames") + ", " +
                             Count(r.videos, "video", "videos");
  if (r.ok()) {
    std::printf("%s: ok\n", counts.c_str());
    return 0;
  }
  std::printf("%s: %s\n", counts.c_str(),
              Count(static_cast<int64_t>(r.problems.size()), "problem", "problems").c_str());
  return 1;
}

}  // namespace

void AddValidateLeRobot(CLI::App& app, Action& action) {
  auto dir = std::make_shared<std::string>();
  CLI::App* sub = app.add_subcommand(
      "validate-lerobot", "Check a LeRobot v3.0 dataset folder (run by validate-dataset)");
  sub->add_option("DIR", *dir, "A LeRobot dataset folder (meta/info.json)")->required();
  sub->callback([&action, dir] { action = [dir] { return Run(*dir); }; });
}

}  // namespace mlspaces::cli
