// CLIP search at MolmoSpaces' scale (run through bench/clip_search_bench.sh, which adds the
// original's numpy formula side by side): synthetic float16 features (deterministic seed)
// written to a store, then the median latency of exact and approximate queries, the
// single-core streaming-read bandwidth over the same bytes, and the approximate recall@50.
//
//   clip_search_bench STORE [--assets N] [--queries Q] [--out DIR]
// Writes STORE when it is missing (N assets x 3 views x 768, plus text). With --out, writes
// DIR/queries.npy (Q x 768 float32) and DIR/exact.json (our exact top-50 per query) for the
// numpy comparison.
#include <fcntl.h>
#include <immintrin.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npy.h"
#include "mlspaces/library/clip_store.h"

namespace {
namespace fs = std::filesystem;
using mlspaces::ClipHit;
using mlspaces::ClipSearchOptions;
using mlspaces::ClipStore;
using Clock = std::chrono::steady_clock;

constexpr size_t kViews = 3, kDim = 768;

struct Rng {
  uint64_t s;
  uint64_t Next() {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return s;
  }
  // Roughly N(0, 1): the sum of four uniforms, rescaled (cheap; the shape does not matter).
  float Normal() {
    float sum = 0;
    for (int i = 0; i < 4; ++i) sum += static_cast<float>(Next() >> 40) / 16777216.0f;
    return (sum - 2.0f) * 1.7320508f;
  }
};

// Clustered features like CLIP's: a shared direction (CLIP embeddings of objects are far from
// isotropic), 2000 category centres, per-object offsets, per-view and text noise, all shaped by
// a decaying spectrum (component j scaled by (1 + j/16)^-0.75: the leading 128 of 768
// components hold ~78% of the variance, as PCA finds for real CLIP features; with
// MLSPACES_CLIP_BENCH_ISOTROPIC=1 every component has the same scale, the worst case for the
// approximate pass).
void Generate(const fs::path& file, size_t n) {
  Rng rng{0x5eed0001};
  constexpr size_t kClusters = 2000;
  std::vector<float> common(kDim), centres(kClusters * kDim), base(kDim), img(kViews * kDim),
      text(kDim);
  const bool isotropic = std::getenv("MLSPACES_CLIP_BENCH_ISOTROPIC") != nullptr;
  std::vector<float> spectrum(kDim);
  for (size_t j = 0; j < kDim; ++j) {
    spectrum[j] = isotropic ? 1.0f : std::pow(1.0f + static_cast<float>(j) / 16.0f, -0.75f);
  }
  for (float& x : common) x = rng.Normal();
  for (float& x : centres) x = rng.Normal();
  mlspaces::ClipStoreWriter writer(file, kViews, kDim);
  char uid[40];
  for (size_t i = 0; i < n; ++i) {
    const float* c = centres.data() + (rng.Next() % kClusters) * kDim;
    for (size_t j = 0; j < kDim; ++j) base[j] = 1.2f * common[j] + c[j] + 0.6f * rng.Normal();
    for (size_t v = 0; v < kViews; ++v) {
      for (size_t j = 0; j < kDim; ++j) {
        img[v * kDim + j] = spectrum[j] * (base[j] + 0.5f * rng.Normal());
      }
    }
    for (size_t j = 0; j < kDim; ++j) text[j] = spectrum[j] * (base[j] + 0.8f * rng.Normal());
    std::snprintf(uid, sizeof uid, "%032llx",
                  static_cast<unsigned long long>(i) * 0x9E3779B97F4A7C15ull);
    writer.Add(uid, img, text);
  }
  writer.Finish();
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

template <class F>
double TimeMs(F&& f) {
  const auto t0 = Clock::now();
  f();
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// One thread summing every 8-byte word of the vectors (what a scan must at least read), with
// 32-byte loads where the CPU has AVX2.
#if defined(__x86_64__)
__attribute__((target("avx2"))) uint64_t StreamSumAvx2(const uint8_t* p, size_t n) {
  __m256i a = _mm256_setzero_si256(), b = a, c = a, d = a;
  size_t i = 0;
  for (; i + 128 <= n; i += 128) {
    a = _mm256_add_epi64(a, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i)));
    b = _mm256_add_epi64(b, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i + 32)));
    c = _mm256_add_epi64(c, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i + 64)));
    d = _mm256_add_epi64(d, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i + 96)));
  }
  alignas(32) uint64_t w[4];
  _mm256_store_si256(reinterpret_cast<__m256i*>(w),
                     _mm256_add_epi64(_mm256_add_epi64(a, b), _mm256_add_epi64(c, d)));
  uint64_t sum = w[0] + w[1] + w[2] + w[3];
  for (; i < n; ++i) sum += p[i];
  return sum;
}
#endif

