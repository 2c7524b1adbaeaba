// object_image_points: the erosion (scipy's), the points drawn from a mask (numpy's rounding),
// the objects of a task, and the points the camera recorder writes for the tutorial scene.
#include "mlspaces/datagen/object_image_points.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/camera_recorder.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/eval_env.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
const fs::path kExample = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";

using Mask = std::vector<unsigned char>;

// The definition of two erosions by the 3x3 cross with the outside unset: every pixel within
// Manhattan distance `n` of a kept pixel is set and inside the image.
Mask ErodeByDefinition(const Mask& m, int w, int h, int n) {
  Mask out(m.size(), 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      bool keep = true;
      for (int dy = -n; dy <= n && keep; ++dy) {
        for (int dx = -n; dx <= n && keep; ++dx) {
          if (std::abs(dx) + std::abs(dy) > n) continue;
          const int u = x + dx, v = y + dy;
          keep = u >= 0 && u < w && v >= 0 && v < h && m[static_cast<size_t>(v) * w + u] != 0;
        }
      }
      out[static_cast<size_t>(y) * w + x] = keep ? 1 : 0;
    }
  }
  return out;
}

TEST(ErodeMask, IsScipysBinaryErosionWithTheCross) {
  // A full 5x5: the border goes, then the ring inside it: the centre alone stays.
  const Mask full(25, 1);
  const Mask once = ErodeMask(full, 5, 5, 1), twice = ErodeMask(full, 5, 5, 2);
  EXPECT_EQ(std::count(once.begin(), once.end(), 1), 9);
  EXPECT_EQ(std::count(twice.begin(), twice.end(), 1), 1);
  EXPECT_EQ(twice[12], 1);
  // Random blobs: equal to the definition for 0, 1, 2 and 3 iterations.
  Rng rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const int w = 5 + static_cast<int>(rng.UniformInt(30)),
              h = 5 + static_cast<int>(rng.UniformInt(30));
    Mask m(static_cast<size_t>(w) * h);
    for (auto& v : m) v = rng.Uniform01() < 0.8 ? 1 : 0;
    for (int n = 0; n <= 3; ++n) {
      ASSERT_EQ(ErodeMask(m, w, h, n), ErodeByDefinition(m, w, h, n)) << trial << " " << n;
    }
  }
  // Thin images erode away; no iteration keeps the mask (as 0 / 1).
  for (const auto& [w, h] : {std::pair{1, 1}, {2, 1}, {1, 3}, {2, 2}, {7, 2}}) {
    const Mask thin(static_cast<size_t>(w) * h, 1);
    EXPECT_EQ(ErodeMask(thin, w, h, 1), Mask(thin.size(), 0)) << w << "x" << h;
  }
  EXPECT_EQ(ErodeMask(Mask{0, 7, 1}, 3, 1, 0), (Mask{0, 1, 1}));
  EXPECT_THROW(ErodeMask(Mask(10), 3, 3, 1), UsageError);
}

Mask Rect(int w, int h, int x0, int y0, int x1, int y1) {
  Mask m(static_cast<size_t>(w) * h, 0);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) m[static_cast<size_t>(y) * w + x] = 1;
  }
  return m;
}

TEST(SampleImagePoints, TenDistinctPixelsOfTheErodedMaskRoundedAsNumpy) {
  const int w = 640, h = 368;
  const Mask m = Rect(w, h, 100, 50, 139, 79);  // 40 x 30
  const Mask eroded = ErodeMask(m, w, h, 2);
  Rng rng(1);
  const ImagePoints p = SampleImagePoints(m, w, h, true, rng);
  ASSERT_EQ(p.count, 10);
  std::set<std::pair<float, float>> seen;
  for (int k = 0; k < 10; ++k) {
    const float x = p.points[2 * k], y = p.points[2 * k + 1];
    const int col = static_cast<int>(std::lround(x * w)),
              row = static_cast<int>(std::lround(y * h));
    EXPECT_EQ(eroded[static_cast<size_t>(row) * w + col], 1) << x << " " << y;
    seen.insert({x, y});
  }
  EXPECT_EQ(seen.size(), 10u);
  // numpy.round(np.float32(col) / 640, 4) in float32 differs from rounding in double here.
  const Mask few = [&] {
    Mask f(static_cast<size_t>(w) * h, 0);
    for (int col : {4, 12, 28}) f[col] = 1;
    return f;
  }();
  Rng untouched(9), reference(9);
  const ImagePoints q = SampleImagePoints(few, w, h, true, untouched);
  ASSERT_EQ(q.count, 3);  // erosion leaves nothing: the mask itself, in row-major order
  EXPECT_EQ(q.points[0], 0.0062f);
  EXPECT_EQ(q.points[2], 0.0188f);
  EXPECT_EQ(q.points[4], 0.0438f);
  EXPECT_EQ(q.points[1], 0.0f);
  for (int k = 6; k < 20; ++k) EXPECT_TRUE(std::isnan(q.points[k])) << k;
  EXPECT_EQ(untouched.NextU64(), reference.NextU64()) << "no draw for ten points or fewer";
  const ImagePoints none = SampleImagePoints(Mask(static_cast<size_t>(w) * h, 0), w, h, true, rng);
  EXPECT_EQ(none.count, 0);
  for (float v : none.points) EXPECT_TRUE(std::isnan(v));
}

