// Renderer::RenderSegmentation: the geom seen at each pixel, against MuJoCo's ray casts, one
// pass against mjr_render's own segmentation, and the colour frames around it unchanged.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::sim {
namespace {

// Every geom type one pass draws (a mesh, a half-transparent box, a plane), a body with two
// geoms, and a big site in front of the capsule.
constexpr const char* kXml = R"(
<mujoco model="segmentation_test">
  <asset>
    <mesh name="tetra" vertex="0 0 0  0.2 0 0  0 0.2 0  0 0 0.2"/>
  </asset>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true" castshadow="true"/>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.5 0.5 0.5 1"/>
    <body name="pair" pos="0 0 0.1">
      <geom name="pair_box" type="box" size="0.1 0.1 0.1" rgba="1 0 0 1"/>
      <geom name="pair_ball" type="sphere" pos="0 0 0.18" size="0.08" rgba="0 1 0 1"/>
    </body>
    <geom name="capsule" type="capsule" fromto="0.35 -0.3 0.06 0.35 0.3 0.06" size="0.06"/>
    <geom name="cylinder" type="cylinder" pos="-0.35 0.2 0.1" size="0.07 0.1"/>
    <geom name="ellipsoid" type="ellipsoid" pos="-0.3 -0.3 0.1" size="0.1 0.06 0.08"/>
    <geom name="glass" type="box" pos="0 -0.35 0.1" size="0.12 0.02 0.1" rgba="0.2 0.2 1 0.4"/>
    <geom name="tetra" type="mesh" mesh="tetra" pos="0.2 0.35 0"/>
    <site name="marker" pos="0.35 0.45 0.06" size="0.05" rgba="1 1 0 1"/>
  </worldbody>
</mujoco>)";

struct World {
  ModelPtr m;
  DataPtr d;
};

World Load() {
  World w;
  w.m = LoadModelFromMemory(kXml);
  w.d = MakeData(w.m.get());
  mj_forward(w.m.get(), w.d.get());
  return w;
}

RenderOptions Options(bool one_pass) {
  RenderOptions o;
  o.width = 320;
  o.height = 240;
  o.one_pass_shadows = one_pass;
  o.coarse_sides = one_pass;
  o.fit_shadows = one_pass;
  o.shadow_size = 1024;
  o.multisamples = 0;
  return o;
}

const CameraView kView = LookAt({1.1, -0.9, 0.9}, {0, 0, 0.1}, 50);

// The geom mj_ray hits through the centre of pixel (row, col) of `view` (-1: none).
int RayGeom(const mjModel* m, const mjData* d, const CameraView& view, int width, int height,
            int row, int col) {
  const double t = std::tan(view.fovy_deg * mjPI / 360.0);
  const double x = ((col + 0.5) / width * 2 - 1) * t * width / height;
  const double y = (1 - (row + 0.5) / height * 2) * t;
  mjtNum dir[3];
  for (int k = 0; k < 3; ++k) {
    dir[k] = x * view.xmat[3 * k] + y * view.xmat[3 * k + 1] - view.xmat[3 * k + 2];
  }
  int geom = -1;
  mj_ray(m, d, view.pos.data(), dir, nullptr, 1, -1, &geom, nullptr);
  return geom;
}

std::vector<int> Segment(Renderer& r, const mjData* d, const CameraView& view,
                         const std::vector<unsigned char>* interest = nullptr) {
  std::vector<int> ids(static_cast<size_t>(r.width()) * r.height(), -7);
  r.RenderSegmentation(d, view, ids.data(), interest);
  return ids;
}

// Whether `part` lies inside the width x height image and every pixel of `ids` outside it is
// -1 (what RenderSegmentation and SegmentLastFrame return).
::testing::AssertionResult MinusOneOutside(const std::vector<int>& ids, int width, int height,
                                           const PixelRect& part) {
  if (part.x < 0 || part.y < 0 || part.x + part.width > width || part.y + part.height > height) {
    return ::testing::AssertionFailure()
           << "the part " << part.width << "x" << part.height << " at (" << part.x << ", " << part.y
           << ") is not inside the image";
  }
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool inside =
          x >= part.x && x < part.x + part.width && y >= part.y && y < part.y + part.height;
      if (!inside && ids[static_cast<size_t>(y) * width + x] != -1) {
        return ::testing::AssertionFailure() << "pixel " << x << "," << y << " outside the part is "
                                             << ids[static_cast<size_t>(y) * width + x];
      }
    }
  }
  return ::testing::AssertionSuccess();
}

