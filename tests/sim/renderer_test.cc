// Headless rendering (OSMesa and EGL): image layout, colours where the geometry is, metric
// depth, arbitrary camera poses against MuJoCo's own fixed-camera path, errors.
#include "mlspaces/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "test_util.h"

namespace mlspaces::sim {

// Test names and messages show "osmesa"/"egl" (found by ADL, so outside the anonymous namespace).
void PrintTo(GlBackend backend, std::ostream* os) { *os << GlBackendName(backend); }

namespace {

namespace fs = std::filesystem;

// A red box (top face at z = 0.2) on a grey floor; a green marker at +y and a blue one at +x;
// a camera 1.2 m above the floor looking straight down (image up = +y, right = +x) and an
// oblique camera aimed at the box by MuJoCo (mode="targetbody").
constexpr const char* kXml = R"(
<mujoco model="render_test">
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.5 0.5 0.5 1"/>
    <body name="box" pos="0 0 0.1">
      <geom type="box" size="0.1 0.1 0.1" rgba="1 0 0 1"/>
    </body>
    <geom name="green" type="box" pos="0 0.3 0.05" size="0.05 0.05 0.05" rgba="0 1 0 1"/>
    <geom name="blue" type="box" pos="0.5 0 0.05" size="0.05 0.05 0.05" rgba="0 0 1 1"/>
    <camera name="top" pos="0 0 1.2" xyaxes="1 0 0 0 1 0" fovy="45"/>
    <camera name="oblique" pos="0.9 -0.7 0.8" mode="targetbody" target="box" fovy="50"/>
  </worldbody>
</mujoco>)";

struct World {
  ModelPtr m;
  DataPtr d;
};

World LoadWorld() {
  World w;
  w.m = LoadModelFromMemory(kXml);
  w.d = MakeData(w.m.get());
  mj_forward(w.m.get(), w.d.get());
  return w;
}

struct Image {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
  std::vector<float> depth;
  explicit Image(const Renderer& r)
      : width(r.width()),
        height(r.height()),
        rgb(static_cast<size_t>(width) * height * 3),
        depth(static_cast<size_t>(width) * height) {}
  const unsigned char* At(int row, int col) const {
    return &rgb[(static_cast<size_t>(row) * width + col) * 3];
  }
  float DepthAt(int row, int col) const { return depth[static_cast<size_t>(row) * width + col]; }
};

enum class Hue { kRed, kGreen, kBlue };

bool Is(const unsigned char* p, Hue hue) {
  const int c = hue == Hue::kRed ? 0 : hue == Hue::kGreen ? 1 : 2;
  const int o1 = (c + 1) % 3, o2 = (c + 2) % 3;
  return p[c] > 60 && p[c] > p[o1] + 50 && p[c] > p[o2] + 50;
}

// Mean row and column of the pixels of `hue`; {-1, -1} when there are none.
std::pair<double, double> Centroid(const Image& img, Hue hue) {
  double rows = 0, cols = 0;
  long n = 0;
  for (int r = 0; r < img.height; ++r) {
    for (int c = 0; c < img.width; ++c) {
      if (Is(img.At(r, c), hue)) {
        rows += r;
        cols += c;
        ++n;
      }
    }
  }
  if (n == 0) return {-1, -1};
  return {rows / n, cols / n};
}

// Makes a renderer; null with `skip` set when EGL cannot start on this machine.
std::unique_ptr<Renderer> MakeRenderer(const mjModel* m, const RenderOptions& options,
                                       std::string* skip) {
  try {
    return std::make_unique<Renderer>(m, options);
  } catch (const Error& e) {
    const std::string what = e.what();
    const bool unavailable = what.find("cannot load the GL library") != std::string::npos ||
                             what.find("surfaceless") != std::string::npos;
    if (options.backend == GlBackend::kEgl && unavailable) {
      *skip = "EGL is not available here: " + what;
      return nullptr;
    }
    throw;
  }
}

// MAKE_RENDERER_OR_SKIP(r, model, RenderOptions{...}): `r` is a unique_ptr<Renderer>.
#define MAKE_RENDERER_OR_SKIP(var, model, ...)                  \
  std::string var##_skip;                                       \
  auto var = MakeRenderer((model), (__VA_ARGS__), &var##_skip); \
  if (!var) GTEST_SKIP() << var##_skip

// One GL backend per process (MuJoCo takes its GL functions from the platform library loaded
// in the process, libEGL first). When the binary runs
// all its tests at once, a test for the backend this process does not use reruns alone in a
// fresh process; under ctest every test has a process of its own and runs in place.
struct ChildRun {
  bool ran = false;
  bool skipped = false;
  int exit_code = 0;
  std::string output;
};

ChildRun RunInChildIfOtherBackend(GlBackend backend) {
  ChildRun run;
  const auto current = ProcessGlBackend();
  if (!current || *current == backend) return run;
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string name = std::string(info->test_suite_name()) + "." + info->name();
  const mlspaces::testing::CliResult r = mlspaces::testing::RunProgram(
      fs::read_symlink("/proc/self/exe").string(), {"--gtest_filter=" + name});
  run.ran = true;
  run.exit_code = r.exit_code;
  run.output = r.out + r.err;
  run.skipped = r.out.find("[  SKIPPED ]") != std::string::npos;
  return run;
}

#define RUN_IN_CHILD_IF_OTHER_BACKEND(backend)                                  \
  if (const ChildRun child = RunInChildIfOtherBackend(backend); child.ran) {    \
    if (child.skipped) GTEST_SKIP() << "in a child process:\n" << child.output; \
    EXPECT_EQ(child.exit_code, 0) << child.output;                              \
    return;                                                                     \
  }

// ---------------------------------------------------------------------------------------------

TEST(GlBackendNames, ParseAndNameRoundTrip) {
  EXPECT_EQ(ParseGlBackend("osmesa"), GlBackend::kOsMesa);
  EXPECT_EQ(ParseGlBackend("egl"), GlBackend::kEgl);
  EXPECT_EQ(GlBackendName(GlBackend::kOsMesa), "osmesa");
  EXPECT_EQ(GlBackendName(GlBackend::kEgl), "egl");
  EXPECT_THROW(ParseGlBackend("glfw"), UsageError);
  EXPECT_THROW(ParseGlBackend("OSMesa"), UsageError);
  mlspaces::testing::ExpectError([] { ParseGlBackend("vulkan"); }, {"vulkan", "osmesa", "egl"});
}

TEST(RenderOptionsDefaults, Are640x368OsMesa) {
  const RenderOptions o;
  EXPECT_EQ(o.width, 640);
  EXPECT_EQ(o.height, 368);
  EXPECT_EQ(o.backend, GlBackend::kOsMesa);
}

TEST(LookAt, MatchesMuJoCoTargetBodyCamera) {
  const World w = LoadWorld();
  const int cam = mj_name2id(w.m.get(), mjOBJ_CAMERA, "oblique");
  const CameraView model = Renderer::ModelCamera(w.m.get(), w.d.get(), cam);
  const CameraView look = LookAt(model.pos, {0, 0, 0.1}, 50);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(look.xmat[i], model.xmat[i], 1e-12) << i;
  EXPECT_EQ(look.fovy_deg, 50);
  // Straight down: image up is world +y, like the "top" camera.
  const CameraView down = LookAt({0, 0, 1.2}, {0, 0, 0});
  const CameraView top = Renderer::ModelCamera(w.m.get(), w.d.get(), 0);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(down.xmat[i], top.xmat[i], 1e-12) << i;
  EXPECT_THROW(LookAt({1, 2, 3}, {1, 2, 3}), UsageError);
}

TEST(ModelCamera, ReadsPoseAndFovyAndChecksTheId) {
  const World w = LoadWorld();
  const CameraView v = Renderer::ModelCamera(w.m.get(), w.d.get(), 0);
  EXPECT_EQ(v.pos, (std::array<double, 3>{0, 0, 1.2}));
  EXPECT_EQ(v.xmat, (std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  EXPECT_DOUBLE_EQ(v.fovy_deg, 45);
  EXPECT_THROW(Renderer::ModelCamera(w.m.get(), w.d.get(), 2), UsageError);
  EXPECT_THROW(Renderer::ModelCamera(w.m.get(), w.d.get(), -1), UsageError);
}

TEST(RendererErrors, BadOptionsAreUsageErrors) {
  const World w = LoadWorld();
  EXPECT_THROW(Renderer(w.m.get(), RenderOptions{.width = 0}), UsageError);
  EXPECT_THROW(Renderer(w.m.get(), RenderOptions{.height = -3}), UsageError);
  EXPECT_THROW(Renderer(w.m.get(), RenderOptions{.max_geom = 0}), UsageError);
  EXPECT_THROW(Renderer(nullptr, RenderOptions{}), UsageError);
}

TEST(RendererErrors, SecondBackendInOneProcessIsAnError) {
  const World w = LoadWorld();
  const GlBackend first = ProcessGlBackend().value_or(GlBackend::kOsMesa);
  const GlBackend other = first == GlBackend::kOsMesa ? GlBackend::kEgl : GlBackend::kOsMesa;
  MAKE_RENDERER_OR_SKIP(r, w.m.get(), RenderOptions{.width = 32, .height = 32, .backend = first});
  ASSERT_EQ(ProcessGlBackend(), first);
  mlspaces::testing::ExpectError(
      [&] { Renderer(w.m.get(), RenderOptions{.width = 32, .height = 32, .backend = other}); },
      {std::string(GlBackendName(other)) + " renderer",
       "already renders with " + std::string(GlBackendName(first)), "one backend per process"});
  // The first backend still works.
  Image img(*r);
  r->RenderCamera(w.d.get(), 0, img.rgb.data());
  EXPECT_TRUE(Is(img.At(16, 16), Hue::kRed));
}

// ---------------------------------------------------------------------------------------------

class RendererTest : public ::testing::TestWithParam<GlBackend> {};

INSTANTIATE_TEST_SUITE_P(Backends, RendererTest,
                         ::testing::Values(GlBackend::kOsMesa, GlBackend::kEgl),
                         [](const auto& info) { return std::string(GlBackendName(info.param)); });

TEST_P(RendererTest, RendersTheBoxFromAboveWithDepth) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  const World w = LoadWorld();
  MAKE_RENDERER_OR_SKIP(r, w.m.get(), RenderOptions{.backend = GetParam()});
  ASSERT_EQ(r->width(), 640);
  ASSERT_EQ(r->height(), 368);
  EXPECT_EQ(r->backend(), GetParam());
  EXPECT_EQ(ProcessGlBackend(), GetParam());
  Image img(*r);
  img.depth.assign(img.depth.size(), -1.f);
  r->Render(w.d.get(), Renderer::ModelCamera(w.m.get(), w.d.get(), 0), img.rgb.data(),
            img.depth.data());

  // Not blank: many distinct grey levels.
  const auto [lo, hi] = std::minmax_element(img.rgb.begin(), img.rgb.end());
  EXPECT_GT(*hi - *lo, 100);
  const int cr = img.height / 2, cc = img.width / 2;
  EXPECT_TRUE(Is(img.At(cr, cc), Hue::kRed))
      << int(img.At(cr, cc)[0]) << " " << int(img.At(cr, cc)[1]) << " " << int(img.At(cr, cc)[2]);
  EXPECT_FALSE(Is(img.At(5, 5), Hue::kRed));
  // Orientation: +y (green) is up in the image, +x (blue) is right; the box is centred.
  const auto [red_row, red_col] = Centroid(img, Hue::kRed);
  const auto [green_row, green_col] = Centroid(img, Hue::kGreen);
  const auto [blue_row, blue_col] = Centroid(img, Hue::kBlue);
  EXPECT_NEAR(red_row, cr, 3);
  EXPECT_NEAR(red_col, cc, 3);
  ASSERT_GE(green_row, 0);
  ASSERT_GE(blue_row, 0);
  // Pinhole: the marker tops (z = 0.1) are 1.1 m away; f = (h/2) / tan(22.5 deg).
  const double f = (img.height / 2.0) / std::tan(22.5 * mjPI / 180);
  EXPECT_NEAR(green_row, cr - f * 0.3 / 1.1, 4);
  EXPECT_NEAR(green_col, cc, 3);
  EXPECT_NEAR(blue_row, cr, 3);
  EXPECT_NEAR(blue_col, cc + f * 0.5 / 1.1, 4);

  // Depth: the box top is 1.0 m below the camera, the floor 1.2 m (planar depth, everywhere).
  EXPECT_NEAR(img.DepthAt(cr, cc), 1.0, 0.01);
  EXPECT_NEAR(img.DepthAt(2, 2), 1.2, 0.01);
  EXPECT_NEAR(img.DepthAt(img.height - 3, img.width - 3), 1.2, 0.01);
  EXPECT_NEAR(img.DepthAt(static_cast<int>(green_row), static_cast<int>(green_col)), 1.1, 0.01);
}

TEST(EglDevicePlatform, RendersTheSamePictureAsSurfaceless) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GlBackend::kEgl);
  const World w = LoadWorld();
  MAKE_RENDERER_OR_SKIP(
      surfaceless, w.m.get(),
      RenderOptions{.backend = GlBackend::kEgl, .egl_platform = EglPlatform::kSurfaceless});
  EXPECT_EQ(surfaceless->egl_device(), -1);
  std::unique_ptr<Renderer> device;
  try {
    device = std::make_unique<Renderer>(w.m.get(), RenderOptions{.backend = GlBackend::kEgl});
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    if (what.find("device") != std::string::npos) GTEST_SKIP() << what;
    throw;
  }
  Image a(*surfaceless), b(*device);
  const CameraView view = Renderer::ModelCamera(w.m.get(), w.d.get(), 1);
  surfaceless->Render(w.d.get(), view, a.rgb.data(), a.depth.data());
  device->Render(w.d.get(), view, b.rgb.data(), b.depth.data());
  EXPECT_TRUE(Is(b.At(b.height / 2, b.width / 2), Hue::kRed));
  // Without a GPU, Mesa's device is its software device: the same rasteriser, the same bytes;
  // a GPU may round differently, not draw another picture.
  long far = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) far += std::abs(int(a.rgb[i]) - int(b.rgb[i])) > 8;
  EXPECT_LE(far, static_cast<long>(a.rgb.size() / 100));
}

