// Packed stores at objaverse scale: a synthetic package of N assets (default 150,000; set
// MLSPACES_PACKED_BENCH_N to change) with ~33 grasps each across 2 robots and small
// red_block-like annotations, written once into a temp folder. Then:
//   - "locate p50 / p99": 1e6 Find calls on random existing UIDs, each timed on its own
//     (steady_clock; the clock's own cost is printed beside it);
//   - resident memory (VmRSS) added by Open + 10,000 lookups;
//   - Google Benchmark: Open, Find (hit / miss), LoadAnnotation, ReadGrasps (50 rows / all),
//     and the JSON decoders the metadata encoding was chosen between (src/library/packed_store.cc).
//
//   build/bench/packed_store_bench --benchmark_min_time=0.5
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/resources/packed_store_writer.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;

struct Store {
  fs::path dir;
  std::vector<std::string> uids;
  std::vector<std::string> misses;
  Annotation red_block;
  std::string red_block_compact;
  std::vector<uint8_t> red_block_msgpack;
  ~Store() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);
  }
};

Store* g_store = nullptr;

size_t NumAssets() {
  const char* env = std::getenv("MLSPACES_PACKED_BENCH_N");
  return env != nullptr ? std::strtoul(env, nullptr, 10) : 150000;
}

std::string Hex32(std::mt19937_64& rng) {
  char buf[33];
  std::snprintf(buf, sizeof buf, "%016llx%016llx", static_cast<unsigned long long>(rng()),
                static_cast<unsigned long long>(rng()));
  return buf;
}

void BuildStore(Store& s, size_t n) {
  std::string tmpl = (fs::temp_directory_path() / "mlspaces_packed_bench_XXXXXX").string();
  if (::mkdtemp(tmpl.data()) == nullptr) std::abort();
  s.dir = tmpl;
  const fs::path red = fs::path(MLSPACES_EXAMPLES_DIR) /
                       "custom_assets/asset_library/red_block/red_block_computed.json";
  s.red_block = LoadAnnotation("red_block", "bench", red, nullptr);
  s.red_block_compact = s.red_block.json.dump();
  s.red_block_msgpack = Json::to_msgpack(s.red_block.json);

  constexpr uint32_t kNumArchives = 10;
  std::vector<std::string> archives;
  std::vector<std::unique_ptr<GraspShardWriter>> shards;
  for (uint32_t a = 0; a < kNumArchives; ++a) {
    char name[64];
    std::snprintf(name, sizeof name, "objaverse_%03u", a);
    archives.push_back(std::string(name) + ".tar.zst");
    shards.push_back(std::make_unique<GraspShardWriter>(s.dir / std::string(kGraspShardDir) /
                                                        (std::string(name) + ".mlsg")));
  }
  std::mt19937_64 rng(42);
  PackedStoreWriter writer(s.dir, "bench", archives);
  std::vector<Mat4> poses(40);
  for (size_t i = 0; i < n; ++i) {
    const std::string uid = Hex32(rng);
    s.uids.push_back(uid);
    Annotation ann = s.red_block;
    ann.uid = uid;
    ann.json["assetId"] = uid;
    ann.json["mass"] = 0.05 + static_cast<double>(rng() % 1000) / 1000.0;
    PackedAssetInput in;
    in.uid = uid;
    in.mjcf = "objects/" + uid + "/" + uid + ".xml";
    in.archive = static_cast<uint32_t>(i % kNumArchives);
    in.annotation = &ann;
    const uint32_t counts[2] = {static_cast<uint32_t>(16 + rng() % 4),
                                static_cast<uint32_t>(14 + rng() % 4)};
    const char* robots[2] = {"franka_droid", "rby1"};
    for (int r = 0; r < 2; ++r) {
      for (uint32_t k = 0; k < counts[r]; ++k) poses[k].m[3] = static_cast<double>(i * 64 + k);
      PackedAssetInput::Grasps g;
      g.robot = robots[r];
      g.archive = in.archive;
      g.count = counts[r];
      g.offset = shards[in.archive]->Append(std::span<const Mat4>(poses.data(), counts[r]));
      in.grasps.push_back(g);
    }
    writer.Add(in);
  }
  for (auto& sh : shards) sh->Finish();
  writer.Finish();
  for (size_t i = 0; i < 100000; ++i) s.misses.push_back(Hex32(rng));
}

/// A "Key:   N kB" field of /proc/self/status (VmRSS, RssAnon, RssFile).
long StatusKb(std::string_view key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.starts_with(key) && line.size() > key.size() && line[key.size()] == ':') {
      return std::strtol(line.c_str() + key.size() + 1, nullptr, 10);
    }
  }
  return -1;
}
long VmRssKb() { return StatusKb("VmRSS"); }

