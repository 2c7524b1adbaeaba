// compute-metadata throughput on generated libraries of N OBJ objects (perturbed UV spheres,
// every 10th with a 512x512 PNG texture): a mixed one (300..10,000 vertices log-uniform) and
// one of ~1,000-vertex objects (800..1,250), each next to MuJoCo's bare mj_loadXML +
// mj_makeData of the same files (1 thread). compute-metadata times the whole command: index
// scan, facts, the *_computed.json files and the index. Then single-asset figures against the
// original's (~1,000 vertices; a textured 8,000-vertex scan), checking the physics-only facts
// against a full compile's. Prints figures and the machine's load average; not a gtest.
//   sim_compute_metadata_bench [N_ASSETS]
#include <sys/resource.h>
#include <zlib.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "mlspaces/core/files.h"
#include "mlspaces/sim/asset_facts.h"
#include "mlspaces/sim/compute_metadata.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

std::string Png(int w, int h, bool noise, std::mt19937& rng) {
  std::string raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);
    for (int x = 0; x < w; ++x) {
      unsigned char v = noise ? static_cast<unsigned char>(rng()) : (x * 255 / w);
      raw += {static_cast<char>(v), static_cast<char>(y * 255 / h), 80};
    }
  }
  uLongf n = compressBound(raw.size());
  std::string z(n, '\0');
  compress(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(raw.data()),
           raw.size());
  z.resize(n);
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  auto chunk = [&](const std::string& type, const std::string& data) {
    std::string td = type + data;
    return be32(data.size()) + td +
           be32(crc32(0, reinterpret_cast<const Bytef*>(td.data()), td.size()));
  };
  std::string ihdr = be32(w) + be32(h) + std::string{8, 2, 0, 0, 0};
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", z) +
         chunk("IEND", "");
}