// Sets an environment variable for the scope (unsets it when `value` is null).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) {
      ::setenv(name, value, 1);
    } else {
      ::unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (old_) {
      ::setenv(name_.c_str(), old_->c_str(), 1);
    } else {
      ::unsetenv(name_.c_str());
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

TEST(GlBackendNames, AFlagThenMlspacesGlThenOsMesaAndTheErrorSaysWhichGaveIt) {
  {
    const ScopedEnv none("MLSPACES_GL", nullptr);
    EXPECT_EQ(ResolveGlBackend("", "--gl"), GlBackend::kOsMesa);
  }
  {
    const ScopedEnv empty("MLSPACES_GL", "");
    EXPECT_EQ(ResolveGlBackend("", "--gl"), GlBackend::kOsMesa);
  }
  {
    const ScopedEnv egl("MLSPACES_GL", "egl");
    EXPECT_EQ(ResolveGlBackend("", "--gl"), GlBackend::kEgl);
    EXPECT_EQ(ResolveGlBackend("osmesa", "--gl"), GlBackend::kOsMesa);  // the flag wins
  }
  const ScopedEnv bad("MLSPACES_GL", "vk");
  mlspaces::testing::ExpectError([] { ResolveGlBackend("", "--gl"); },
                                 {"MLSPACES_GL: unknown GL backend 'vk'"});
  mlspaces::testing::ExpectError([] { ResolveGlBackend("glfw", "--gl"); },
                                 {"--gl: unknown GL backend 'glfw'"});
}

// The device list, or a skip reason when EGL has no device platform here.
std::vector<EglDevice> DevicesOrSkip(std::string* skip) {
  try {
    return ListEglDevices();
  } catch (const Error& e) {
    *skip = std::string("no EGL devices here: ") + e.what();
    return {};
  }
}

TEST(EglDevices, WorkersTakeTheDevicesInTurnAndMlspacesEglDeviceChooses) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GlBackend::kEgl);
  std::string skip;
  const std::vector<EglDevice> devices = DevicesOrSkip(&skip);
  if (devices.empty()) GTEST_SKIP() << skip;
  bool any_hardware = false;
  for (size_t i = 0; i < devices.size(); ++i) {
    EXPECT_EQ(devices[i].index, static_cast<int>(i));
    EXPECT_FALSE(devices[i].name.empty());
    any_hardware |= !devices[i].software;
  }
  {
    ScopedEnv env("MLSPACES_EGL_DEVICE", nullptr);
    // Unset: hardware devices in turn (Mesa's software device when there is none).
    for (int worker = 0; worker < 5; ++worker) {
      const int d = ChooseEglDevice(worker);
      ASSERT_GE(d, 0);
      ASSERT_LT(d, static_cast<int>(devices.size()));
      EXPECT_EQ(devices[d].software, !any_hardware) << devices[d].name;
    }
  }
  {
    ScopedEnv env("MLSPACES_EGL_DEVICE", "0");
    EXPECT_EQ(ChooseEglDevice(0), 0);
    EXPECT_EQ(ChooseEglDevice(3), 0);
  }
  {
    // A list: worker k takes entry k mod n.
    ScopedEnv env("MLSPACES_EGL_DEVICE", "0,0,0");
    EXPECT_EQ(ChooseEglDevice(2), 0);
  }
  for (const char* bad : {"99", "x", "0,,0", "-1", "1.5"}) {
    SCOPED_TRACE(bad);
    ScopedEnv env("MLSPACES_EGL_DEVICE", bad);
    mlspaces::testing::ExpectError([] { ChooseEglDevice(0); },
                                   {"MLSPACES_EGL_DEVICE=" + std::string(bad), "devices: 0 ("});
    EXPECT_THROW(ChooseEglDevice(0), UsageError);
  }
}

