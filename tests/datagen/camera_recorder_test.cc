#include "mlspaces/datagen/camera_recorder.h"

#include <cmath>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/video.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

// A small, fast camera system: the DROID cameras at 320 x 192 without shadows or reflections.
CameraSystemConfig SmallCameras() {
  CameraSystemConfig c;
  c.img_resolution = {320, 192};
  c.shadows = false;
  c.reflections = false;
  return c;
}

class CameraRecorderTest : public ::testing::Test {
 protected:
  CameraRecorderTest()
      : env_(Env::Create(sim::Scene::Load(kExample / "scene.xml"),
                         RobotSpecFromConfig(TutorialRobot()), "house_0")) {}
  static RobotConfig TutorialRobot() {
    RobotConfig robot;
    robot.base_size.reset();  // the tutorial's robot stands on the floor
    return robot;
  }
  Env env_;
};

TEST_F(CameraRecorderTest, DroidCamerasSitWhereTheSpecPutsThem) {
  const CameraSystem cams(env_.model(), CameraSystemConfig{});
  ASSERT_EQ(cams.size(), 2u);
  EXPECT_EQ(cams.name(0), "wrist_camera");
  EXPECT_EQ(cams.name(1), "exo_camera_1");
  // The wrist camera is the model camera; the exo camera is offset from fr3_link0 (at the
  // world origin with the base at identity): position = offset.
  const sim::CameraView wrist = cams.View(0, env_.data());
  const int id = mj_name2id(env_.model(), mjOBJ_CAMERA, "robot_0/gripper/wrist_camera");
  for (int a = 0; a < 3; ++a) EXPECT_EQ(wrist.pos[a], env_.data()->cam_xpos[3 * id + a]);
  EXPECT_DOUBLE_EQ(wrist.fovy_deg, 56.74);
  const sim::CameraView exo = cams.View(1, env_.data());
  EXPECT_NEAR(exo.pos[0], 0.1, 1e-12);
  EXPECT_NEAR(exo.pos[1], 0.57, 1e-12);
  EXPECT_NEAR(exo.pos[2], 0.66, 1e-12);
  // It looks down toward the robot's workspace: forward (-z) points down and toward -y.
  EXPECT_LT(-exo.xmat[8], -0.3);
  EXPECT_LT(-exo.xmat[5], -0.3);
  // Moving the base moves the exo camera with it.
  env_.SetRobotBasePose({{1.0, 0, 0}, {1, 0, 0, 0}});
  env_.ForwardPosition();
  EXPECT_NEAR(cams.View(1, env_.data()).pos[0], 1.1, 1e-12);
}

TEST_F(CameraRecorderTest, ParamsFollowTheOriginalsConventions) {
  std::map<std::string, Series> params;
  sim::CameraView v;
  v.pos = {1, 2, 3};
  v.fovy_deg = 90;
  CameraSystem::AppendParams(v, 640, 368, params);
  ASSERT_EQ(params.size(), 3u);
  const auto* c2w = reinterpret_cast<const double*>(params["cam2world_gl"].bytes().data());
  // Identity camera: right = +x, -up = -y, forward = -z, position.
  const double expected[16] = {1, 0, 0, 1, 0, -1, 0, 2, 0, 0, -1, 3, 0, 0, 0, 1};
  for (int i = 0; i < 16; ++i) EXPECT_EQ(c2w[i], expected[i]) << i;
  const auto* ext = reinterpret_cast<const double*>(params["extrinsic_cv"].bytes().data());
  // World to camera maps the camera position to the origin.
  for (int r = 0; r < 3; ++r) {
    double s = ext[4 * r + 3];
    for (int c = 0; c < 3; ++c) s += ext[4 * r + c] * v.pos[c];
    EXPECT_NEAR(s, 0, 1e-12);
  }
  const auto* k = reinterpret_cast<const double*>(params["intrinsic_cv"].bytes().data());
  EXPECT_NEAR(k[0], 184.0, 1e-9);  // (368 / 2) / tan(45 deg)
  EXPECT_EQ(k[2], 320.0);
  EXPECT_EQ(k[5], 184.0);
}

