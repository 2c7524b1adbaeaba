// Registry lookups on 3 synthetic user libraries totalling 150,000 UIDs.
// Targets (median): Locate < 1 us, GetAnnotation warm < 1 us, first time < 10 us,
// LoadGrasps (pickup) 50 of 1,000 (STORED f8) < 30 us.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/library/registry.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;

constexpr size_t kLibraries = 3;
constexpr size_t kUidsPerLibrary = 50000;
// UIDs with a metadata file on disk (the first-time benchmark reads each once).
constexpr size_t kMetadataFiles = 21000;  // 20,000 first-time loads (4,000 x 5 repeats)

std::string Uid(size_t lib, size_t i) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%016llx%08zx%08zx",
                static_cast<unsigned long long>(HashString(std::to_string(i))), lib, i);
  return buf;
}

/// The fixture: built once, removed at exit.
struct Fixture {
  fs::path root;
  std::unique_ptr<Registry> registry;
  std::vector<std::string> uids;
  size_t next_fresh = 0;  // next UID whose annotation was never loaded

  Fixture() {
    std::string tmpl = (fs::temp_directory_path() / "mlspaces_bench_XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) std::abort();
    root = tmpl;
    registry = std::make_unique<Registry>();
    size_t with_metadata = 0;
    for (size_t lib = 0; lib < kLibraries; ++lib) {
      const fs::path dir = root / ("lib" + std::to_string(lib));
      FlatJson index = FlatJson::object();
      for (size_t i = 0; i < kUidsPerLibrary; ++i) {
        const std::string uid = Uid(lib, i);
        // The tutorial layout: <uid>/<uid>.json, one small folder per asset.
        const std::string meta = uid + "/" + uid + ".json";
        index[uid] = {{"uid", uid},
                      {"object_path", uid + "/" + uid + ".xml"},
                      {"metadata_path", meta},
                      {"metadata_npz_path", nullptr}};
        if (with_metadata < kMetadataFiles && i < kMetadataFiles / kLibraries) {
          WriteSmall(dir / meta, R"({"assetId": ")" + uid +
                                     R"(", "category": "block", "description": "A block.",
"description_short": {"one_word": "block", "two_words": "red block"}, "synset": "block.n.01",
"mass": 0.125, "boundingBox": {"x": 0.05, "y": 0.05, "z": 0.05}})");
          ++with_metadata;
        }
        uids.push_back(uid);
      }
      WriteSmall(dir / "assets_index.json", index.dump());
      registry->RegisterAssetLibrary("lib" + std::to_string(lib), dir);
    }
    // One grasp library: 1,000 STORED f8 grasps for the first UID.
    const fs::path grasps = root / "grasps";
    std::vector<double> values;
    for (int k = 0; k < 1000; ++k) {
      Mat4 m;
      m(0, 3) = k;
      values.insert(values.end(), m.m.begin(), m.m.end());
    }
    WriteNpz(grasps / "g.npz", {{"transforms", NpyArray::FromDoubles({1000, 4, 4}, values)}});
    Json gindex = {{"grasp_paths", {{"droid", {{uids[0], "g.npz"}}}}}};
    WriteSmall(grasps / "grasps_index.json", gindex.dump());
    registry->RegisterGraspLibrary("g", grasps, "lib0");
    // Flush the thousands of files just written, so kernel writeback does not run during
    // the timed loops.
    ::sync();
  }
  ~Fixture() {
    std::error_code ec;
    fs::remove_all(root, ec);
  }

  static void WriteSmall(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (f == nullptr) std::abort();
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
  }

  /// A UID with a metadata file that was never loaded.
  const std::string& FreshUid() {
    const size_t k = next_fresh++;
    const size_t lib = k % kLibraries, i = k / kLibraries;
    if (i >= kMetadataFiles / kLibraries) std::abort();  // ran out: raise kMetadataFiles
    return uids[lib * kUidsPerLibrary + i];
  }
};

Fixture& GetFixture() {
  static Fixture fixture;
  return fixture;
}

void BM_Locate(benchmark::State& state) {
  Fixture& f = GetFixture();
  // Random UIDs drawn up front into one contiguous buffer, so the caller's own strings are
  // not what the benchmark measures.
  constexpr size_t kQueries = 1 << 20;
  const size_t width = f.uids[0].size();
  std::string buffer;
  buffer.reserve(kQueries * width);
  Rng rng(1);
  for (size_t i = 0; i < kQueries; ++i) buffer += f.uids[rng.UniformInt(f.uids.size())];
  size_t k = 0;
  for (auto _ : state) {
    auto loc = f.registry->Locate(std::string_view(buffer).substr(k * width, width));
    benchmark::DoNotOptimize(loc);
    k = (k + 1) & (kQueries - 1);
  }
}
BENCHMARK(BM_Locate);

void BM_LocateMiss(benchmark::State& state) {
  Fixture& f = GetFixture();
  const std::string uid = "not_a_registered_uid";
  for (auto _ : state) benchmark::DoNotOptimize(f.registry->Locate(uid));
}
BENCHMARK(BM_LocateMiss);

void BM_GetAnnotationWarm(benchmark::State& state) {
  Fixture& f = GetFixture();
  std::vector<std::string> warm;
  for (size_t i = 0; i < 64; ++i) {
    warm.push_back(f.FreshUid());
    f.registry->GetAnnotation(warm.back());
  }
  size_t k = 0;
  for (auto _ : state) {
    auto a = f.registry->GetAnnotation(warm[k++ & 63]);
    benchmark::DoNotOptimize(a);
  }
}
BENCHMARK(BM_GetAnnotationWarm);

void BM_GetAnnotationFirstTime(benchmark::State& state) {
  Fixture& f = GetFixture();
  // UIDs never loaded before, picked outside the timed loop (Pause/ResumeTiming would add
  // clock syscalls to every iteration).
  std::vector<const std::string*> fresh;
  for (int64_t i = 0; i < state.max_iterations; ++i) fresh.push_back(&f.FreshUid());
  size_t k = 0;
  for (auto _ : state) {
    auto a = f.registry->GetAnnotation(*fresh[k++]);
    benchmark::DoNotOptimize(a);
  }
}
// Fixed iterations: every iteration needs a UID never loaded before.
BENCHMARK(BM_GetAnnotationFirstTime)->Iterations(4000)->Repetitions(5);

void BM_LoadPickupGrasps50Of1000(benchmark::State& state) {
  Fixture& f = GetFixture();
  const std::string& uid = f.uids[0];
  uint64_t seed = 0;
  for (auto _ : state) {
    GraspSet set = f.registry->LoadGrasps({uid}, 50, seed++);
    benchmark::DoNotOptimize(set);
  }
}
BENCHMARK(BM_LoadPickupGrasps50Of1000);

}  // namespace
}  // namespace mlspaces

BENCHMARK_MAIN();
