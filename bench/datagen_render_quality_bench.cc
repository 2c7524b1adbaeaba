// Camera rendering: speed against picture quality, on the states of real episodes.
//
// Runs `--episodes` episodes of a datagen config (default: the custom-asset tutorial,
// examples/custom_assets/datagen.yaml; `--config` any other, e.g. examples/open_close's cabinet
// or examples/pick_and_place's table, on its first scene) without cameras, keeping the simulation
// state at every policy step, then renders every kept state from every camera of the config (DROID:
// wrist_camera, exo_camera_1, 640x368) under each render setting below. Per setting it prints the
// mean time of one camera frame (Render: scene update, GL passes, read-back, row flip), frames per
// second, and the mean and minimum SSIM per camera against the full-quality frame of the same state
// (MuJoCo's own settings: 4096² shadow maps over MuJoCo's fixed square, 4x multisampling, shadows
// and reflections); "fit" rows fit the shadow maps to the casters (sim::FitShadowMaps), "map" is
// the side of the map that gives; "one" draws the shadows in one pass (one_pass_shadows), "crs"
// with coarse straight sides (coarse_sides), "mip" sampling textures from the nearest mipmap level
// (nearest_mipmap; the others MuJoCo's trilinear filter). It then times the H.264 encoding of the
// default setting's frames (VideoWriter, the dataset's options) and prints the per-episode cost of
// each stage and the camera episodes per hour per process that follow.
//
// SSIM is skimage.metrics.structural_similarity(a, b, channel_axis=2, data_range=255) with its
// defaults (7x7 uniform window, sample covariance, K1 0.01, K2 0.03, the 3-pixel border left
// out), averaged over the channels.
//
//   datagen_render_quality_bench [--gl osmesa|egl] [--episodes N] [--settings a,b,...]
//                                [--csv FILE] [--config DATAGEN.yaml]
// DUMP=DIR writes each setting's frames of the middle state there (PPM), to look at.
// LP_NUM_THREADS (llvmpipe's threads) is left as the caller sets it; bench/render_bench.sh sets
// 0 (rasterising on the calling thread, as datagen does with one worker per core).
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/camera_recorder.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_runner.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/datagen/video.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/renderer.h"
#include "mlspaces/sim/scene.h"

namespace {

namespace fs = std::filesystem;
namespace dg = mlspaces::datagen;
namespace sim = mlspaces::sim;
using Clock = std::chrono::steady_clock;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double Mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0 : sum / static_cast<double>(v.size());
}

struct Setting {
  std::string name;
  int shadow_size;   // 0: the model's (4096)
  int multisamples;  // -1: the model's (4)
  bool shadows;
  bool reflections;
  bool fit;               // shadow maps fitted to the casters (sim::FitShadowMaps)
  bool one_pass = false;  // shadows in one pass (sim::RenderOptions::one_pass_shadows)
  bool coarse = false;    // coarse straight sides (sim::RenderOptions::coarse_sides)
  bool mip = false;       // nearest mipmap level (sim::RenderOptions::nearest_mipmap)
};

// The curve: from the original's settings down to no shadows. "default" is camera_config's.
std::vector<Setting> AllSettings() {
  const dg::CameraSystemConfig d;
  return {
      {"full", 0, -1, true, true, false},
      {"shadow4096_ms0", 4096, 0, true, true, false},
      {"shadow2048_ms4", 2048, 4, true, true, false},
      {"shadow2048_ms0", 2048, 0, true, true, false},
      {"shadow2048_ms0_norefl", 2048, 0, true, false, false},
      {"shadow1024_ms4", 1024, 4, true, true, false},
      {"shadow1024_ms0", 1024, 0, true, true, false},
      {"shadow512_ms0", 512, 0, true, true, false},
      {"fit4096_ms0", 4096, 0, true, true, true},
      {"fit2048_ms0", 2048, 0, true, true, true},
      {"fit1536_ms0", 1536, 0, true, true, true},
      {"fit1024_ms4", 1024, 4, true, true, true},
      {"fit1024_ms0", 1024, 0, true, true, true},
      {"fit1024_ms0_norefl", 1024, 0, true, false, true},
      {"fit768_ms0", 768, 0, true, true, true},
      {"fit512_ms0", 512, 0, true, true, true},
      {"onepass_fit2048_ms0", 2048, 0, true, true, true, true},
      {"onepass_fit1024_ms0", 1024, 0, true, true, true, true},
      {"onepass_fit1024_ms0_coarse", 1024, 0, true, true, true, true, true},
      {"onepass_fit1024_ms0_coarse_mip", 1024, 0, true, true, true, true, true, true},
      {"onepass_fit1024_ms0_coarse_mip_norefl", 1024, 0, true, false, true, true, true, true},
      {"onepass_fit768_ms0_coarse", 768, 0, true, true, true, true, true},
      {"onepass_fit768_ms0", 768, 0, true, true, true, true},
      {"onepass_shadow2048_ms0", 2048, 0, true, true, false, true},
      {"default", static_cast<int>(d.shadow_size), static_cast<int>(d.multisamples), d.shadows,
       d.reflections, d.fit_shadows, d.one_pass_shadows, d.coarse_sides, d.nearest_mipmap},
      {"noshadow_ms4", 0, 4, false, true, false},
      {"noshadow_ms0", 0, 0, false, true, false},
      {"noshadow_ms0_norefl", 0, 0, false, false, false},
  };
}