// Equal counts and points, NaN equal to NaN.
bool SamePoints(const ImagePoints& a, const ImagePoints& b) {
  return a.count == b.count &&
         std::equal(a.points.begin(), a.points.end(), b.points.begin(),
                    [](float x, float y) { return x == y || (std::isnan(x) && std::isnan(y)); });
}

TEST(SampleImagePoints, AWindowHoldingTheMaskDrawsTheWholeImagesPoints) {
  const int w = 200, h = 100;
  const Mask whole = Rect(w, h, 30, 20, 80, 60);
  Mask window(51 * 41, 1);
  Rng a(3), b(3);
  const ImagePoints p = SampleImagePoints(whole, w, h, true, a);
  const ImagePoints q = SampleImagePoints(window, 51, 41, true, b, {30, 20, w, h});
  EXPECT_TRUE(SamePoints(p, q));
  // Without erosion the border pixels can be drawn too; a different seed draws others.
  Rng c(4);
  const ImagePoints r = SampleImagePoints(whole, w, h, false, c);
  EXPECT_EQ(r.count, 10);
  EXPECT_FALSE(SamePoints(p, r));
}

// The points are the mask's set pixels, listed in row-major order, at the ordinals
// SampleIndices draws: on masks from empty to full, sparse and dense (the draw's two paths).
TEST(SampleImagePoints, DrawsTheSetPixelsAtTheOrdinalsSampleIndicesDraws) {
  Rng masks(21);
  for (const int w : {1, 7, 300}) {
    for (const double density : {0.0, 0.001, 0.05, 0.5, 1.0}) {
      const int h = 97;
      Mask m(static_cast<size_t>(w) * h, 0);
      for (unsigned char& v : m) v = masks.Uniform01() < density ? 3 : 0;  // any non-zero is set
      std::vector<uint32_t> listed;
      for (size_t i = 0; i < m.size(); ++i) {
        if (m[i] != 0) listed.push_back(static_cast<uint32_t>(i));
      }
      Rng a(5), b(5);
      const ImagePoints p = SampleImagePoints(m, w, h, false, a);
      const std::vector<size_t> drawn = SampleIndices(b, listed.size(), kMaxImagePoints);
      ASSERT_EQ(p.count, static_cast<int32_t>(drawn.size())) << w << " " << density;
      for (size_t k = 0; k < drawn.size(); ++k) {
        const uint32_t pixel = listed[drawn[k]];
        const uint32_t column = pixel % w, line = pixel / w;  // the pixel's column and row
        const auto col = static_cast<float>(column), row = static_cast<float>(line);
        EXPECT_EQ(p.points[2 * k], std::nearbyint(col / w * 1e4f) / 1e4f)
            << w << " " << density << " point " << k;
        EXPECT_EQ(p.points[2 * k + 1], std::nearbyint(row / h * 1e4f) / 1e4f);
      }
      EXPECT_EQ(a.NextU64(), b.NextU64());
    }
  }
}

TEST(TracksObjectsIn, LeavesOutFollowerCameras) {
  EXPECT_TRUE(TracksObjectsIn("wrist_camera"));
  EXPECT_FALSE(TracksObjectsIn("exo_Follower_camera"));
}

class ObjectImagePointsTest : public ::testing::Test {
 protected:
  ObjectImagePointsTest()
      : env_(Env::Create(sim::Scene::Load(kExample / "scene.xml"),
                         RobotSpecFromConfig(TutorialRobot()), "house_0")) {}
  static RobotConfig TutorialRobot() {
    RobotConfig robot;
    robot.base_size.reset();
    return robot;
  }
  // The tutorial's pick objects.
  static std::vector<TrackedObject> GripperAndBlock() {
    return {{"gripper", "robot_0/gripper/base"}, {"pickup_obj", "red_block"}};
  }
  Env env_;
};