/// Resident KiB of the mappings of files whose path ends with `name` (/proc/self/smaps).
long MappedRssKb(std::string_view name) {
  std::ifstream in("/proc/self/smaps");
  std::string line;
  bool inside = false;
  long total = 0;
  while (std::getline(in, line)) {
    const size_t dash = line.find('-');
    if (dash != std::string::npos && dash > 0 && dash < 17 &&
        line.find_first_not_of("0123456789abcdef") == dash) {
      inside = line.size() >= name.size() && line.ends_with(name);
      continue;
    }
    if (inside && line.rfind("Rss:", 0) == 0) total += std::strtol(line.c_str() + 4, nullptr, 10);
  }
  return total;
}

void PrintLocatePercentiles(const Store& s) {
  const auto lib = PackedLibrary::Open(s.dir, "bench");
  std::mt19937_64 rng(1);
  constexpr size_t kLookups = 1000000;
  // The queries, copied in query order into one buffer: reading them is sequential, so the
  // timings are Find's own cache misses, not the benchmark's.
  std::string buffer;
  std::vector<std::pair<size_t, size_t>> spans(kLookups);
  for (auto& sp : spans) {
    const std::string& uid = s.uids[rng() % s.uids.size()];
    sp = {buffer.size(), uid.size()};
    buffer += uid;
  }
  std::vector<double> ns(kLookups);
  size_t found = 0;
  for (size_t i = 0; i < kLookups; ++i) {
    const std::string_view query(buffer.data() + spans[i].first, spans[i].second);
    const auto t0 = std::chrono::steady_clock::now();
    const auto a = lib->Find(query);
    const auto t1 = std::chrono::steady_clock::now();
    found += a.has_value();
    ns[i] = std::chrono::duration<double, std::nano>(t1 - t0).count();
  }
  std::vector<double> clock_ns(100000);
  for (double& c : clock_ns) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto t1 = std::chrono::steady_clock::now();
    c = std::chrono::duration<double, std::nano>(t1 - t0).count();
  }
  auto pct = [](std::vector<double>& v, double p) {
    const size_t k = static_cast<size_t>(p * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + static_cast<ptrdiff_t>(k), v.end());
    return v[k];
  };
  const double p50 = pct(ns, 0.50), p99 = pct(ns, 0.99), p999 = pct(ns, 0.999);
  std::printf(
      "locate p50 %.0f ns p99 %.0f ns (p99.9 %.0f ns; %zu of %zu found; "
      "%zu assets; steady_clock pair alone p50 %.0f ns, included)\n",
      p50, p99, p999, found, kLookups, s.uids.size(), pct(clock_ns, 0.5));
}

void PrintResidentMemory(const Store& s) {
  const long before = VmRssKb(), anon_before = StatusKb("RssAnon");
  const auto t0 = std::chrono::steady_clock::now();
  const auto lib = PackedLibrary::Open(s.dir, "bench");
  const auto t1 = std::chrono::steady_clock::now();
  const long after_open = VmRssKb();
  std::mt19937_64 rng(2);
  size_t found = 0;
  for (int i = 0; i < 10000; ++i) found += lib->Find(s.uids[rng() % s.uids.size()]).has_value();
  const long after_lookups = VmRssKb();
  const long anon_after = StatusKb("RssAnon");
  const long index_rss = MappedRssKb(kUidIndexFile), meta_rss = MappedRssKb(kMetadataStoreFile);
  const auto index_size = fs::file_size(s.dir / std::string(kUidIndexFile));
  const auto meta_size = fs::file_size(s.dir / std::string(kMetadataStoreFile));
  std::printf(
      "open (first, cold mapping) %.1f us; VmRSS +%ld KiB after Open, +%ld KiB after "
      "Open + 10,000 lookups (%zu found); files: uid_index.mlsx %.1f MiB, "
      "metadata.mlsm %.1f MiB; resident of their mappings now: %ld KiB / %ld KiB (file pages, "
      "shared with the page "
      "cache; whole large folios are mapped at a time); RssAnon +%ld KiB\n",
      std::chrono::duration<double, std::micro>(t1 - t0).count(), after_open - before,
      after_lookups - before, found, index_size / 1048576.0, meta_size / 1048576.0, index_rss,
      meta_rss, anon_after - anon_before);
}

void BM_Open(benchmark::State& state) {
  for (auto _ : state) {
    auto lib = PackedLibrary::Open(g_store->dir, "bench");
    benchmark::DoNotOptimize(lib);
  }
}
BENCHMARK(BM_Open)->Unit(benchmark::kMicrosecond);

void BM_FindHit(benchmark::State& state) {
  const auto lib = PackedLibrary::Open(g_store->dir, "bench");
  std::mt19937_64 rng(3);
  std::vector<uint32_t> which(1 << 16);
  for (auto& w : which) w = static_cast<uint32_t>(rng() % g_store->uids.size());
  size_t i = 0;
  for (auto _ : state) {
    auto a = lib->Find(g_store->uids[which[i++ & 0xffff]]);
    benchmark::DoNotOptimize(a);
  }
}
BENCHMARK(BM_FindHit);

