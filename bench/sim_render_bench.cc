// Headless rendering speed: frames per second at 640x368 of the tutorial scene with the
// franka_droid robot, RGB only and RGB + metric depth, OSMesa and EGL; and RGB + depth with
// shadows and reflections off (the scene's defaults have both). Real time: llvmpipe renders
// on threads of its own, so the main thread's CPU time says little.
//
// A process renders with one GL backend (MuJoCo takes its GL functions from the platform
// library loaded in the process, libEGL first), so main() runs each backend's benchmarks
// in a forked child of its own; the usual Google Benchmark flags apply to both.
//   build/bench/sim_render_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <sys/wait.h>
#include <unistd.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/renderer.h"
#include "mlspaces/sim/scene.h"

namespace {

namespace fs = std::filesystem;
using mlspaces::sim::GlBackend;

struct World {
  mlspaces::sim::ModelPtr m;
  mlspaces::sim::DataPtr d;
};

World LoadWorld() {
  const fs::path root = MLSPACES_SOURCE_DIR;
  auto scene =
      mlspaces::sim::Scene::Load(fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/scene.xml");
  mlspaces::Pose base;
  base.pos = {-0.5, 0, 0};
  scene.InsertRobot(root / "assets/robots/franka_droid/franka_droid.xml", "robot_0/", base);
  World w;
  w.m = scene.Compile();
  w.d = mlspaces::sim::MakeData(w.m.get());
  mj_forward(w.m.get(), w.d.get());
  return w;
}

void BM_Render(benchmark::State& state, GlBackend backend, bool depth, bool effects) {
  const World w = LoadWorld();
  mlspaces::sim::RenderOptions options;  // 640x368
  options.backend = backend;
  std::unique_ptr<mlspaces::sim::Renderer> renderer;
  try {
    renderer = std::make_unique<mlspaces::sim::Renderer>(w.m.get(), options);
  } catch (const mlspaces::Error& e) {
    state.SkipWithError(e.what());
    return;
  }
  if (!effects) {
    renderer->scene().flags[mjRND_SHADOW] = 0;
    renderer->scene().flags[mjRND_REFLECTION] = 0;
  }
  const auto view = mlspaces::sim::LookAt({1.2, -1.2, 1.1}, {-0.2, 0, 0.45}, 58);
  std::vector<unsigned char> rgb(3 * options.width * options.height);
  std::vector<float> depth_m(depth ? options.width * options.height : 0);
  for (int i = 0; i < 2; ++i) {  // warm-up: the first frames upload textures and meshes
    renderer->Render(w.d.get(), view, rgb.data(), depth ? depth_m.data() : nullptr);
  }
  for (auto _ : state) {
    renderer->Render(w.d.get(), view, rgb.data(), depth ? depth_m.data() : nullptr);
    benchmark::DoNotOptimize(rgb.data());
  }
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void RegisterFor(GlBackend backend) {
  const std::string suffix = "/" + std::string(mlspaces::sim::GlBackendName(backend));
  struct Variant {
    const char* name;
    bool depth, effects;
  };
  for (const Variant& v : {Variant{"BM_Render640x368Rgb", false, true},
                           Variant{"BM_Render640x368RgbDepth", true, true},
                           Variant{"BM_Render640x368RgbDepthNoShadowNoReflection", true, false}}) {
    benchmark::RegisterBenchmark((v.name + suffix).c_str(), BM_Render, backend, v.depth, v.effects)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  int status = 0;
  for (GlBackend backend : {GlBackend::kOsMesa, GlBackend::kEgl}) {
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) {
      std::perror("fork");
      return 1;
    }
    if (pid == 0) {
      RegisterFor(backend);
      benchmark::RunSpecifiedBenchmarks();
      benchmark::Shutdown();
      std::fflush(nullptr);
      ::_exit(0);
    }
    int child = 0;
    ::waitpid(pid, &child, 0);
    if (!WIFEXITED(child) || WEXITSTATUS(child) != 0) status = 1;
  }
  return status;
}