TEST_F(ObjectImagePointsTest, TheTaskObjectsAreTheOriginals) {
  Task task;
  task.pickup_obj_name = "red_block";
  TaskConfig config;
  config.added_objects = {{"red_block", "block.xml"}, {"not_in_scene", "x.xml"}};
  const std::vector<TrackedObject> pick =
      TaskObjects(env_.model(), task, config, "robot_0/gripper/base");
  ASSERT_EQ(pick.size(), 2u);
  EXPECT_EQ(pick[0].key, "gripper");
  EXPECT_EQ(pick[0].body, "robot_0/gripper/base");
  EXPECT_EQ(pick[1].key, "pickup_obj");  // replaces added_0, the same body
  EXPECT_EQ(pick[1].body, "red_block");
  task.place = TaskPlace{};
  task.place->receptacle = "bowl";
  task.place->other_receptacles = {"plate", "cup"};
  const std::vector<TrackedObject> place = TaskObjects(env_.model(), task, {}, "g");
  std::vector<std::string> keys;
  keys.reserve(place.size());
  for (const TrackedObject& o : place) keys.push_back(o.key + "=" + o.body);
  EXPECT_EQ(keys, (std::vector<std::string>{"gripper=g", "added_0=plate", "added_1=cup",
                                            "pickup_obj=red_block", "place_receptacle=bowl"}));
}

TEST_F(ObjectImagePointsTest, AMissingBodyIsNamed) {
  testing::ExpectError(
      [&] {
        ObjectImagePoints(env_.model(), {{"pickup_obj", "no_such_body"}});
      },
      {"no_such_body", "object_image_points/pickup_obj"});
}

// The recorder's points lie on the object in a segmentation of the same state, ten per
// camera while it is seen, none for an object out of sight; the same seed draws the same.
TEST_F(ObjectImagePointsTest, TheRecorderDrawsThemFromTheObjectsPixels) {
  testing::TempDir dir;
  CameraSystemConfig config;
  config.img_resolution = {320, 192};
  const mjModel* m = env_.model();
  mjData* d = env_.data();
  const std::vector<TrackedObject> objects = GripperAndBlock();
  auto capture = [&](uint64_t seed) {
    CameraRecorder rec(m, config, 15, sim::GlBackend::kOsMesa);
    std::map<std::string, Series> extra;
    rec.Begin(dir.path(), 0, objects, seed);
    rec.Capture(d, &extra);
    rec.Capture(d, nullptr);  // nothing to append to
    rec.End();
    return extra;
  };
  mj_forward(m, d);
  const std::map<std::string, Series> extra = capture(11);
  ASSERT_EQ(extra.size(), 8u);
  const CameraSystem cams(m, config);
  sim::RenderOptions options;
  options.width = 320;
  options.height = 192;
  sim::Renderer seg(m, options);
  std::vector<int> ids(320 * 192);
  const int block = mj_name2id(m, mjOBJ_BODY, "red_block");
  for (size_t c = 0; c < cams.size(); ++c) {
    seg.RenderSegmentation(d, cams.View(c, d), ids.data());
    const std::string base = "object_image_points/pickup_obj/" + cams.name(c) + "/";
    const Series& points = extra.at(base + "points");
    const Series& count = extra.at(base + "num_points");
    ASSERT_EQ(points.steps(), 1u);
    EXPECT_EQ(points.row_shape(), (std::vector<size_t>{10, 2}));
    EXPECT_EQ(count.dtype(), DType::kInt32);
    const int32_t n = *reinterpret_cast<const int32_t*>(count.bytes().data());
    const auto* xy = reinterpret_cast<const float*>(points.bytes().data());
    EXPECT_EQ(n, 10) << cams.name(c) << ": the block is in both cameras' views";
    for (int k = 0; k < n; ++k) {
      const int col = static_cast<int>(std::lround(xy[2 * k] * 320));
      const int row = static_cast<int>(std::lround(xy[2 * k + 1] * 192));
      const int g = ids[static_cast<size_t>(row) * 320 + col];
      ASSERT_GE(g, 0);
      EXPECT_EQ(m->geom_bodyid[g], block) << cams.name(c) << " point " << k;
    }
  }
  // The same seed, the same bytes; another seed, other points.
  EXPECT_EQ(capture(11).at("object_image_points/gripper/wrist_camera/points").bytes(),
            extra.at("object_image_points/gripper/wrist_camera/points").bytes());
  EXPECT_NE(capture(12).at("object_image_points/pickup_obj/exo_camera_1/points").bytes(),
            extra.at("object_image_points/pickup_obj/exo_camera_1/points").bytes());
  // The block far away: out of both views, no points, NaN rows.
  const int jnt = m->body_jntadr[block];
  d->qpos[m->jnt_qposadr[jnt] + 2] = -50;
  mj_forward(m, d);
  const std::map<std::string, Series> hidden = capture(11);
  const Series& gone = hidden.at("object_image_points/pickup_obj/exo_camera_1/num_points");
  EXPECT_EQ(*reinterpret_cast<const int32_t*>(gone.bytes().data()), 0);
  // Switched off: nothing recorded.
  config.object_image_points = false;
  EXPECT_TRUE(capture(11).empty());
}

