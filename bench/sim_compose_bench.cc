// Composing the tutorial scene + the franka_droid robot + 10 objects (MuJoCo's parser and
// mjs_attach, plus our checks), separate from MuJoCo's compile of the result. Issue target:
// composition < 50 ms beyond MuJoCo's compile.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "mlspaces/sim/mjcf_composer.h"

namespace {

namespace fs = std::filesystem;
const fs::path kRoot = fs::path(MLSPACES_SOURCE_DIR);
const fs::path kExample = kRoot / "examples/custom_assets";

mlspaces::sim::MjcfComposer Compose() {
  mlspaces::sim::MjcfComposer scene(kExample / "scene.xml");
  mlspaces::Pose base;
  base.pos = {-0.5, 0, 0};
  scene.Attach(kRoot / "assets/robots/franka_droid/franka_droid.xml", "world", "robot_0/", base);
  for (int i = 0; i < 10; ++i) {
    mlspaces::Pose p;
    p.pos = {0.1 * i, 0.3, 0.025};
    scene.Attach(kExample / "asset_library/red_block/red_block.xml", "world",
                 "obj_" + std::to_string(i) + "/", p);
  }
  return scene;
}

void BM_ComposeSceneRobot10Objects(benchmark::State& state) {
  for (auto _ : state) {
    auto scene = Compose();
    benchmark::DoNotOptimize(scene);
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
