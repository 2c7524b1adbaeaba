// MP4 writing speed (VideoWriter: RGB -> yuv420p -> libx264 -> MP4, fsync + rename) at a
// camera-like 640x368 (32 frames per iteration), crf 25, for the x264 presets "veryfast" (our
// default) and "medium" (the original's, x264's default); and ProbeVideo's full decode.
// items_per_second = frames per second; bytes_per_frame = file size / frames. Run:
//   build/bench/datagen_video_bench --benchmark_repetitions=5
//     --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/datagen/video.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 640, kHeight = 368, kFrames = 32;

/// Camera-like content, not a flat colour: a gradient "wall" over a checkered "floor" that
/// scrolls (camera motion), a moving box, and sensor-like noise (+-8).
std::vector<unsigned char> MakeFrame(int t) {
  std::vector<unsigned char> rgb(static_cast<size_t>(kWidth) * kHeight * 3);
  uint32_t state = 99991u + static_cast<uint32_t>(t) * 7919u;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      state = state * 1664525u + 1013904223u;
      const int noise = static_cast<int>(state >> 28) - 8;
      const int u = x + 5 * t, v = y + 2 * t;
      int r, g, b;
      if (x > 200 + 6 * t && x < 320 + 6 * t && y > 120 + 2 * t && y < 240 + 2 * t) {
        r = 200, g = 40 + (x - 200 - 6 * t) / 2, b = 40;  // the box
      } else if (y < kHeight / 3) {
        r = 120 + u * 100 / kWidth % 100, g = 140 + y / 2, b = 170;  // wall
      } else {
        const bool dark = ((u / 24) + (v / 24)) % 2 == 0;  // floor tiles
        r = dark ? 90 : 170, g = dark ? 70 : 140, b = dark ? 50 : 100;
      }
      unsigned char* p = &rgb[(static_cast<size_t>(y) * kWidth + x) * 3];
      p[0] = static_cast<unsigned char>(std::clamp(r + noise, 0, 255));
      p[1] = static_cast<unsigned char>(std::clamp(g + noise, 0, 255));
      p[2] = static_cast<unsigned char>(std::clamp(b + noise, 0, 255));
    }
  }
  return rgb;
}

struct Fixture {
  fs::path dir;
  std::vector<std::vector<unsigned char>> frames;
  Fixture() {
    dir = fs::temp_directory_path() / ("mlspaces_video_bench_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    for (int t = 0; t < kFrames; ++t) frames.push_back(MakeFrame(t));
  }
  ~Fixture() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const Fixture& GetFixture() {
  static const Fixture f;
  return f;
}

void BM_DatagenVideoEncode(benchmark::State& state, std::string preset) {
  const Fixture& f = GetFixture();
  const fs::path mp4 = f.dir / ("encode_" + preset + ".mp4");
  VideoOptions options;
  options.preset = preset;
  options.crf = 25;
  for (auto _ : state) {
    VideoWriter writer(mp4, kWidth, kHeight, options);
    for (const auto& frame : f.frames) writer.AddFrame(frame.data());
    writer.Finish();
  }
  state.SetItemsProcessed(state.iterations() * kFrames);
  state.counters["bytes_per_frame"] = static_cast<double>(fs::file_size(mp4)) / kFrames;
}
BENCHMARK_CAPTURE(BM_DatagenVideoEncode, veryfast, std::string("veryfast"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_DatagenVideoEncode, medium, std::string("medium"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_DatagenVideoProbe(benchmark::State& state) {
  const Fixture& f = GetFixture();
  const fs::path mp4 = f.dir / "probe.mp4";
  {
    VideoWriter writer(mp4, kWidth, kHeight);
    for (const auto& frame : f.frames) writer.AddFrame(frame.data());
    writer.Finish();
  }
  for (auto _ : state) benchmark::DoNotOptimize(ProbeVideo(mp4).frames);
  state.SetItemsProcessed(state.iterations() * kFrames);
}
BENCHMARK(BM_DatagenVideoProbe)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace mlspaces::datagen

BENCHMARK_MAIN();