class SegmentationTest : public ::testing::TestWithParam<bool> {};

TEST_P(SegmentationTest, EachPixelShowsTheGeomAMujocoRayHits) {
  World w = Load();
  Renderer r(w.m.get(), Options(GetParam()));
  const std::vector<int> ids = Segment(r, w.d.get(), kView);
  int agree = 0, total = 0;
  std::set<int> seen;
  for (int row = 0; row < r.height(); row += 2) {
    for (int col = 0; col < r.width(); col += 2) {
      const int id = ids[static_cast<size_t>(row) * r.width() + col];
      ASSERT_GE(id, -1);
      ASSERT_LT(id, w.m->ngeom);
      seen.insert(id);
      agree += id == RayGeom(w.m.get(), w.d.get(), kView, r.width(), r.height(), row, col);
      ++total;
    }
  }
  // Pixels on the outlines of tessellated shapes may differ; nothing else.
  EXPECT_GT(agree, 0.97 * total) << agree << " of " << total;
  EXPECT_EQ(static_cast<int>(seen.size()), w.m->ngeom + 1) << "every geom and the background";
}

TEST_P(SegmentationTest, SitesAndTheBackgroundAreNoGeom) {
  World w = Load();
  Renderer r(w.m.get(), Options(GetParam()));
  r.vis_option().sitegroup[0] = 1;
  const int site = mj_name2id(w.m.get(), mjOBJ_SITE, "marker");
  const std::array<double, 3> p{w.d->site_xpos[3 * site], w.d->site_xpos[3 * site + 1],
                                w.d->site_xpos[3 * site + 2]};
  // Looking at the site from above, the floor beyond the plane's edge at the top.
  const CameraView view = LookAt({p[0], p[1] - 0.6, p[2] + 0.4}, p, 40);
  const std::vector<int> ids = Segment(r, w.d.get(), view);
  const int w2 = r.width() / 2, h2 = r.height() / 2;
  EXPECT_EQ(ids[static_cast<size_t>(h2) * r.width() + w2], -1) << "the site";
  r.vis_option().sitegroup[0] = 0;
  const std::vector<int> without = Segment(r, w.d.get(), view);
  EXPECT_EQ(without[static_cast<size_t>(h2) * r.width() + w2],
            RayGeom(w.m.get(), w.d.get(), view, r.width(), r.height(), h2, w2));
  const CameraView sky = LookAt({0, 0, 0.5}, {0, 0, 3}, 40);
  const std::vector<int> up = Segment(r, w.d.get(), sky);
  for (const int id : up) ASSERT_EQ(id, -1);
}

TEST_P(SegmentationTest, LeavesTheColourFramesAsTheyWere) {
  World w = Load();
  Renderer r(w.m.get(), Options(GetParam()));
  const size_t n = static_cast<size_t>(r.width()) * r.height();
  std::vector<unsigned char> before(3 * n), after(3 * n);
  std::vector<float> depth_before(n), depth_after(n);
  r.Render(w.d.get(), kView, before.data(), depth_before.data());
  Segment(r, w.d.get(), kView);
  r.Render(w.d.get(), kView, after.data(), depth_after.data());
  EXPECT_EQ(before, after);
  EXPECT_EQ(depth_before, depth_after);
}

TEST_P(SegmentationTest, ChecksItsArguments) {
  World w = Load();
  Renderer r(w.m.get(), Options(GetParam()));
  std::vector<int> ids(static_cast<size_t>(r.width()) * r.height());
  EXPECT_THROW(r.RenderSegmentation(nullptr, kView, ids.data()), UsageError);
  EXPECT_THROW(r.RenderSegmentation(w.d.get(), kView, nullptr), UsageError);
  CameraView bad = kView;
  bad.fovy_deg = 180;
  EXPECT_THROW(r.RenderSegmentation(w.d.get(), bad, ids.data()), UsageError);
}