// Writes <dir>/<uid>/<uid>.{obj,xml,json}; returns the vertex count.
int WriteAsset(const fs::path& dir, const std::string& uid, int target_verts, bool textured,
               int tex_size, bool noise, std::mt19937& rng) {
  int rings = std::max(3, static_cast<int>(std::sqrt(target_verts / 2.0)));
  int segs = std::max(3, (target_verts - 2) / (rings - 1));
  std::normal_distribution<double> jitter(0, 0.05);
  std::string obj;
  obj.reserve(target_verts * 80);
  char buf[128];
  auto vert = [&](double th, double ph) {
    double r = 0.05 * (1 + jitter(rng));
    std::snprintf(buf, sizeof buf, "v %.6f %.6f %.6f\n", r * std::sin(th) * std::cos(ph),
                  r * std::sin(th) * std::sin(ph), 0.6 * r * std::cos(th) + 0.01);
    obj += buf;
  };
  vert(0, 0);
  for (int i = 1; i < rings; ++i) {
    for (int j = 0; j < segs; ++j) vert(M_PI * i / rings, 2 * M_PI * j / segs);
  }
  vert(M_PI, 0);
  int n = 2 + (rings - 1) * segs;
  if (textured) {
    for (int k = 0; k < n; ++k) {
      std::snprintf(buf, sizeof buf, "vt %.4f %.4f\n", (k % 97) / 97.0, (k % 89) / 89.0);
      obj += buf;
    }
  }
  auto id = [&](int ring, int seg) { return 2 + (ring - 1) * segs + (seg % segs); };
  auto face = [&](int a, int b, int c) {
    if (textured) {
      std::snprintf(buf, sizeof buf, "f %d/%d %d/%d %d/%d\n", a, a, b, b, c, c);
    } else {
      std::snprintf(buf, sizeof buf, "f %d %d %d\n", a, b, c);
    }
    obj += buf;
  };
  for (int j = 0; j < segs; ++j) face(1, id(1, j), id(1, j + 1));
  for (int i = 1; i < rings - 1; ++i) {
    for (int j = 0; j < segs; ++j) {
      face(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      face(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  }
  for (int j = 0; j < segs; ++j) face(n, id(rings - 1, j + 1), id(rings - 1, j));
  fs::path d = dir / uid;
  mlspaces::WriteFileAtomic(d / (uid + ".obj"), obj);
  std::string asset = "    <mesh name=\"" + uid + "\" file=\"" + uid + ".obj\"/>\n";
  std::string geom_mat;
  if (textured) {
    mlspaces::WriteFileAtomic(d / (uid + ".png"), Png(tex_size, tex_size, noise, rng));
    asset += "    <texture name=\"tex\" type=\"2d\" file=\"" + uid +
             ".png\"/>\n"
             "    <material name=\"mat\" texture=\"tex\"/>\n";
    geom_mat = " material=\"mat\"";
  }
  mlspaces::WriteFileAtomic(d / (uid + ".xml"),
                            "<mujoco model=\"" + uid + "\">\n  <asset>\n" + asset +
                                "  </asset>\n  <worldbody>\n" + "    <body name=\"" + uid +
                                "\">\n      <freejoint/>\n      <geom type=\"mesh\" mesh=\"" + uid +
                                "\"" + geom_mat + "/>\n    </body>\n  </worldbody>\n</mujoco>\n");
  mlspaces::WriteFileAtomic(d / (uid + ".json"),
                            "{\"assetId\": \"" + uid + "\", \"category\": \"blob\"}");
  return n;
}

double Seconds(Clock::time_point a) {
  return std::chrono::duration<double>(Clock::now() - a).count();
}

double BareLoad(const fs::path& xml) {
  char err[1000];
  auto t = Clock::now();
  mjModel* m = mj_loadXML(xml.c_str(), nullptr, err, sizeof err);
  if (!m) {
    std::fprintf(stderr, "bare load failed: %s\n", err);
    std::exit(1);
  }
  mjData* d = mj_makeData(m);
  double s = Seconds(t);
  mj_deleteData(d);
  mj_deleteModel(m);
  return s;
}

// User + system CPU seconds of this process so far (all threads).
double CpuSeconds() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

// Generates `count` assets under `dir` with vertex counts log-uniform in [lo, hi], then times
// bare loads and compute-metadata with 1 and 2 threads.
void RunLibrary(const fs::path& dir, int count, double lo, double hi, std::mt19937& rng) {
  fs::remove_all(dir);
  std::uniform_real_distribution<double> logn(std::log(lo), std::log(hi));
  std::vector<fs::path> xmls;
  long total_verts = 0;
  auto t = Clock::now();
  for (int i = 0; i < count; ++i) {
    char uid[32];
    std::snprintf(uid, sizeof uid, "obj_%04d", i);
    total_verts +=
        WriteAsset(dir, uid, static_cast<int>(std::exp(logn(rng))), i % 10 == 0, 512, false, rng);
    xmls.push_back(dir / uid / (std::string(uid) + ".xml"));
  }
  std::printf(
      "\n%d assets, %.0f..%.0f vertices (%.0f on average), every 10th textured, "
      "generated in %.1f s\n",
      count, lo, hi, static_cast<double>(total_verts) / count, Seconds(t));
  double bare = 0;
  for (const fs::path& x : xmls) bare += BareLoad(x);
  std::printf("  bare mj_loadXML + mj_makeData, 1 thread : %7.1f assets/s (%.2f ms/asset)\n",
              count / bare, 1000 * bare / count);
  for (int threads : {1, 2}) {
    mlspaces::AssetIndexOptions o;
    o.overwrite = true;
    mlspaces::sim::ComputeMetadataOptions c;
    c.threads = threads;
    t = Clock::now();
    double cpu = CpuSeconds();
    auto r = mlspaces::sim::ComputeAssetMetadata(dir, o, c);
    double s = Seconds(t);
    cpu = CpuSeconds() - cpu;
    std::printf(
        "  compute-metadata, %d thread%s        : %7.1f assets/s (%.2f ms/asset wall, "
        "%.2f ms CPU/asset, %zu ok, %zu failed)\n",
        threads, threads == 1 ? " " : "s", count / s, 1000 * s / count, 1000 * cpu / count,
        r.computed, r.failures.size());
  }
  fs::remove_all(dir);
}

}  // namespace

int main(int argc, char** argv) {
  int count = argc > 1 ? std::atoi(argv[1]) : 1000;
  mlspaces::sim::InstallMujocoHandlers();
  fs::path dir = fs::temp_directory_path() / "mlspaces_cm_bench";
  fs::remove_all(dir);
  std::mt19937 rng(12345);
  std::printf("load average before: %s (%u hardware threads)\n", LoadAverage().c_str(),
              std::thread::hardware_concurrency());
  RunLibrary(dir / "mixed", count, 300, 10000, rng);
  RunLibrary(dir / "v1000", count, 800, 1250, rng);
  std::printf("\n");

  // Single-asset figures against the original's: ~1,000 vertices, and a textured 8,000-vertex
  // "scan" with a 1024x1024 texture.
  fs::path one = dir / "single";
  WriteAsset(one, "v1000", 1000, false, 0, false, rng);
  WriteAsset(one, "scan8000", 8000, true, 1024, true, rng);
  for (const char* uid : {"v1000", "scan8000"}) {
    fs::path x = one / uid / (std::string(uid) + ".xml");
    const int reps = 20;
    double b = 0, fast = 0, full = 0;
    bool bitwise = true;
    for (int k = 0; k < reps; ++k) {
      b += BareLoad(x);
      auto t1 = Clock::now();
      auto f1 = mlspaces::sim::ComputeAssetFacts(x, true);
      fast += Seconds(t1);
      t1 = Clock::now();
      auto f2 = mlspaces::sim::ComputeAssetFacts(x, false);
      full += Seconds(t1);
      bool close = std::fabs(f1.mass - f2.mass) <= 1e-9 * f2.mass;
      for (int i = 0; i < 3; ++i) {
        close = close && std::fabs(f1.aabb_min[i] - f2.aabb_min[i]) <= 1e-9 &&
                std::fabs(f1.aabb_max[i] - f2.aabb_max[i]) <= 1e-9;
      }
      if (!close) {
        std::fprintf(stderr, "fast and full compile disagree on %s\n", uid);
        return 1;
      }
      bitwise =
          bitwise && f1.mass == f2.mass && f1.aabb_min == f2.aabb_min && f1.aabb_max == f2.aabb_max;
    }
    std::printf("%-9s: bare load %.2f ms, our facts %.2f ms (full compile %.2f ms), %s\n", uid,
                1000 * b / reps, 1000 * fast / reps, 1000 * full / reps,
                bitwise ? "bitwise equal" : "equal within 1e-9");
  }
  fs::remove_all(dir);
  std::printf("load average after: %s\n", LoadAverage().c_str());
  return 0;
}
