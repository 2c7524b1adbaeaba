// Pictures of the data engine: the tutorial scene as composed (the red block in view of the
// overview and the exo camera), an episode's frames at its phase changes from a real 1-episode
// run with small cameras, and one-line errors for bad input.
#include "mlspaces/datagen/pictures.h"

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/datagen/task_sampler.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;

const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

ExperimentConfig Tutorial() {
  ExperimentConfig c = LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins());
  c.seed = 1;
  c.camera_config.shadows = false;
  c.camera_config.reflections = false;
  c.camera_config.img_resolution = {96, 64};
  return c;
}

size_t RedPixels(const sim::Image& image, int x0, int y0, int w, int h) {
  size_t n = 0;
  for (int y = y0; y < y0 + h; ++y) {
    for (int x = x0; x < x0 + w; ++x) {
      const sim::Rgb8 c = image.At(x, y);
      n += c[0] > 120 && c[1] < 60 && c[2] < 60 ? 1 : 0;
    }
  }
  return n;
}

/// A 1-episode run of the tutorial with 96x64 cameras (cameras off: no videos).
fs::path SmallRun(const fs::path& dir, bool cameras) {
  ExperimentConfig c = Tutorial();
  c.output_dir = dir;
  c.task_sampler_config.samples_per_house = 1;
  c.task_config.enable_rendering = cameras;
  RunOptions options;
  options.progress = false;
  RunDatagen(c, TaskSamplerRegistry::WithBuiltins(), options);
  return dir;
}

TEST(ScenePictureTest, TheTutorialSceneShowsTheRedBlockInTheOverviewAndTheExoCamera) {
  sim::PictureOptions o;
  o.width = 96;
  o.height = 72;
  const sim::Image picture = ScenePicture(Tutorial(), SceneRequest{}, o);
  // overview, wrist_camera, exo_camera_1 in one row under a title.
  ASSERT_EQ(picture.width, 4 + 3 * (96 + 4));
  const int top = picture.height - 4 - (9 + 6) - 72;  // the tiles' first row
  EXPECT_GT(RedPixels(picture, 4, top, 96, 72), 0u) << "overview";
  EXPECT_GT(RedPixels(picture, 4 + 2 * 100, top, 96, 72), 0u) << "exo camera";
  // Not blank: the tiles hold many colours.
  std::vector<bool> seen(1 << 12);
  size_t distinct = 0;
  for (int y = top; y < top + 72; ++y) {
    for (int x = 4; x < picture.width - 4; ++x) {
      const sim::Rgb8 c = picture.At(x, y);
      const int key = (c[0] >> 4) << 8 | (c[1] >> 4) << 4 | (c[2] >> 4);
      distinct += seen[key] ? 0 : 1;
      seen[key] = true;
    }
  }
  EXPECT_GT(distinct, 20u);
}

TEST(ScenePictureTest, ABadHouseIsAnErrorNamingTheField) {
  SceneRequest r;
  r.house = 7;
  const std::string e = testing::ErrorOf([&] { ScenePicture(Tutorial(), r, {}); });
  EXPECT_NE(e.find("scene_xml_paths"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

TEST(EpisodePicturesTest, FramesAtEachPhaseChangeFromTheVideo) {
  const testing::TempDir tmp;
  const fs::path run = SmallRun(tmp / "run", true);
  const std::vector<EpisodeRef> episodes = ListEpisodes(run);
  ASSERT_EQ(episodes.size(), 1u);
  EXPECT_EQ(episodes[0].traj, "traj_0");
  EXPECT_EQ(ListEpisodes(episodes[0].file).size(), 1u);
  const EpisodeFrames frames = EpisodePhaseFrames(run, 0);
  EXPECT_EQ(frames.camera, "exo_camera_1");  // the first by name
  ASSERT_GE(frames.frames.size(), 4u);
  EXPECT_EQ(frames.frames.front().step, 0);
  EXPECT_EQ(frames.frames.back().step, frames.num_steps - 1);
  std::vector<std::string> names;
  for (size_t i = 0; i < frames.frames.size(); ++i) {
    const PhaseFrame& f = frames.frames[i];
    names.push_back(f.phase_name);
    EXPECT_EQ(f.image.width, 96);
    EXPECT_EQ(f.image.height, 64);
    if (i > 0) {
      EXPECT_GT(f.step, frames.frames[i - 1].step);
    }
  }
  // The pick's phases, in order (docs/datagen.md, "The planner").
  const auto at = [&](const std::string& n) {
    return std::find(names.begin(), names.end(), n) - names.begin();
  };
  EXPECT_LT(at("pregrasp"), at("grasp"));
  EXPECT_LT(at("grasp"), at("gripper-close"));
  EXPECT_LT(at("gripper-close"), at("lift"));
  EXPECT_LT(at("lift"), static_cast<long>(names.size()));
  // The red block is in the exo camera's first frame.
  EXPECT_GT(RedPixels(frames.frames.front().image, 0, 0, 96, 64), 0u);
  const sim::Image sheet = EpisodePhaseSheet(frames, 3, 48);
  EXPECT_EQ(sheet.width, 4 + 3 * (48 + 4));
  // Other camera; errors.
  EXPECT_EQ(EpisodePhaseFrames(run, 0, "wrist_camera").camera, "wrist_camera");
  const std::string cam = testing::ErrorOf([&] { EpisodePhaseFrames(run, 0, "top"); });
  EXPECT_NE(cam.find("no camera 'top' (cameras: exo_camera_1, wrist_camera)"), std::string::npos)
      << cam;
  const std::string range = testing::ErrorOf([&] { EpisodePhaseFrames(run, 1); });
  EXPECT_NE(range.find("episode 1 out of range: the dataset has 1 episodes"), std::string::npos)
      << range;
}

TEST(EpisodePicturesTest, BadDatasetsAreOneLineErrors) {
  const testing::TempDir tmp;
  const std::string missing = testing::ErrorOf([&] { EpisodePhaseFrames(tmp / "nope", 0); });
  EXPECT_NE(missing.find("dataset not found"), std::string::npos) << missing;
  const std::string empty = testing::ErrorOf([&] { EpisodePhaseFrames(tmp.path(), 0); });
  EXPECT_NE(empty.find("not a dataset folder"), std::string::npos) << empty;
  testing::WriteText(tmp / "x.h5", "not hdf5");
  const std::string bad = testing::ErrorOf([&] { EpisodePhaseFrames(tmp / "x.h5", 0); });
  EXPECT_NE(bad.find("cannot read it as an HDF5 batch file"), std::string::npos) << bad;
  const fs::path run = SmallRun(tmp / "nocam", false);
  const std::string novideo = testing::ErrorOf([&] { EpisodePhaseFrames(run, 0); });
  EXPECT_NE(novideo.find("no camera videos"), std::string::npos) << novideo;
  for (const std::string& e : {missing, empty, bad, novideo}) {
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace mlspaces::datagen