INSTANTIATE_TEST_SUITE_P(Paths, SegmentationTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? std::string("OnePass") : std::string("MuJoCo");
                         });

TEST(Segmentation, OnePassEqualsMujocosOwn) {
  World w = Load();
  Renderer one(w.m.get(), Options(true)), mujoco(w.m.get(), Options(false));
  for (const CameraView& view :
       {kView, LookAt({0.2, 0.1, 1.5}, {0, 0, 0}, 45), LookAt({-0.8, 0.6, 0.3}, {0, 0, 0.1}, 60)}) {
    const std::vector<int> a = Segment(one, w.d.get(), view), b = Segment(mujoco, w.d.get(), view);
    size_t same = 0;
    for (size_t i = 0; i < a.size(); ++i) same += a[i] == b[i];
    EXPECT_GT(static_cast<double>(same), 0.999 * static_cast<double>(a.size()))
        << same << " of " << a.size();
  }
}

// With geoms of interest, only the part of the image where they may be is drawn: their pixels
// as in the whole segmentation (what hides them too), -1 around; nothing in view, all -1.
TEST(Segmentation, GeomsOfInterestKeepTheirPixelsInLessWork) {
  World w = Load();
  Renderer r(w.m.get(), Options(true));
  std::vector<unsigned char> interest(static_cast<size_t>(w.m->ngeom), 0);
  for (const char* name : {"pair_box", "pair_ball"}) {
    interest[static_cast<size_t>(mj_name2id(w.m.get(), mjOBJ_GEOM, name))] = 1;
  }
  const std::vector<CameraView> views = {
      kView,                                             // the pair in the middle, small
      LookAt({0.45, 0.0, 0.35}, {0.9, 0.0, 0.35}, 60),   // the pair behind the eye
      LookAt({0.0, -0.13, 0.25}, {0.0, 0.5, 0.25}, 60),  // the box crossing the near plane
      LookAt({0.9, 0.9, 0.6}, {0.0, 0.0, 0.2}, 30),      // the pair at the edge, the glass before
  };
  for (size_t v = 0; v < views.size(); ++v) {
    const std::vector<int> full = Segment(r, w.d.get(), views[v]);
    std::vector<int> part(full.size(), -7);
    const PixelRect rect = r.RenderSegmentation(w.d.get(), views[v], part.data(), &interest);
    ASSERT_TRUE(MinusOneOutside(part, r.width(), r.height(), rect)) << "view " << v;
    if (v == 0) {
      EXPECT_LT(rect.width * rect.height, r.width() * r.height() / 2);
    }
    if (v == 1) {
      EXPECT_EQ(rect.width * rect.height, 0);
    }
    size_t of_interest = 0, dropped = 0;
    for (size_t i = 0; i < full.size(); ++i) {
      const bool wanted = full[i] >= 0 && interest[static_cast<size_t>(full[i])] != 0;
      of_interest += wanted;
      if (wanted) {
        ASSERT_EQ(part[i], full[i]) << "view " << v << " pixel " << i;
      }
      if (part[i] != full[i]) {
        ASSERT_EQ(part[i], -1) << "view " << v << " pixel " << i;
        ++dropped;
      }
    }
    if (v == 0) {
      EXPECT_GT(of_interest, 100u);
      EXPECT_GT(dropped, full.size() / 2) << "most of the image is not drawn";
    }
    if (v == 1) {
      EXPECT_EQ(dropped, full.size() - std::count(full.begin(), full.end(), -1));
    }
  }
}