TEST(EglDevices, ARendererOnTheChosenDeviceRendersTheScene) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GlBackend::kEgl);
  std::string skip;
  const std::vector<EglDevice> devices = DevicesOrSkip(&skip);
  if (devices.empty()) GTEST_SKIP() << skip;
  const World w = LoadWorld();
  const int last = static_cast<int>(devices.size()) - 1;
  Renderer r(
      w.m.get(),
      RenderOptions{.width = 64, .height = 48, .backend = GlBackend::kEgl, .egl_device = last});
  EXPECT_EQ(r.egl_device(), last);
  Image img(r);
  r.RenderCamera(w.d.get(), 0, img.rgb.data());
  EXPECT_TRUE(Is(img.At(24, 32), Hue::kRed));
  // MLSPACES_EGL_DEVICE steers a Renderer that leaves the choice to it.
  {
    ScopedEnv env("MLSPACES_EGL_DEVICE", std::to_string(last).c_str());
    Renderer chosen(w.m.get(), RenderOptions{.width = 8, .height = 8, .backend = GlBackend::kEgl});
    EXPECT_EQ(chosen.egl_device(), last);
  }
  // A device that does not exist: one line naming it and listing the devices.
  mlspaces::testing::ExpectError(
      [&] {
        Renderer(w.m.get(),
                 RenderOptions{
                     .width = 8, .height = 8, .backend = GlBackend::kEgl, .egl_device = last + 7});
      },
      {"no EGL device " + std::to_string(last + 7), "devices: 0 ("});
  {
    ScopedEnv env("MLSPACES_EGL_DEVICE", "42");
    mlspaces::testing::ExpectError(
        [&] {
          Renderer(w.m.get(), RenderOptions{.width = 8, .height = 8, .backend = GlBackend::kEgl});
        },
        {"MLSPACES_EGL_DEVICE=42", "no EGL device 42"});
  }
}