// skimage's structural_similarity with its defaults, averaged over the 3 channels. Window sums
// come from summed-area tables (exact in double for 8-bit images of this size).
double Ssim(const std::vector<unsigned char>& a, const std::vector<unsigned char>& b, int w,
            int h) {
  constexpr int kWin = 7, kPad = kWin / 2;
  constexpr double kC1 = (0.01 * 255) * (0.01 * 255), kC2 = (0.03 * 255) * (0.03 * 255);
  constexpr double kNp = kWin * kWin, kCov = kNp / (kNp - 1);
  const size_t W = static_cast<size_t>(w) + 1;
  // Tables of a, b, a², b², ab: t[(y + 1) * W + x + 1] = sum over rows <= y, columns <= x.
  std::vector<double> t[5];
  for (auto& v : t) v.assign(W * (h + 1), 0.0);
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    for (int y = 0; y < h; ++y) {
      double row[5] = {0, 0, 0, 0, 0};
      for (int x = 0; x < w; ++x) {
        const size_t i = (static_cast<size_t>(y) * w + x) * 3 + c;
        const double va = a[i], vb = b[i];
        const double vals[5] = {va, vb, va * va, vb * vb, va * vb};
        const size_t o = (y + 1) * W + x + 1;
        for (int k = 0; k < 5; ++k) {
          row[k] += vals[k];
          t[k][o] = t[k][o - W] + row[k];
        }
      }
    }
    auto box = [&](int k, int y, int x) {  // the window centred at (y, x)
      const size_t y0 = y - kPad, y1 = y + kPad + 1, x0 = x - kPad, x1 = x + kPad + 1;
      return t[k][y1 * W + x1] - t[k][y0 * W + x1] - t[k][y1 * W + x0] + t[k][y0 * W + x0];
    };
    double sum = 0;
    long count = 0;
    for (int y = kPad; y < h - kPad; ++y) {
      for (int x = kPad; x < w - kPad; ++x) {
        const double ma = box(0, y, x) / kNp, mb = box(1, y, x) / kNp;
        const double vxa = kCov * (box(2, y, x) / kNp - ma * ma);
        const double vxb = kCov * (box(3, y, x) / kNp - mb * mb);
        const double cab = kCov * (box(4, y, x) / kNp - ma * mb);
        sum += ((2 * ma * mb + kC1) * (2 * cab + kC2)) /
               ((ma * ma + mb * mb + kC1) * (vxa + vxb + kC2));
        ++count;
      }
    }
    total += sum / static_cast<double>(count);
  }
  return total / 3;
}

struct Options {
  sim::GlBackend gl = sim::GlBackend::kOsMesa;
  int episodes = 4;
  std::vector<std::string> settings;
  std::string csv;
  fs::path config = kExample / "datagen.yaml";
};

Options ParseArgs(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw mlspaces::UsageError(a + " needs a value");
      return argv[++i];
    };
    if (a == "--gl") {
      o.gl = sim::ParseGlBackend(value());
    } else if (a == "--episodes") {
      o.episodes = std::stoi(value());
    } else if (a == "--settings") {
      std::string list = value();
      for (size_t start = 0; start <= list.size();) {
        const size_t comma = std::min(list.find(',', start), list.size());
        o.settings.push_back(list.substr(start, comma - start));
        start = comma + 1;
      }
    } else if (a == "--csv") {
      o.csv = value();
    } else if (a == "--config") {
      o.config = value();
    } else {
      throw mlspaces::UsageError("unknown argument " + a);
    }
  }
  return o;
}

struct Episodes {
  std::vector<std::vector<double>> qpos;  // one per kept state
  int64_t episodes = 0, successes = 0;
  double physics_seconds = 0;  // the whole episodes, cameras off
};