// Right after a frame, its depth gives the geoms of interest the pixels a segmentation gives
// them; when the frame cannot serve (MuJoCo's passes, multisampling, another render since),
// the segmentation is rendered.
TEST(Segmentation, TheLastFramesDepthShowsTheGeomsOfInterestAsASegmentation) {
  World w = Load();
  const int glass = mj_name2id(w.m.get(), mjOBJ_GEOM, "glass");
  ASSERT_LT(w.m->geom_rgba[4 * glass + 3], 1);
  struct Case {
    RenderOptions options;
    bool shadows;
    bool glass_of_interest = false;
  };
  RenderOptions multisampled = Options(true);
  multisampled.multisamples = 4;
  for (const Case& c :
       {Case{Options(true), true}, Case{Options(true), true, true}, Case{Options(true), false},
        Case{Options(false), true}, Case{multisampled, true}}) {
    const bool from_depth = c.options.one_pass_shadows && c.shadows && c.options.multisamples < 1;
    std::vector<unsigned char> interest(static_cast<size_t>(w.m->ngeom), 0);
    for (const char* name : {"pair_box", "pair_ball", "capsule", "floor"}) {
      interest[static_cast<size_t>(mj_name2id(w.m.get(), mjOBJ_GEOM, name))] = 1;
    }
    // A transparent geom of interest shows where it is in front, as in a segmentation.
    interest[static_cast<size_t>(glass)] = c.glass_of_interest ? 1 : 0;
    for (const CameraView& view : {kView, LookAt({-0.8, 0.6, 0.3}, {0, 0, 0.1}, 60)}) {
      Renderer r(w.m.get(), c.options);
      r.scene().flags[mjRND_SHADOW] = c.shadows ? 1 : 0;
      const size_t n = static_cast<size_t>(r.width()) * r.height();
      std::vector<unsigned char> rgb(3 * n);
      const std::vector<int> full = Segment(r, w.d.get(), view);
      r.Render(w.d.get(), view, rgb.data());
      std::vector<int> last(n, -7);
      const PixelRect rect = r.SegmentLastFrame(w.d.get(), view, last.data(), interest);
      EXPECT_GT(rect.width * rect.height, 0);
      ASSERT_TRUE(MinusOneOutside(last, r.width(), r.height(), rect));
      // Other geoms' pixels are -1, or theirs.
      size_t wanted = 0, same = 0, others_shown = 0, glass_wanted = 0, glass_same = 0;
      for (size_t i = 0; i < n; ++i) {
        if (full[i] < 0 || interest[static_cast<size_t>(full[i])] == 0) {
          // A transparent geom not of interest hides nothing: what is behind it shows.
          const bool transparent = full[i] >= 0 && w.m->geom_rgba[4 * full[i] + 3] < 1;
          others_shown += !transparent && last[i] != -1 && last[i] != full[i];
          continue;
        }
        ++wanted;
        same += last[i] == full[i];
        glass_wanted += full[i] == glass;
        glass_same += full[i] == glass && last[i] == glass;
      }
      EXPECT_LT(others_shown, n / 1000);
      if (c.glass_of_interest) {
        EXPECT_GT(glass_wanted, n / 100);
        EXPECT_GT(static_cast<double>(glass_same), 0.999 * static_cast<double>(glass_wanted))
            << glass_same << " of " << glass_wanted << " pixels of the glass";
      }
      EXPECT_EQ(r.frame_segmentations(), from_depth ? 1 : 0);
      EXPECT_GT(wanted, n / 4);
      EXPECT_GT(static_cast<double>(same), 0.999 * static_cast<double>(wanted))
          << same << " of " << wanted << (c.shadows ? "" : " (no shadows)");
      if (from_depth) std::printf("from the frame's depth: %zu of %zu pixels\n", same, wanted);
      // Another render in between: the frame is gone, the segmentation is rendered.
      r.Render(w.d.get(), view, rgb.data());
      Segment(r, w.d.get(), view);
      r.SegmentLastFrame(w.d.get(), view, last.data(), interest);
      EXPECT_EQ(r.frame_segmentations(), from_depth ? 1 : 0);
      for (size_t i = 0; i < n; ++i) {
        if (full[i] >= 0 && interest[static_cast<size_t>(full[i])] != 0) {
          ASSERT_EQ(last[i], full[i]) << i;
        }
      }
    }
  }
}

}  // namespace
}  // namespace mlspaces::sim