// Sampling inside the part a segmentation returns draws the whole image's points.
TEST_F(ObjectImagePointsTest, ThePartASegmentationReturnsHoldsThePoints) {
  const mjModel* m = env_.model();
  mjData* d = env_.data();
  mj_forward(m, d);
  const ObjectImagePoints points(m, GripperAndBlock());
  sim::RenderOptions options;
  options.width = 320;
  options.height = 192;
  options.one_pass_shadows = true;
  sim::Renderer r(m, options);
  const CameraSystemConfig config;
  const CameraSystem cams(m, config);
  std::vector<int> ids(320 * 192);
  int smaller = 0;  // the exo camera's part is smaller; the wrist camera's gripper fills it
  for (size_t c = 0; c < cams.size(); ++c) {
    const sim::PixelRect part =
        r.RenderSegmentation(d, cams.View(c, d), ids.data(), &points.tracked_geoms());
    smaller += part.width * part.height < 320 * 192;
    Rng whole_rng(7), part_rng(7);
    const std::vector<ImagePoints> whole = points.Sample(ids.data(), 320, 192, false, whole_rng);
    const std::vector<ImagePoints> inside =
        points.Sample(ids.data(), 320, 192, part, false, part_rng);
    ASSERT_EQ(whole.size(), inside.size());
    for (size_t k = 0; k < whole.size(); ++k) {
      EXPECT_EQ(whole[k].count, 10) << cams.name(c) << " object " << k;
      EXPECT_EQ(inside[k].count, whole[k].count);
      EXPECT_TRUE(SamePoints(inside[k], whole[k])) << cams.name(c) << " object " << k;
    }
    EXPECT_EQ(whole_rng.NextU64(), part_rng.NextU64());
  }
  EXPECT_GT(smaller, 0);
  Rng rng(7);
  testing::ExpectError(
      [&] {
        points.Sample(ids.data(), 320, 192, {300, 0, 21, 5}, false, rng);
      },
      {"part 21x5 at (300, 0)", "320x192"});
}

// An object inside another (the world's subtree holds the block) gets the pixels of its own
// subtree, and the outer one all of them, as masks made by hand give.
TEST_F(ObjectImagePointsTest, NestedObjectsEachGetTheirSubtreesPixels) {
  const mjModel* m = env_.model();
  mjData* d = env_.data();
  mj_forward(m, d);
  const ObjectImagePoints points(m, {{"added_0", "world"}, {"pickup_obj", "red_block"}});
  const int w = 320, h = 192;
  sim::RenderOptions options;
  options.width = w;
  options.height = h;
  sim::Renderer r(m, options);
  const CameraSystemConfig config;
  const CameraSystem cams(m, config);
  const int block = mj_name2id(m, mjOBJ_BODY, "red_block");
  std::vector<int> ids(static_cast<size_t>(w) * h);
  for (size_t c = 0; c < cams.size(); ++c) {
    r.RenderSegmentation(d, cams.View(c, d), ids.data());
    Rng rng(3), reference(3);
    const std::vector<ImagePoints> got = points.Sample(ids.data(), w, h, false, rng);
    ASSERT_EQ(got.size(), 2u);
    for (const bool block_only : {false, true}) {
      auto of = [&](int x, int y) {
        const int g = ids[static_cast<size_t>(y) * w + x];
        return g >= 0 && (!block_only || m->geom_bodyid[g] == block);
      };
      int x0 = w, y0 = h, x1 = -1, y1 = -1;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          if (!of(x, y)) continue;
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
      }
      ASSERT_GE(x1, 0) << "seen in " << cams.name(c);
      Mask mask;
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) mask.push_back(of(x, y) ? 1 : 0);
      }
      const ImagePoints want =
          SampleImagePoints(mask, x1 - x0 + 1, y1 - y0 + 1, true, reference, {x0, y0, w, h});
      EXPECT_EQ(got[block_only ? 1 : 0].count, 10) << cams.name(c);
      EXPECT_TRUE(SamePoints(got[block_only ? 1 : 0], want))
          << cams.name(c) << (block_only ? ": the block" : ": the world");
    }
  }
}

