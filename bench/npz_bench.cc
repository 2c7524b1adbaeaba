// NpzReader speed on grasp-sized archives: open + read 50 random rows of 1,000 grasps.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "mlspaces/core/npz.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;

constexpr size_t kNumGrasps = 1000;
constexpr size_t kRowsPerRead = 50;

// Grasp archives written once per process into a temp folder, removed at exit.
class Files {
 public:
  Files() {
    dir_ = fs::temp_directory_path() / ("mlspaces_npz_bench_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> value(-1.0, 1.0);
    std::vector<double> values(kNumGrasps * 16);
    for (double& v : values) v = value(rng);
    WriteNpz(stored(), {{"transforms", NpyArray::FromDoubles({kNumGrasps, 4, 4}, values)}});
    WriteNpz(deflated(),
             {{"transforms", NpyArray::FromDoubles(DType::kF2, {kNumGrasps, 4, 4}, values)}},
             {.compress = true, .npy = {}});
    // A fixed cycle of row sets, like random.sample(range(1000), 50) per lookup.
    std::vector<size_t> all(kNumGrasps);
    std::iota(all.begin(), all.end(), 0);
    for (int i = 0; i < 64; ++i) {
      std::shuffle(all.begin(), all.end(), rng);
      row_sets_.emplace_back(all.begin(), all.begin() + kRowsPerRead);
    }
  }
  ~Files() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path stored() const { return dir_ / "grasps_f8_stored.npz"; }
  fs::path deflated() const { return dir_ / "grasps_f2_deflated.npz"; }
  const std::vector<size_t>& rows(size_t i) const { return row_sets_[i % row_sets_.size()]; }

 private:
  fs::path dir_;
  std::vector<std::vector<size_t>> row_sets_;
};

const Files& GetFiles() {
  static const Files files;
  return files;
}

void OpenAndReadRows(benchmark::State& state, const fs::path& path) {
  const Files& files = GetFiles();
  size_t i = 0;
  for (auto _ : state) {
    NpzReader reader(path);
    NpyArray rows = reader.ReadRows("transforms", files.rows(i++));
    benchmark::DoNotOptimize(rows.data.data());
  }
}

void BM_OpenReadRows50_StoredF8(benchmark::State& state) {
  OpenAndReadRows(state, GetFiles().stored());
}
BENCHMARK(BM_OpenReadRows50_StoredF8)->Unit(benchmark::kMicrosecond);

void BM_OpenReadRows50_DeflateF2(benchmark::State& state) {
  OpenAndReadRows(state, GetFiles().deflated());
}
BENCHMARK(BM_OpenReadRows50_DeflateF2)->Unit(benchmark::kMicrosecond);

void OpenAndReadHeader(benchmark::State& state, const fs::path& path) {
  for (auto _ : state) {
    NpzReader reader(path);
    NpyHeader header = reader.ReadHeader("transforms");
    benchmark::DoNotOptimize(header.shape.data());
  }
}

void BM_OpenReadHeader_StoredF8(benchmark::State& state) {
  OpenAndReadHeader(state, GetFiles().stored());
}
BENCHMARK(BM_OpenReadHeader_StoredF8)->Unit(benchmark::kMicrosecond);

void BM_OpenReadHeader_DeflateF2(benchmark::State& state) {
  OpenAndReadHeader(state, GetFiles().deflated());
}
BENCHMARK(BM_OpenReadHeader_DeflateF2)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace mlspaces

BENCHMARK_MAIN();