uint64_t StreamSum(const uint8_t* p, size_t n) {
#if defined(__x86_64__)
  if (__builtin_cpu_supports("avx2")) return StreamSumAvx2(p, n);
#endif
  uint64_t a = 0, b = 0;
  size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    uint64_t w[2];
    std::memcpy(w, p + i, 16);
    a += w[0];
    b += w[1];
  }
  for (; i < n; ++i) a += p[i];
  return a + b;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 2) {
    std::fprintf(stderr, "usage: clip_search_bench STORE [--assets N] [--queries Q] [--out DIR]\n");
    return 2;
  }
  const fs::path file = argv[1];
  size_t n = 131000, queries = 20;
  fs::path out;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--assets") n = std::stoul(argv[i + 1]);
    if (flag == "--queries") queries = std::stoul(argv[i + 1]);
    if (flag == "--out") out = argv[i + 1];
  }
  if (!fs::exists(file)) {
    std::printf("writing %zu x %zu x %zu float16 features to %s ...\n", n, kViews + 1, kDim,
                file.c_str());
    std::fflush(stdout);
    const double ms = TimeMs([&] { Generate(file, n); });
    std::printf("  written in %.1f s\n", ms / 1000);
  }
  auto store = ClipStore::Open(file);
  n = store->size();
  const size_t vector_bytes = n * (kViews + 1) * kDim * 2;
  std::printf("features: %s\n", std::getenv("MLSPACES_CLIP_BENCH_ISOTROPIC") != nullptr
                                    ? "isotropic (every component the same scale)"
                                    : "decaying spectrum (1 + j/16)^-0.75");
  std::printf("store: %zu assets, %.1f MB of vectors (%zu bytes file), kernel %s, %u cores\n", n,
              vector_bytes / 1e6, static_cast<size_t>(fs::file_size(file)),
              std::string(mlspaces::ClipKernelName()).c_str(), std::thread::hardware_concurrency());

  // Queries: a stored text feature plus noise (so that the default threshold keeps results).
  std::vector<std::vector<float>> qs;
  Rng rng{77};
  for (size_t k = 0; k < queries; ++k) {
    std::vector<float> q = store->TextFeature(rng.Next() % n);
    for (float& x : q) x += 0.03f * rng.Normal();
    qs.push_back(std::move(q));
  }

  // Bandwidth: the same bytes, read by one thread (file mapped and in the page cache).
  const std::string bytes_path = file.string();
  std::vector<double> bw_ms;
  {
    const int fd = ::open(bytes_path.c_str(), O_RDONLY);
    const size_t size = fs::file_size(file);
    void* map = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
    ::close(fd);
    volatile uint64_t sink = 0;
    for (int r = 0; r < 7; ++r) {
      bw_ms.push_back(TimeMs(
          [&] { sink = sink + StreamSum(static_cast<const uint8_t*>(map) + 64, vector_bytes); }));
    }
    ::munmap(map, size);
  }
  const double read_ms = Median(bw_ms);

  auto run = [&](const ClipSearchOptions& o, std::vector<std::vector<ClipHit>>* hits) {
    std::vector<double> ms;
    store->Search(qs[0], o);  // warm-up
    for (const auto& q : qs) {
      std::vector<ClipHit> h;
      ms.push_back(TimeMs([&] { h = store->Search(q, o); }));
      if (hits) hits->push_back(std::move(h));
    }
    return Median(ms);
  };
  ClipSearchOptions exact;  // defaults: top 50, threshold 0.5 (bounded exact query)
  std::vector<std::vector<ClipHit>> exact_hits, approx_hits, exact_all, approx_all, full_hits,
      full_all;
  size_t scored = 0;
  exact.scored = &scored;
  std::vector<double> scored_counts;
  auto run_counting = [&](const ClipSearchOptions& o, std::vector<std::vector<ClipHit>>* hits) {
    std::vector<double> ms;
    store->Search(qs[0], o);  // warm-up
    scored_counts.clear();
    for (const auto& q : qs) {
      std::vector<ClipHit> h;
      ms.push_back(TimeMs([&] { h = store->Search(q, o); }));
      scored_counts.push_back(static_cast<double>(scored));
      if (hits) hits->push_back(std::move(h));
    }
    return Median(ms);
  };
  const double exact_ms = run_counting(exact, &exact_hits);
  const double exact_scored = Median(scored_counts);
  ClipSearchOptions full = exact;
  full.full_scan = true;
  full.scored = nullptr;
  const double full_ms = run(full, &full_hits);
  ClipSearchOptions bounded_nothr = exact;
  bounded_nothr.threshold = -10;
  const double exact_nothr_ms = run_counting(bounded_nothr, &exact_all);
  const double exact_nothr_scored = Median(scored_counts);
  ClipSearchOptions full_nothr = full;
  full_nothr.threshold = -10;
  run(full_nothr, &full_all);
  // The bounded answer must be the full scan's, bit for bit.
  size_t mismatches = 0;
  for (size_t k = 0; k < queries; ++k) {
    for (const auto& [a, b] :
         {std::pair(&exact_hits[k], &full_hits[k]), std::pair(&exact_all[k], &full_all[k])}) {
      bool same = a->size() == b->size();
      for (size_t h = 0; same && h < a->size(); ++h) {
        same = (*a)[h].uid == (*b)[h].uid && (*a)[h].score == (*b)[h].score;
      }
      mismatches += !same;
    }
  }
  ClipSearchOptions threaded = full;
  threaded.threads = 0;
  const double threaded_ms = run(threaded, nullptr);
  ClipSearchOptions approx = exact;
  approx.approximate = true;
  const double approx_ms = run(approx, &approx_hits);
  // Recall without the threshold too: the 50 best whatever their score.
  ClipSearchOptions approx_nothr = approx;
  approx_nothr.threshold = -10;
  approx_nothr.scored = nullptr;
  run(approx_nothr, &approx_all);
  auto recall = [](const auto& a, const auto& b) {
    size_t found = 0, total = 0;
    for (size_t k = 0; k < a.size(); ++k) {
      for (const ClipHit& h : a[k]) {
        ++total;
        found +=
            std::any_of(b[k].begin(), b[k].end(), [&](const ClipHit& x) { return x.uid == h.uid; });
      }
    }
    return total == 0 ? 1.0 : static_cast<double>(found) / static_cast<double>(total);
  };
  size_t kept = 0;
  for (const auto& h : exact_hits) kept += h.size();

  std::printf("single-core streaming read of the %.0f MB: %.1f ms (%.2f GB/s)\n",
              vector_bytes / 1e6, read_ms, vector_bytes / read_ms / 1e6);
  std::printf(
      "exact query (bounds), 1 thread: median %.1f ms over %zu queries (%.2fx the read time), "
      "median %.0f of %zu assets scored exactly\n",
      exact_ms, queries, exact_ms / read_ms, exact_scored, n);
  std::printf("  same, no threshold (top 50 whatever the score): median %.1f ms, %.0f scored\n",
              exact_nothr_ms, exact_nothr_scored);
  std::printf("exact full scan, 1 thread:      median %.1f ms (%.2fx the read time)\n", full_ms,
              full_ms / read_ms);
  std::printf("exact full scan, all cores:     median %.1f ms\n", threaded_ms);
  std::printf("bounded vs full scan: %zu of %zu answers differ (UIDs, scores, order)\n", mismatches,
              2 * queries);
  std::printf("approximate query:       median %.2f ms\n", approx_ms);
  std::printf("approx recall@50: %.4f with threshold 0.5 (%.1f results/query), %.4f without\n",
              recall(exact_hits, approx_hits), static_cast<double>(kept) / queries,
              recall(exact_all, approx_all));
  for (size_t c : {500, 1000, 4000}) {  // the candidate count trades latency for recall
    ClipSearchOptions o = approx_nothr;
    o.candidates = c;
    std::vector<std::vector<ClipHit>> h;
    const double ms = run(o, &h);
    o.scored = nullptr;
    std::printf("  approx with %4zu candidates: median %.2f ms, recall@50 %.4f (no threshold)\n", c,
                ms, recall(exact_all, h));
  }
  if (!out.empty()) {
    fs::create_directories(out);
    std::vector<double> flat;
    for (const auto& q : qs) flat.insert(flat.end(), q.begin(), q.end());
    const mlspaces::NpyArray arr =
        mlspaces::NpyArray::FromDoubles(mlspaces::DType::kF4, {queries, kDim}, flat);
    mlspaces::WriteNpyFile((out / "queries.npy").string(), arr);
    mlspaces::Json j = mlspaces::Json::object();
    j["exact_ms"] = exact_ms;
    j["read_ms"] = read_ms;
    j["approx_ms"] = approx_ms;
    mlspaces::Json res = mlspaces::Json::array();
    for (const auto& h : exact_all) {
      mlspaces::Json one = mlspaces::Json::array();
      for (const ClipHit& x : h) one.push_back({std::string(x.uid), x.score});
      res.push_back(one);
    }
    j["top50"] = res;
    mlspaces::WriteFileAtomic(out / "exact.json", j.dump());
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "clip_search_bench: %s\n", e.what());
  return 1;
}