TEST_P(RendererTest, ShadowSizeAndMultisamplesOverrideTheModelsQuality) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  const World w = LoadWorld();
  ASSERT_EQ(w.m->vis.quality.shadowsize, 4096);
  ASSERT_EQ(w.m->vis.quality.offsamples, 4);
  const RenderOptions base{.width = 160, .height = 120, .backend = GetParam()};
  MAKE_RENDERER_OR_SKIP(model_own, w.m.get(), base);
  RenderOptions same = base;
  same.shadow_size = 4096;
  same.multisamples = 4;
  RenderOptions cheap = base;
  cheap.shadow_size = 256;
  cheap.multisamples = 0;
  Renderer explicit_same(w.m.get(), same), cheaper(w.m.get(), cheap);
  const int cam = mj_name2id(w.m.get(), mjOBJ_CAMERA, "oblique");
  Image a(*model_own), b(explicit_same), c(cheaper);
  model_own->RenderCamera(w.d.get(), cam, a.rgb.data());
  explicit_same.RenderCamera(w.d.get(), cam, b.rgb.data());
  cheaper.RenderCamera(w.d.get(), cam, c.rgb.data());
  EXPECT_EQ(a.rgb, b.rgb);                       // 0 / -1 mean the model's own settings
  EXPECT_NE(a.rgb, c.rgb);                       // the cheaper settings take effect ...
  EXPECT_TRUE(Is(c.At(60, 80), Hue::kRed));      // ... and draw the same scene
  EXPECT_EQ(w.m->vis.quality.shadowsize, 4096);  // on the renderer's copy only
  for (const auto& [shadow, samples] : {std::pair{-1, 0}, std::pair{1024, -2}}) {
    RenderOptions bad = base;
    bad.shadow_size = shadow;
    bad.multisamples = samples;
    EXPECT_THROW(Renderer(w.m.get(), bad), UsageError);
  }
}

