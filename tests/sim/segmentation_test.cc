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

World Load(const std::string& xml = kXml) {
  World w;
  w.m = LoadModelFromMemory(xml.c_str());
  w.d = MakeData(w.m.get());
  mj_forward(w.m.get(), w.d.get());
  return w;
}

// On OSMesa, or on the backend MLSPACES_GL names (ctest's SegmentationTest.OnEglDevice).
RenderOptions Options(bool one_pass) {
  RenderOptions o;
  o.backend = ResolveGlBackend("", "");
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

// With the geoms of interest tracked (TrackGeoms), the frame carries their ids: SegmentLastFrame
// reads them (nothing drawn, the frame kept) and gives the pixels the depth path gives, and
// the frame's colours and depth are those of an untracked renderer. A transparent geom of
// interest, another interest or another render since take the other paths.
TEST(Segmentation, TrackedGeomsAreReadFromTheFrameWithTheDepthPathsPixels) {
  // The floor reflective: the reflection is drawn first, the floor added over it.
  std::string xml = kXml;
  const std::string floor = R"(rgba="0.5 0.5 0.5 1"/>)";
  xml.replace(xml.find(floor), floor.size(), R"(rgba="0.5 0.5 0.5 1" material="mirror"/>)");
  const std::string assets = "<asset>";
  xml.replace(xml.find(assets), assets.size(),
              R"(<asset><material name="mirror" reflectance="0.4"/>)");
  World w = Load(xml);
  ASSERT_GT(w.m->mat_reflectance[0], 0);
  auto id = [&](const char* name) {
    return static_cast<size_t>(mj_name2id(w.m.get(), mjOBJ_GEOM, name));
  };
  std::vector<unsigned char> interest(static_cast<size_t>(w.m->ngeom), 0);
  // The floor is the reflective plane (added over its reflection), the tetra a mesh.
  for (const char* name : {"pair_box", "pair_ball", "capsule", "floor", "tetra"}) {
    interest[id(name)] = 1;
  }
  for (const CameraView& view : {kView, LookAt({-0.8, 0.6, 0.3}, {0, 0, 0.1}, 60)}) {
    Renderer plain(w.m.get(), Options(true));
    Renderer tracked(w.m.get(), Options(true));
    tracked.TrackGeoms(interest);
    const size_t n = static_cast<size_t>(plain.width()) * plain.height();
    std::vector<unsigned char> rgb0(3 * n), rgb1(3 * n);
    std::vector<float> depth0(n), depth1(n);
    plain.Render(w.d.get(), view, rgb0.data(), depth0.data());
    tracked.Render(w.d.get(), view, rgb1.data(), depth1.data());
    ASSERT_EQ(rgb0, rgb1) << "tracking changes no colour";
    ASSERT_EQ(depth0, depth1);
    std::vector<int> by_depth(n, -7), by_ids(n, -7), again(n, -7);
    const PixelRect r0 = plain.SegmentLastFrame(w.d.get(), view, by_depth.data(), interest);
    const PixelRect r1 = tracked.SegmentLastFrame(w.d.get(), view, by_ids.data(), interest);
    EXPECT_EQ(plain.tracked_segmentations(), 0);
    EXPECT_EQ(tracked.tracked_segmentations(), 1);
    EXPECT_EQ(tracked.frame_segmentations(), 1);
    EXPECT_EQ(r0.x, r1.x);
    EXPECT_EQ(r0.width, r1.width);
    EXPECT_EQ(r0.y, r1.y);
    EXPECT_EQ(r0.height, r1.height);
    ASSERT_TRUE(MinusOneOutside(by_ids, tracked.width(), tracked.height(), r1));
    size_t shown = 0;
    std::set<int> geoms;
    for (size_t i = 0; i < n; ++i) {
      // The depth path may mark other geoms' pixels -1 or not: only these are meant.
      const bool meant = by_depth[i] >= 0 && interest[static_cast<size_t>(by_depth[i])] != 0;
      if (meant) {
        ASSERT_EQ(by_ids[i], by_depth[i]) << "pixel " << i;
        ++shown;
        geoms.insert(by_ids[i]);
      } else {
        ASSERT_EQ(by_ids[i], -1) << "pixel " << i;
      }
    }
    EXPECT_GT(shown, n / 4);
    EXPECT_GE(geoms.size(), 4u);
    // The frame stays: the same again.
    tracked.SegmentLastFrame(w.d.get(), view, again.data(), interest);
    EXPECT_EQ(tracked.tracked_segmentations(), 2);
    EXPECT_EQ(again, by_ids);
    // Another interest: drawn from the depth (the frame is spent), then rendered.
    std::vector<unsigned char> box_only(interest.size(), 0);
    box_only[id("pair_box")] = 1;
    tracked.SegmentLastFrame(w.d.get(), view, again.data(), box_only);
    EXPECT_EQ(tracked.tracked_segmentations(), 2);
    EXPECT_EQ(tracked.frame_segmentations(), 3);
    for (size_t i = 0; i < n; ++i) {
      if (by_ids[i] == static_cast<int>(id("pair_box"))) {
        ASSERT_EQ(again[i], by_ids[i]) << i;
      }
    }
    tracked.SegmentLastFrame(w.d.get(), view, again.data(), interest);
    EXPECT_EQ(tracked.frame_segmentations(), 3);
    EXPECT_EQ(tracked.tracked_segmentations(), 2);
    // A transparent geom of interest: the depth path, the glass where it is in front.
    std::vector<unsigned char> with_glass = interest;
    with_glass[id("glass")] = 1;
    tracked.TrackGeoms(with_glass);
    tracked.Render(w.d.get(), view, rgb1.data());
    ASSERT_EQ(rgb0, rgb1);
    tracked.SegmentLastFrame(w.d.get(), view, again.data(), with_glass);
    EXPECT_EQ(tracked.frame_segmentations(), 4);
    EXPECT_EQ(tracked.tracked_segmentations(), 2);
  }
}

// The ids are a byte: 255 geoms are tracked (the 255th read right), 256 are not (the depth
// path then). A 16 x 16 grid of boxes seen from above.
TEST(Segmentation, UpTo255GeomsAreTracked) {
  // A skybox behind, around a floor smaller than the grid: drawn after the lit pass, it leaves
  // the ids alone.
  std::string xml = R"(<mujoco><asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="64" height="64"/>
    </asset><worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true" castshadow="true"/>
    <geom name="floor" type="plane" size="0.3 0.3 0.1" rgba="0.5 0.5 0.5 1"/>)";
  for (int i = 0; i < 256; ++i) {
    const int col = i % 16, row = i / 16;
    xml += "<geom type=\"box\" size=\"0.02 0.02 0.02\" pos=\"" +
           std::to_string(0.05 * col - 0.375) + " " + std::to_string(0.05 * row - 0.375) +
           " 0.02\" rgba=\"" + std::to_string((i % 7) / 7.0) + " 0.5 " +
           std::to_string((i % 5) / 5.0) + " 1\"/>";
  }
  xml += "</worldbody></mujoco>";
  ModelPtr m = LoadModelFromMemory(xml.c_str());
  DataPtr d = MakeData(m.get());
  mj_forward(m.get(), d.get());
  const CameraView view = LookAt({0, 0, 1.2}, {0, 0, 0}, 45);
  for (const int count : {255, 256}) {
    std::vector<unsigned char> interest(static_cast<size_t>(m->ngeom), 0);
    for (int g = 1; g <= count; ++g) interest[static_cast<size_t>(g)] = 1;  // 0 is the floor
    Renderer r(m.get(), Options(true));
    r.TrackGeoms(interest);
    const size_t n = static_cast<size_t>(r.width()) * r.height();
    std::vector<unsigned char> rgb(3 * n);
    const std::vector<int> full = Segment(r, d.get(), view);
    r.Render(d.get(), view, rgb.data());
    std::vector<int> last(n, -7);
    r.SegmentLastFrame(d.get(), view, last.data(), interest);
    EXPECT_EQ(r.tracked_segmentations(), count == 255 ? 1 : 0);
    std::set<int> seen;
    size_t wanted = 0, same = 0;
    size_t others = 0;
    for (size_t i = 0; i < n; ++i) {
      if (full[i] < 0 || interest[static_cast<size_t>(full[i])] == 0) {
        others += last[i] != -1;
        continue;
      }
      ++wanted;
      same += last[i] == full[i];
      if (last[i] == full[i]) seen.insert(last[i]);
    }
    EXPECT_GT(static_cast<double>(same), 0.999 * static_cast<double>(wanted)) << count;
    if (count == 255) {
      EXPECT_EQ(others, 0u) << "the floor and the sky are no tracked geom";
    }
    EXPECT_EQ(seen.size(), static_cast<size_t>(count)) << "every box seen";
    EXPECT_EQ(seen.count(255), 1u) << "the 255th tracked geom read right";
  }
}

}  // namespace
}  // namespace mlspaces::sim
