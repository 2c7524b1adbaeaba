// Lookups on an installed packed library at scale (issue 6): run by
// bench/resources_scale_bench.sh after it has generated, packed and installed a library of
// 150,000 assets with 5,000,000 grasps. Prints medians and tails of per-call timings
// (Google Benchmark reports means; tails need the individual calls).
//
//   resources_scale_bench ASSETS_DIR NAME
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "mlspaces/core/rng.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/library/registry.h"

namespace {

using namespace mlspaces;
namespace fs = std::filesystem;

double NowNs() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1e9 + ts.tv_nsec;
}

long RssKb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  }
  return -1;
}

/// Times `calls` calls of f(i) one by one; prints p50 / p99 / max in the unit given.
void Report(const char* what, size_t calls, const std::function<void(size_t)>& f,
            double target_p50_ns = 0, double target_p99_ns = 0) {
  std::vector<double> t(calls);
  for (size_t i = 0; i < calls; ++i) {
    const double a = NowNs();
    f(i);
    t[i] = NowNs() - a;
  }
  std::sort(t.begin(), t.end());
  const double p50 = t[calls / 2], p99 = t[calls * 99 / 100];
  std::printf("%-44s p50 %8.0f ns   p99 %8.0f ns   (%zu calls)", what, p50, p99, calls);
  if (target_p50_ns > 0) std::printf("   target p50 < %.0f ns", target_p50_ns);
  if (target_p99_ns > 0) std::printf(", p99 < %.0f ns", target_p99_ns);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s ASSETS_DIR NAME\n", argv[0]);
    return 2;
  }
  const fs::path assets = argv[1];
  const std::string name = argv[2];
  const fs::path dir = assets / "objects" / name;

  // Index open: a fresh PackedLibrary each time (mmap + header checks), median of 50.
  const long rss0 = RssKb();
  std::vector<double> opens;
  std::shared_ptr<const PackedLibrary> lib;
  for (int i = 0; i < 50; ++i) {
    lib.reset();
    const double a = NowNs();
    lib = PackedLibrary::Open(dir, name);
    opens.push_back(NowNs() - a);
  }
  std::sort(opens.begin(), opens.end());
  std::printf("%zu assets, %zu archives\n", lib->size(), lib->archives().size());
  std::printf("%-44s median %.3f ms   (target < 5 ms)\n", "PackedLibrary::Open", opens[25] / 1e6);

  Registry::Options options;
  options.assets_dir = assets;
  double a = NowNs();
  Registry registry(options);
  std::printf("%-44s %.3f ms\n", "Registry over the assets dir (opens it)", (NowNs() - a) / 1e6);

  // Random existing UIDs (and some misses), drawn up front.
  Rng rng(6);
  const size_t n = lib->size();
  std::vector<std::string> uids(1000000);
  for (std::string& u : uids) u = std::string(lib->At(rng.UniformInt(n)).uid);
  std::vector<std::string> misses(100000);
  for (size_t i = 0; i < misses.size(); ++i) misses[i] = "missing_" + std::to_string(i) + "_x";

  size_t sink = 0;
  Report(
      "locate: PackedLibrary::Find (hit)", uids.size(),
      [&](size_t i) { sink += lib->Find(uids[i])->archive; }, 1000, 2000);
  Report("locate: PackedLibrary::Find (miss)", misses.size(),
         [&](size_t i) { sink += lib->Find(misses[i]).has_value(); });
  Report("locate: Registry::Locate (path + archive)", 200000,
         [&](size_t i) { sink += registry.Locate(uids[i])->mjcf_path.native().size(); });
  Report(
      "annotation: PackedLibrary::LoadAnnotation", 200000,
      [&](size_t i) { sink += lib->LoadAnnotation(*lib->Find(uids[i]))->json.size(); }, 2000);
  Report("annotation: Registry::GetAnnotation (first)", 100000,
         [&](size_t i) { sink += registry.GetAnnotation(uids[i])->json.size(); });
  Report("annotation: Registry::GetAnnotation (again)", 100000,
         [&](size_t i) { sink += registry.GetAnnotation(uids[i])->json.size(); });
  const std::vector<std::string> filter = {name + "/droid"};
  Report(
      "grasps: PackedLibrary::ReadGrasps (50 rows)", 100000,
      [&](size_t i) {
        const PackedAsset asset = *lib->Find(uids[i]);
        const PackedGraspRef ref = *lib->FindGrasps(asset, "droid", "");
        std::vector<size_t> rows(std::min<size_t>(50, ref.count));
        for (size_t r = 0; r < rows.size(); ++r) rows[r] = r;
        sink += lib->ReadGrasps(ref, &rows).size();
      },
      20000);
  Report(
      "grasps: Registry::LoadGrasps (50)", 100000,
      [&](size_t i) {
        sink += registry.LoadGrasps({uids[i], "", filter}, 50, i).poses.size();
      },
      20000);
  std::printf(
      "resident memory: %ld kB before opening, %ld kB after all of the above "
      "(%zu checksum)\n",
      rss0, RssKb(), sink % 10);

  // Resident memory of a process that only opens the library and locates 10,000 UIDs.
  std::fflush(stdout);
  const pid_t pid = ::fork();
  if (pid == 0) {
    lib.reset();
    const long before = RssKb();
    auto fresh = PackedLibrary::Open(dir, name);
    const long opened = RssKb();
    for (size_t i = 0; i < 10000; ++i) sink += fresh->Find(uids[i])->archive;
    std::printf(
        "resident memory, fresh process: +%ld kB after Open, +%ld kB after 10,000 "
        "locates\n",
        opened - before, RssKb() - before);
    std::fflush(stdout);
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return 0;
}
