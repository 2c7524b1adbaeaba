// Camera videos are the same bytes for the same config and seed on each renderer (OSMesa, and
// EGL through its device platform with two workers taking devices in turn), with shadows and
// reflections and without multisampling, as the defaults render.
#include <filesystem>
#include <map>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/datagen/config.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

// Two episodes in two batches (so two workers each render one) at a small size, with shadows
// and reflections (small shadow maps: they are most of a frame's cost).
testing::CliResult RunTutorial(const fs::path& out, const std::string& gl, int workers) {
  return testing::RunCli(
      {"datagen", (kExample / "datagen.yaml").string(), "--output", out.string(), "--episodes", "2",
       "--seed", "4", "-q", "--gl", gl, "--workers", std::to_string(workers), "--set",
       "task_sampler_config.episodes_per_batch=1", "--set", "camera_config.img_resolution=[96, 64]",
       "--set", "camera_config.shadow_size=256"});
}

TEST(RenderDeterminismTest, DefaultSettingsRenderFittedShadowsInOnePassWithoutMultisampling) {
  const CameraSystemConfig c;
  EXPECT_TRUE(c.shadows);
  EXPECT_TRUE(c.reflections);
  EXPECT_EQ(c.shadow_size, 1024);
  EXPECT_EQ(c.multisamples, 0);
  EXPECT_TRUE(c.fit_shadows);
  EXPECT_TRUE(c.one_pass_shadows);
  EXPECT_TRUE(c.coarse_sides);
  EXPECT_TRUE(c.nearest_mipmap);
}

class RenderDeterminismTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RenderDeterminismTest, SameConfigAndSeedGiveTheSameVideoBytes) {
  testing::TempDir dir;
  const testing::CliResult a = RunTutorial(dir / "a", GetParam(), 2);
  if (a.exit_code != 0 && GetParam() == "egl" &&
      a.err.find("cannot load the GL library") != std::string::npos) {
    GTEST_SKIP() << "EGL is not available here: " << a.err;
  }
  ASSERT_EQ(a.exit_code, 0) << a.err;
  // OSMesa: two worker processes against one run in the CLI's own process. EGL: two workers
  // both times, since Mesa's EGL device list outlives a run in the process and ASan's leak
  // check sees it (from a library unloaded at exit, so it cannot be suppressed by name).
  const testing::CliResult b = RunTutorial(dir / "b", GetParam(), GetParam() == "egl" ? 2 : 1);
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto va = testing::FilesByExtension(dir / "a", {".mp4"});
  const auto vb = testing::FilesByExtension(dir / "b", {".mp4"});
  EXPECT_EQ(va.size(), 4u);  // 2 episodes x 2 cameras
  ASSERT_EQ(va.size(), vb.size());
  for (const auto& [name, bytes] : va) {
    ASSERT_TRUE(vb.count(name)) << name;
    EXPECT_TRUE(vb.at(name) == bytes) << name << " differs between the runs";
    EXPECT_GT(bytes.size(), 1000u) << name;
  }
}

// A scene one pass cannot draw (a point light): the run goes on through MuJoCo's passes and
// says so once, though two workers render it.
TEST(RenderDeterminismTest, AFrameOnePassCannotDrawIsToldOncePerScene) {
  testing::TempDir dir;
  fs::copy(kExample, dir / "p", fs::copy_options::recursive);
  std::string xml = testing::Slurp(dir / "p/scene.xml");
  xml.replace(
      xml.find("  </worldbody>"), 0,
      "    <light name=\"bulb\" type=\"point\" pos=\"0 0 1.5\" diffuse=\"0.2 0.2 0.2\"/>\n");
  testing::WriteText(dir / "p/scene.xml", xml);
  const testing::CliResult r = testing::RunCli(
      {"datagen", (dir / "p/datagen.yaml").string(), "--output", (dir / "run").string(),
       "--episodes", "2", "--seed", "4", "-q", "--workers", "2", "--set",
       "task_sampler_config.episodes_per_batch=1", "--set", "camera_config.img_resolution=[96, 64]",
       "--set", "camera_config.shadow_size=256"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(testing::FilesByExtension(dir / "run", {".mp4"}).size(), 4u);
  const std::string told =
      "house_0: one-pass shadows cannot draw its camera frames (a point or image light)";
  const size_t at = r.err.find(told);
  ASSERT_NE(at, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(told, at + 1), std::string::npos) << "told twice: " << r.err;
  // The tutorial itself: nothing to tell.
  const testing::CliResult plain = RunTutorial(dir / "plain", "osmesa", 2);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(plain.err.find("one-pass shadows"), std::string::npos) << plain.err;
}

INSTANTIATE_TEST_SUITE_P(Renderers, RenderDeterminismTest, ::testing::Values("osmesa", "egl"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mlspaces::datagen