TEST_F(CameraRecorderTest, OneFramePerCaptureInEveryVideo) {
  testing::TempDir dir;
  CameraSystemConfig config = SmallCameras();
  config.record_depth = true;
  CameraRecorder rec(env_.model(), config, 1000.0 / 66.0, sim::GlBackend::kOsMesa);
  rec.Begin(dir.path(), 7);
  for (int i = 0; i < 5; ++i) {
    rec.Capture(env_.data());
    mj_step(env_.model(), env_.data());
  }
  const std::vector<CameraRecord> cams = rec.End();
  ASSERT_EQ(cams.size(), 2u);
  for (const CameraRecord& c : cams) {
    EXPECT_EQ(c.video_file, CameraRecorder::TempVideoName(7, c.name));
    EXPECT_EQ(c.depth_video_file, CameraRecorder::TempVideoName(7, c.name + "_depth"));
    EXPECT_EQ(c.params.at("cam2world_gl").steps(), 5u);
    const VideoInfo info = ProbeVideo(dir / c.video_file);
    EXPECT_EQ(info.frames, 5);
    EXPECT_EQ(info.width, 320);
    EXPECT_EQ(info.height, 192);
    EXPECT_NEAR(info.fps, 1000.0 / 66.0, 0.01);
    EXPECT_EQ(ProbeVideo(dir / c.depth_video_file).frames, 5);
  }
  // The exo camera sees the red block (5 cm, 0.9 m away) near the image centre.
  int red = 0;
  ProbeVideo(dir / cams[1].video_file, [&](const VideoFrame& f) {
    if (f.index != 0) return;
    for (int p = 0; p < f.width * f.height; ++p) {
      const unsigned char* px = f.rgb + 3 * p;
      if (px[0] > 150 && px[1] < 80 && px[2] < 80) ++red;
    }
  });
  EXPECT_GT(red, 25);
  // Abort leaves nothing behind.
  rec.Begin(dir.path(), 8);
  rec.Capture(env_.data());
  rec.Abort();
  for (const auto& e : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".episode_8_"), std::string::npos) << e.path();
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  }
}

// With the default shadows (fitted to what the state's cameras see, one pass), both cameras
// of a state share one set of maps: one map draw per captured state.
TEST_F(CameraRecorderTest, TheCamerasOfAStateShareItsShadowMaps) {
  testing::TempDir dir;
  CameraSystemConfig config;
  config.img_resolution = {160, 96};
  ASSERT_TRUE(config.shadows && config.fit_shadows && config.one_pass_shadows &&
              config.nearest_mipmap);
  CameraRecorder rec(env_.model(), config, 15, sim::GlBackend::kOsMesa);
  rec.Begin(dir.path(), 0);
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 25; ++k) mj_step(env_.model(), env_.data());
    mj_forward(env_.model(), env_.data());
    rec.Capture(env_.data());
  }
  rec.End();
  EXPECT_EQ(rec.renderer().frames(), 6);
  EXPECT_EQ(rec.renderer().one_pass_frames(), 6);
  EXPECT_EQ(rec.renderer().shadow_map_renders(), 3);
  // camera_config.nearest_mipmap reaches the renderer (llvmpipe has sampler objects).
  EXPECT_EQ(rec.renderer().one_pass_nearest_mipmap_frames(), 6);
}

TEST_F(CameraRecorderTest, MissingCamerasAreNamed) {
  CameraSystemConfig config = SmallCameras();
  config.cameras[0].mjcf_name = "gripper/no_camera";
  testing::ExpectError([&] { CameraSystem(env_.model(), config); },
                       {"camera_config.cameras[0].mjcf_name", "robot_0/gripper/no_camera"});
  config = SmallCameras();
  config.cameras[1].reference_body_names = {"nowhere"};
  testing::ExpectError([&] { CameraSystem(env_.model(), config); },
                       {"camera_config.cameras[1].reference_body_names", "nowhere"});
}

}  // namespace
}  // namespace mlspaces::datagen

namespace mlspaces::datagen {
namespace {

// A state's frames do not depend on what the renderer drew before (resumed runs re-render
// an episode in a fresh process and must produce the same video bytes).
TEST_F(CameraRecorderTest, SameStateSameFramesWhateverWasRenderedBefore) {
  const CameraSystemConfig config = SmallCameras();
  const CameraSystem cams(env_.model(), config);
  std::vector<unsigned char> first(3 * 320 * 192), again(3 * 320 * 192);
  mjData* d = env_.data();
  for (int i = 0; i < 40; ++i) mj_step(env_.model(), d);  // somewhere else
  mj_forward(env_.model(), d);  // kinematics of this qpos (mj_step leaves the previous one's)
  const std::vector<double> qpos(d->qpos, d->qpos + env_.model()->nq);
  sim::RenderOptions options;
  options.width = 320;
  options.height = 192;
  {
    sim::Renderer fresh(env_.model(), options);
    fresh.scene().flags[mjRND_SHADOW] = 0;
    fresh.scene().flags[mjRND_REFLECTION] = 0;
    fresh.Render(d, cams.View(0, d), first.data());
  }
  sim::Renderer used(env_.model(), options);
  used.scene().flags[mjRND_SHADOW] = 0;
  used.scene().flags[mjRND_REFLECTION] = 0;
  env_.Reset();
  for (int i = 0; i < 5; ++i) used.Render(d, cams.View(i % 2, d), again.data());
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  mj_forward(env_.model(), d);
  used.Render(d, cams.View(0, d), again.data());
  size_t differ = 0;
  for (size_t i = 0; i < first.size(); ++i) differ += first[i] != again[i] ? 1 : 0;
  EXPECT_EQ(differ, 0u);
}

}  // namespace
}  // namespace mlspaces::datagen