// Runs episodes 0..n-1 of the config's first scene as `mlspaces datagen` does, cameras off.
Episodes RunEpisodes(const dg::ExperimentConfig& config, dg::Env& env, dg::TaskSampler& sampler,
                     mlspaces::Registry& registry, int n) {
  Episodes out;
  dg::EpisodeRunnerOptions options;
  options.scene_name = "house_0";
  options.on_step = [&](const mjModel* m, const mjData* d, int64_t) {
    out.qpos.emplace_back(d->qpos, d->qpos + m->nq);
  };
  dg::EpisodeRunner runner(env, sampler, registry, config, options);
  for (int e = 0; e < n; ++e) {
    const auto t0 = Clock::now();
    const dg::EpisodeResult r = runner.Run(e);
    out.physics_seconds += Since(t0);
    ++out.episodes;
    out.successes += r.success;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options opt = ParseArgs(argc, argv);
    dg::ExperimentConfig config =
        dg::LoadConfigFile(opt.config, dg::ConfigRegistry::WithBuiltins());
    if (!config.seed) config.seed = 1;
    // As `mlspaces datagen` builds a scene's environment (datagen/run.cc).
    mlspaces::Registry registry(mlspaces::Registry::Options{config.libraries.assets_dir});
    config.libraries.ApplyTo(registry);
    auto sampler = dg::TaskSamplerRegistry::WithBuiltins().Create(config, *config.seed);
    dg::Env env = dg::CreateSceneEnv(config, *sampler,
                                     config.task_sampler_config.scene_xml_paths.at(0), "house_0");
    sampler->PrepareEnv(env);
    env.Reset();
    const Episodes eps = RunEpisodes(config, env, *sampler, registry, opt.episodes);
    const mjModel* m = env.model();
    const dg::CameraSystemConfig cams =
        dg::CamerasForRobot(config.camera_config, dg::RobotSpecFromConfig(config.robot_config));
    const dg::CameraSystem system(m, cams);
    const int w = system.width(), h = system.height();
    const size_t ncam = system.size(), nstates = eps.qpos.size();
    std::printf("# %s: %lld episodes (%lld successful), %zu states, %zu cameras at %dx%d, gl %s\n",
                opt.config.filename().string().c_str(), static_cast<long long>(eps.episodes),
                static_cast<long long>(eps.successes), nstates, ncam, w, h,
                std::string(sim::GlBackendName(opt.gl)).c_str());
    const char* lp = std::getenv("LP_NUM_THREADS");
    std::printf("# LP_NUM_THREADS=%s\n", lp ? lp : "(unset)");

    mlspaces::sim::DataPtr data = sim::MakeData(m);
    auto set_state = [&](size_t s) {
      std::copy(eps.qpos[s].begin(), eps.qpos[s].end(), data->qpos);
      mj_forward(m, data.get());
    };
    // Renders every state from every camera: frames [state * ncam + cam].
    auto render_all = [&](const Setting& st, std::vector<double>* times, int* map) {
      dg::CameraSystemConfig c = cams;
      c.shadow_size = st.shadow_size;
      c.multisamples = st.multisamples;
      c.shadows = st.shadows;
      c.reflections = st.reflections;
      c.fit_shadows = st.fit;
      c.one_pass_shadows = st.one_pass;
      c.coarse_sides = st.coarse;
      c.nearest_mipmap = st.mip;
      std::unique_ptr<sim::Renderer> r = dg::MakeCameraRenderer(m, c, opt.gl);
      *map = st.shadows ? r->shadow_size() : 0;
      std::vector<std::vector<unsigned char>> frames(nstates * ncam);
      std::vector<unsigned char> warm(static_cast<size_t>(w) * h * 3);
      set_state(0);
      r->Render(data.get(), system.View(0, data.get()), warm.data());  // first-use compiles
      for (size_t s = 0; s < nstates; ++s) {
        set_state(s);
        std::vector<sim::CameraView> views;  // as the camera recorder: one state's maps shared
        for (size_t k = 0; k < ncam; ++k) views.push_back(system.View(k, data.get()));
        r->SetShadowViews(views);
        for (size_t k = 0; k < ncam; ++k) {
          std::vector<unsigned char>& f = frames[s * ncam + k];
          f.resize(static_cast<size_t>(w) * h * 3);
          const sim::CameraView& view = views[k];
          const auto t0 = Clock::now();
          r->Render(data.get(), view, f.data());
          times->push_back(Since(t0));
        }
      }
      return frames;
    };

    std::vector<double> full_times;
    int full_map = 0;
    const std::vector<std::vector<unsigned char>> full =
        render_all(AllSettings()[0], &full_times, &full_map);
    std::ofstream csv;
    if (!opt.csv.empty()) {
      csv.open(opt.csv);
      csv << "setting,shadow_size,multisamples,shadows,reflections,fit_shadows,one_pass,"
             "coarse_sides,nearest_mipmap,map_size,ms_per_frame,frames_per_s";
      for (size_t k = 0; k < ncam; ++k) {
        csv << ",ssim_mean_" << system.name(k) << ",ssim_min_" << system.name(k);
      }
      csv << "\n";
    }
    std::printf("%-26s %6s %4s %5s %5s %4s %4s %4s %4s %5s %9s %8s", "setting", "shadow", "ms",
                "shdw", "refl", "fit", "one", "crs", "mip", "map", "ms/frame", "frames/s");
    for (size_t k = 0; k < ncam; ++k) std::printf("  ssim %-14s", system.name(k).c_str());
    std::printf("\n");
    double default_ms = 0, full_ms = 0;
    std::vector<std::vector<unsigned char>> default_frames;
    for (const Setting& st : AllSettings()) {
      if (!opt.settings.empty() &&
          std::find(opt.settings.begin(), opt.settings.end(), st.name) == opt.settings.end() &&
          st.name != "full" && st.name != "default") {
        continue;
      }
      std::vector<double> times;
      int map = full_map;
      std::vector<std::vector<unsigned char>> frames =
          st.name == "full" ? full : render_all(st, &times, &map);
      if (const char* dump = std::getenv("DUMP")) {
        for (size_t k = 0; k < ncam; ++k) {
          std::ofstream f(std::string(dump) + "/" + st.name + "_" + std::to_string(k) + ".ppm",
                          std::ios::binary);
          f << "P6 " << w << " " << h << " 255\n";
          const size_t s0 = nstates / 2;
          f.write(reinterpret_cast<const char*>(frames[s0 * ncam + k].data()),
                  static_cast<std::streamsize>(frames[s0 * ncam + k].size()));
        }
      }
      if (st.name == "full") times = full_times;
      // The mean, not the median: with one-pass shadows the first camera of a state draws
      // the maps that the others share, so frames alternate between two costs.
      const double ms = 1e3 * Mean(times);
      std::printf("%-26s %6d %4d %5d %5d %4d %4d %4d %4d %5d %9.2f %8.1f", st.name.c_str(),
                  st.shadow_size, st.multisamples, st.shadows, st.reflections, st.fit, st.one_pass,
                  st.coarse, st.mip, map, ms, 1e3 / ms);
      if (csv.is_open()) {
        csv << st.name << "," << st.shadow_size << "," << st.multisamples << "," << st.shadows
            << "," << st.reflections << "," << st.fit << "," << st.one_pass << "," << st.coarse
            << "," << st.mip << "," << map << "," << ms << "," << 1e3 / ms;
      }
      for (size_t k = 0; k < ncam; ++k) {
        double sum = 0, lo = 1;
        for (size_t s = 0; s < nstates; ++s) {
          const double v = Ssim(full[s * ncam + k], frames[s * ncam + k], w, h);
          sum += v;
          lo = std::min(lo, v);
        }
        std::printf("  mean %.4f min %.4f", sum / nstates, lo);
        if (csv.is_open()) csv << "," << sum / nstates << "," << lo;
      }
      std::printf("\n");
      if (csv.is_open()) csv << "\n";
      if (st.name == "default") {
        default_ms = ms;
        default_frames = std::move(frames);
      }
      if (st.name == "full") full_ms = ms;
    }

    // Encoding of the default frames, per camera as datagen writes them.
    const fs::path tmp =
        fs::temp_directory_path() / ("render_quality_bench_" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    double encode_seconds = 0;
    for (size_t k = 0; k < ncam; ++k) {
      dg::VideoOptions vo;
      vo.crf = static_cast<int>(cams.video_crf);
      vo.preset = cams.video_preset;
      dg::VideoWriter writer(tmp / (system.name(k) + ".mp4"), w, h, vo);
      const auto t0 = Clock::now();
      for (size_t s = 0; s < nstates; ++s) writer.AddFrame(default_frames[s * ncam + k].data());
      writer.Finish();
      encode_seconds += Since(t0);
    }
    fs::remove_all(tmp);
    const double frames = static_cast<double>(nstates * ncam);
    const double per_episode_frames = frames / static_cast<double>(eps.episodes);
    const double physics = eps.physics_seconds / static_cast<double>(eps.episodes);
    const double encode = encode_seconds / static_cast<double>(eps.episodes);
    const double render_default = per_episode_frames * default_ms / 1e3;
    const double render_full = per_episode_frames * full_ms / 1e3;
    std::printf(
        "# per episode: %.0f camera frames; physics+planning %.3f s; encode %.3f s "
        "(%.2f ms/frame); render %.3f s default, %.3f s full\n",
        per_episode_frames, physics, encode, 1e3 * encode_seconds / frames, render_default,
        render_full);
    const double success = static_cast<double>(eps.successes) / static_cast<double>(eps.episodes);
    std::printf(
        "# successful camera episodes per hour per process: default %.0f, full %.0f, "
        "no cameras %.0f (success rate %.2f; from the stage times)\n",
        3600 * success / (physics + encode + render_default),
        3600 * success / (physics + encode + render_full), 3600 * success / physics, success);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "datagen_render_quality_bench: %s\n", e.what());
    return 1;
  }
}