// Reading the points from a frame (the ids it carries) leaves the videos' bytes as they were.
TEST_F(ObjectImagePointsTest, TheVideosAreTheSameWithAndWithoutPoints) {
  testing::TempDir dir;
  CameraSystemConfig config;
  config.img_resolution = {160, 96};
  const mjModel* m = env_.model();
  mjData* d = env_.data();
  auto record = [&](int64_t episode, bool points) {
    CameraRecorder rec(m, config, 15, sim::GlBackend::kOsMesa);
    std::map<std::string, Series> extra;
    mj_resetData(m, d);
    rec.Begin(dir.path(), episode, points ? GripperAndBlock() : std::vector<TrackedObject>{}, 3);
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 20; ++k) mj_step(m, d);
      mj_forward(m, d);
      rec.Capture(d, &extra);
    }
    EXPECT_EQ(extra.size(), points ? 8u : 0u);
    if (points) {
      EXPECT_EQ(rec.renderer().frame_segmentations(), 6);
      EXPECT_EQ(rec.renderer().tracked_segmentations(), 6) << "read from the frames' ids";
    }
    return rec.End();
  };
  const std::vector<CameraRecord> with = record(0, true), without = record(1, false);
  ASSERT_EQ(with.size(), 2u);
  for (size_t c = 0; c < with.size(); ++c) {
    EXPECT_EQ(testing::Slurp(dir / with[c].video_file), testing::Slurp(dir / without[c].video_file))
        << with[c].name;
  }
}

// The evaluation env's observations carry the points as the recorder draws them (the Python
// gym env's replay test compares them with a dataset's): every camera but followers, the
// episode's objects, the frames' count checked.
TEST(EvalEnvImagePoints, ObserveDrawsThePointsOfEachTrackedCamera) {
  ExperimentConfig config =
      LoadConfigFile(kExample / "datagen.yaml", ConfigRegistry::WithBuiltins());
  config.camera_config.img_resolution = {96, 64};
  ASSERT_EQ(config.camera_config.cameras.size(), 2u);
  config.camera_config.cameras[1].name = "exo_Follower";
  auto observe = [&](const ExperimentConfig& c, std::vector<std::vector<ImagePoints>>& points,
                     std::vector<TrackedObject>& objects) {
    EvalEnv eval(c, TaskSamplerRegistry::WithBuiltins().Create(c, 3));
    std::vector<unsigned char> a(96 * 64 * 3), b(a.size());
    std::vector<unsigned char*> frames{a.data(), b.data()};
    testing::ExpectError([&] { eval.Observe(frames, &points); }, {"reset first"});
    eval.Reset(3, 0, 0);
    objects = eval.image_point_objects();
    testing::ExpectError([&] { eval.Observe(std::span(frames).first(1), &points); },
                         {"1 frames for 2 cameras"});
    eval.Observe(frames, &points);
    EXPECT_GT(std::count(a.begin(), a.end(), 0), 0);  // the frames are rendered
    EXPECT_NE(a, b);
  };
  std::vector<std::vector<ImagePoints>> points;
  std::vector<TrackedObject> objects;
  observe(config, points, objects);
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[0].key, "gripper");
  EXPECT_EQ(objects[1].key, "pickup_obj");
  EXPECT_EQ(objects[1].body, "red_block");
  ASSERT_EQ(points.size(), 2u);
  ASSERT_EQ(points[0].size(), 2u);
  EXPECT_EQ(points[0][0].count, kMaxImagePoints);  // the fingers fill the wrist camera
  EXPECT_TRUE(points[1].empty());                  // a follower camera tracks nothing

  config.camera_config.object_image_points = false;
  observe(config, points, objects);
  EXPECT_TRUE(objects.empty());
  ASSERT_EQ(points.size(), 2u);
  EXPECT_TRUE(points[0].empty() && points[1].empty());
}

}  // namespace
}  // namespace mlspaces::datagen