TEST_P(RendererTest, FreeCameraEqualsMuJoCosFixedCamera) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  const World w = LoadWorld();
  MAKE_RENDERER_OR_SKIP(r, w.m.get(), RenderOptions{.backend = GetParam()});
  const int cam = mj_name2id(w.m.get(), mjOBJ_CAMERA, "oblique");
  Image fixed(*r), free(*r);
  r->RenderCamera(w.d.get(), cam, fixed.rgb.data(), fixed.depth.data());
  r->Render(w.d.get(), Renderer::ModelCamera(w.m.get(), w.d.get(), cam), free.rgb.data(),
            free.depth.data());
  int max_diff = 0;
  long differing = 0;
  for (size_t i = 0; i < fixed.rgb.size(); ++i) {
    const int diff = std::abs(int(fixed.rgb[i]) - int(free.rgb[i]));
    max_diff = std::max(max_diff, diff);
    differing += diff > 0;
  }
  // Float rounding of the averaged eye position only: MuJoCo's fixed camera is two eyes
  // ipd/2 either side, averaged in float (the headlight too), which flips a few pixels on
  // shadow edges (seen with MuJoCo 3.5: 13 pixels of 640x368, up to 89 levels).
  EXPECT_LE(differing, static_cast<long>(fixed.rgb.size() / 10000)) << "max diff " << max_diff;
  float max_depth_diff = 0;
  for (size_t i = 0; i < fixed.depth.size(); ++i) {
    max_depth_diff = std::max(max_depth_diff, std::abs(fixed.depth[i] - free.depth[i]));
  }
  EXPECT_LE(max_depth_diff, 1e-3f);
  // The box is in view, at the centre (the camera aims at its centre).
  EXPECT_TRUE(Is(free.At(free.height / 2, free.width / 2), Hue::kRed));
  // A LookAt pose from the same place gives the same picture.
  Image look(*r);
  r->Render(w.d.get(), LookAt({0.9, -0.7, 0.8}, {0, 0, 0.1}, 50), look.rgb.data());
  EXPECT_EQ(look.rgb, free.rgb);
}

