// Composing a scene + robot + 10 objects (our part), separate from MuJoCo's compile.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "mlspaces/sim/mjcf_composer.h"

namespace {

namespace fs = std::filesystem;
const fs::path kData = fs::path(MLSPACES_SOURCE_DIR) / "tests/sim/testdata";

mlspaces::sim::MjcfComposer Compose() {
  mlspaces::sim::MjcfComposer scene(kData / "custom_assets/scene.xml");
  mlspaces::sim::Pose base;
  base.pos = {-0.5, 0, 0};
  scene.Attach(kData / "two_link_arm.xml", "world", "robot_0/", base);
  for (int i = 0; i < 10; ++i) {
    mlspaces::sim::Pose p;
    p.pos = {0.1 * i, 0.3, 0.05};
    scene.Attach(kData / "library/neg_tet/neg_tet.xml", "world",
                 "obj_" + std::to_string(i) + "/", p);
  }
  return scene;
}

void BM_ComposeSceneRobot10Objects(benchmark::State& state) {
  for (auto _ : state) {
    auto scene = Compose();
    std::string xml = scene.Emit();
    benchmark::DoNotOptimize(xml);
  }
}
BENCHMARK(BM_ComposeSceneRobot10Objects)->Unit(benchmark::kMillisecond);

void BM_MujocoCompileOfComposedScene(benchmark::State& state) {
  auto scene = Compose();
  for (auto _ : state) {
    auto m = scene.Compile();
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_MujocoCompileOfComposedScene)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