void BM_FindMiss(benchmark::State& state) {
  const auto lib = PackedLibrary::Open(g_store->dir, "bench");
  size_t i = 0;
  for (auto _ : state) {
    auto a = lib->Find(g_store->misses[i++ % g_store->misses.size()]);
    benchmark::DoNotOptimize(a);
  }
}
BENCHMARK(BM_FindMiss);

void BM_LoadAnnotation(benchmark::State& state) {
  const auto lib = PackedLibrary::Open(g_store->dir, "bench");
  std::mt19937_64 rng(4);
  std::vector<PackedAsset> assets;
  for (int i = 0; i < 4096; ++i)
    assets.push_back(*lib->Find(g_store->uids[rng() % g_store->uids.size()]));
  size_t i = 0;
  for (auto _ : state) {
    auto a = lib->LoadAnnotation(assets[i++ & 4095]);
    benchmark::DoNotOptimize(a);
  }
}
BENCHMARK(BM_LoadAnnotation);

/// Find + LoadAnnotation, what a first-time metadata lookup by UID costs.
void BM_FindAndLoadAnnotation(benchmark::State& state) {
  const auto lib = PackedLibrary::Open(g_store->dir, "bench");
  std::mt19937_64 rng(5);
  size_t i = 0;
  std::vector<uint32_t> which(4096);
  for (auto& w : which) w = static_cast<uint32_t>(rng() % g_store->uids.size());
  for (auto _ : state) {
    auto a = lib->LoadAnnotation(*lib->Find(g_store->uids[which[i++ & 4095]]));
    benchmark::DoNotOptimize(a);
  }
}
BENCHMARK(BM_FindAndLoadAnnotation);

void BM_ReadGrasps50Rows(benchmark::State& state) {
  const auto lib = PackedLibrary::Open(g_store->dir, "bench");
  std::mt19937_64 rng(6);
  std::vector<PackedGraspRef> refs;
  for (int i = 0; i < 4096; ++i) {
    const PackedAsset a = *lib->Find(g_store->uids[rng() % g_store->uids.size()]);
    refs.push_back(*lib->FindGrasps(a, "franka_droid", ""));
  }
  std::vector<size_t> rows(50);  // with repeats: a ref holds 16-19 poses
  for (size_t& r : rows) r = rng() % 16;
  size_t i = 0;
  for (auto _ : state) {
    auto poses = lib->ReadGrasps(refs[i++ & 4095], &rows);
    benchmark::DoNotOptimize(poses);
  }
}
BENCHMARK(BM_ReadGrasps50Rows);

void BM_ReadGraspsAll(benchmark::State& state) {
  const auto lib = PackedLibrary::Open(g_store->dir, "bench");
  std::mt19937_64 rng(7);
  std::vector<PackedGraspRef> refs;
  for (int i = 0; i < 4096; ++i) {
    const PackedAsset a = *lib->Find(g_store->uids[rng() % g_store->uids.size()]);
    refs.push_back(*lib->FindGrasps(a, "rby1", ""));
  }
  size_t i = 0;
  for (auto _ : state) {
    auto poses = lib->ReadGrasps(refs[i++ & 4095]);
    benchmark::DoNotOptimize(poses);
  }
}
BENCHMARK(BM_ReadGraspsAll);

// The candidates for the metadata JSON encoding, on red_block_computed.json.
void BM_JsonDecodeNlohmannText(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(Json::parse(g_store->red_block_compact));
}
BENCHMARK(BM_JsonDecodeNlohmannText);

void BM_JsonDecodeSimdjsonText(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(ParseJson(g_store->red_block_compact, "bench"));
}
BENCHMARK(BM_JsonDecodeSimdjsonText);

void BM_JsonDecodeNlohmannMsgpack(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(Json::from_msgpack(g_store->red_block_msgpack));
}
BENCHMARK(BM_JsonDecodeNlohmannMsgpack);

void BM_JsonCopy(benchmark::State& state) {
  for (auto _ : state) {
    Json copy = g_store->red_block.json;
    benchmark::DoNotOptimize(copy);
  }
}
BENCHMARK(BM_JsonCopy);

}  // namespace
}  // namespace mlspaces

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  mlspaces::Store store;
  mlspaces::g_store = &store;
  const size_t n = mlspaces::NumAssets();
  const auto t0 = std::chrono::steady_clock::now();
  mlspaces::BuildStore(store, n);
  const auto t1 = std::chrono::steady_clock::now();
  std::printf("built a store of %zu assets in %.1f s (%s)\n", n,
              std::chrono::duration<double>(t1 - t0).count(), store.dir.c_str());
  mlspaces::PrintResidentMemory(store);
  mlspaces::PrintLocatePercentiles(store);
  std::fflush(stdout);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