TEST_P(RendererTest, OddSizeLargerThanTheModelsOffscreenBuffer) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  const World w = LoadWorld();
  const int offwidth = w.m->vis.global.offwidth, offheight = w.m->vis.global.offheight;
  ASSERT_LT(offwidth, 1001);
  for (const auto& [width, height] : {std::pair{101, 37}, std::pair{1001, 701}}) {
    SCOPED_TRACE(std::to_string(width) + "x" + std::to_string(height));
    MAKE_RENDERER_OR_SKIP(r, w.m.get(),
                          RenderOptions{.width = width, .height = height, .backend = GetParam()});
    Image img(*r);
    r->RenderCamera(w.d.get(), 0, img.rgb.data(), img.depth.data());
    EXPECT_TRUE(Is(img.At(height / 2, width / 2), Hue::kRed));
    EXPECT_NEAR(img.DepthAt(height / 2, width / 2), 1.0, 0.01);
    const auto [green_row, green_col] = Centroid(img, Hue::kGreen);
    EXPECT_LT(green_row, height / 2.0);
    EXPECT_NEAR(green_col, width / 2.0, 2);
  }
  // The shared model is untouched: the renderer raised its own copy's buffer.
  EXPECT_EQ(w.m->vis.global.offwidth, offwidth);
  EXPECT_EQ(w.m->vis.global.offheight, offheight);
}

TEST_P(RendererTest, TwoRenderersInOneThreadTakeTurns) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  const World w = LoadWorld();
  MAKE_RENDERER_OR_SKIP(a, w.m.get(),
                        RenderOptions{.width = 160, .height = 120, .backend = GetParam()});
  MAKE_RENDERER_OR_SKIP(b, w.m.get(),
                        RenderOptions{.width = 200, .height = 100, .backend = GetParam()});
  Image a1(*a), a2(*a), b1(*b), b2(*b);
  a->RenderCamera(w.d.get(), 1, a1.rgb.data());
  b->RenderCamera(w.d.get(), 0, b1.rgb.data());
  a->RenderCamera(w.d.get(), 1, a2.rgb.data());
  b->RenderCamera(w.d.get(), 0, b2.rgb.data());
  EXPECT_EQ(a1.rgb, a2.rgb);
  EXPECT_EQ(b1.rgb, b2.rgb);
  EXPECT_TRUE(Is(b1.At(50, 100), Hue::kRed));
  a.reset();  // destroying one leaves the other working
  Image b3(*b);
  b->RenderCamera(w.d.get(), 0, b3.rgb.data());
  EXPECT_EQ(b3.rgb, b1.rgb);
}

TEST_P(RendererTest, OneRendererPerThreadInParallel) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  const World w = LoadWorld();
  {  // EGL availability (skips like the other tests)
    MAKE_RENDERER_OR_SKIP(probe, w.m.get(),
                          RenderOptions{.width = 8, .height = 8, .backend = GetParam()});
  }
  constexpr int kThreads = 3;
  std::vector<std::vector<unsigned char>> images(kThreads);
  std::vector<std::string> errors(kThreads);
  std::vector<std::thread> threads;
  threads.reserve(kThreads);
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      try {
        DataPtr d = MakeData(w.m.get());  // one mjData per thread (its scratch stack is used)
        mj_forward(w.m.get(), d.get());
        Renderer r(w.m.get(), RenderOptions{.width = 96, .height = 64, .backend = GetParam()});
        images[t].resize(96 * 64 * 3);
        for (int i = 0; i < 3; ++i) r.RenderCamera(d.get(), 0, images[t].data());
      } catch (const std::exception& e) {
        errors[t] = e.what();
      }
    });
  }
  for (std::thread& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    EXPECT_EQ(errors[t], "") << t;
    EXPECT_EQ(images[t], images[0]) << t;
  }
  EXPECT_TRUE(Is(&images[0][(32 * 96 + 48) * 3], Hue::kRed));
}

TEST_P(RendererTest, FollowsTheStateAndChecksArguments) {
  RUN_IN_CHILD_IF_OTHER_BACKEND(GetParam());
  World w = LoadWorld();
  MAKE_RENDERER_OR_SKIP(r, w.m.get(),
                        RenderOptions{.width = 64, .height = 64, .backend = GetParam()});
  Image img(*r);
  const CameraView top = Renderer::ModelCamera(w.m.get(), w.d.get(), 0);
  r->Render(w.d.get(), top, img.rgb.data());
  EXPECT_TRUE(Is(img.At(32, 32), Hue::kRed));
  // Move the camera 0.5 m along +x: the blue marker is now in the middle.
  CameraView shifted = top;
  shifted.pos[0] += 0.5;
  r->Render(w.d.get(), shifted, img.rgb.data());
  EXPECT_TRUE(Is(img.At(32, 32), Hue::kBlue));
  EXPECT_THROW(r->RenderCamera(w.d.get(), 7, img.rgb.data()), UsageError);
  EXPECT_THROW(r->Render(w.d.get(), CameraView{.fovy_deg = 0}, img.rgb.data()), UsageError);
  EXPECT_THROW(r->Render(nullptr, top, img.rgb.data()), UsageError);
  // Scene flags can be changed between renders.
  r->scene().flags[mjRND_SHADOW] = 0;
  r->Render(w.d.get(), top, img.rgb.data());
  EXPECT_TRUE(Is(img.At(32, 32), Hue::kRed));
}

}  // namespace
}  // namespace mlspaces::sim
