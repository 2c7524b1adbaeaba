// Shadows in one pass (RenderOptions::one_pass_shadows): the same pictures as mjr_render's
// per-light passes, the maps drawn once per state, and scenes it cannot draw left to MuJoCo.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::sim {
namespace {

constexpr int kW = 320, kH = 240;

// A reflective checker floor, a textured box, a capsule and a ball; a shadow-casting sun, a
// shadow-casting spot lamp and a fill light without shadows. `buried` adds a block half sunk
// in the floor and a ball under it (which the floor hides), `glass` a transparent geom, `sky`
// a skybox over an infinite floor (with MuJoCo's haze on the horizon).
std::string Xml(bool glass, bool buried = false, bool sky = false) {
  return std::string(R"(
<mujoco>
  <asset>)") +
         (sky ? R"(<texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.8" rgb2="0 0 0"
                            width="64" height="384"/>)"
              : "") +
         R"(
    <texture name="grid" type="2d" builtin="checker" rgb1="0.7 0.7 0.7" rgb2="0.3 0.35 0.4"
             width="256" height="256"/>
    <material name="floor" texture="grid" texrepeat="4 4" texuniform="true" reflectance="0.2"/>
    <texture name="cube" type="cube" builtin="gradient" rgb1="1 0.8 0.2" rgb2="0.2 0.1 0"
             width="64" height="64"/>
    <material name="crate" texture="cube" specular="0.8" shininess="0.6"/>
  </asset>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0.4 0.3 -1" directional="true" castshadow="true"
           diffuse="0.7 0.7 0.7"/>
    <light name="lamp" pos="-0.6 -0.4 1.6" dir="0.4 0.3 -1" cutoff="50" exponent="2"
           castshadow="true" diffuse="0.5 0.4 0.3"/>
    <light name="fill" pos="0 0 3" dir="0 0 -1" directional="true" castshadow="false"
           diffuse="0.2 0.2 0.2"/>
    <geom name="floor" type="plane" size=")" +
         (sky ? "0 0" : "3 3") + R"( 0.1" material="floor"/>
    <geom name="box" type="box" pos="0 0 0.15" size="0.1 0.1 0.15" material="crate"/>
    <geom name="arm" type="capsule" fromto="0.4 0.2 0.3 0.7 0.1 0.6" size="0.04"
          rgba="0 0 1 1"/>
    <body name="ball" pos="-0.3 0.3 0.4">
      <freejoint/>
      <geom type="sphere" size="0.08" rgba="0.9 0.9 0.2 1"/>
    </body>
    <camera name="high" pos="1.2 -1.4 1.3" xyaxes="0.76 0.65 0 -0.4 0.47 0.78" fovy="50"/>
    <camera name="low" pos="-1.3 -0.6 0.5" xyaxes="0.42 -0.91 0 0.2 0.09 0.97" fovy="60"/>)" +
         (buried ? R"(<geom name="sunk" type="box" pos="0.35 -0.35 0.02" size="0.08 0.08 0.06"
                          rgba="0.2 0.8 0.3 1"/>
                    <geom name="under" type="sphere" pos="-0.2 -0.3 -0.3" size="0.2"
                          rgba="1 0 1 1"/>)"
                 : "") +
         (glass ? R"(<geom name="glass" type="box" pos="0.2 -0.3 0.2" size="0.1 0.02 0.2"
                         rgba="0.5 0.8 1 0.4"/>)"
                : "") +
         R"(
  </worldbody>
</mujoco>)";
}

struct World {
  ModelPtr m;
  DataPtr d;
  explicit World(const std::string& xml) {
    m = LoadModelFromMemory(xml);
    d = MakeData(m.get());
    mj_forward(m.get(), d.get());
  }
  explicit World(bool glass = false, bool buried = false, bool sky = false)
      : World(Xml(glass, buried, sky)) {}
  int Camera(const char* name) const { return mj_name2id(m.get(), mjOBJ_CAMERA, name); }
};

RenderOptions Options(bool one_pass, bool fit) {
  RenderOptions o;
  o.width = kW;
  o.height = kH;
  o.shadow_size = 1024;
  o.multisamples = 0;
  o.fit_shadows = fit;
  o.one_pass_shadows = one_pass;
  return o;
}

std::vector<unsigned char> Shoot(Renderer& r, const World& w, const char* camera,
                                 bool shadows = true) {
  r.scene().flags[mjRND_SHADOW] = shadows ? 1 : 0;
  std::vector<unsigned char> rgb(3 * kW * kH);
  r.RenderCamera(w.d.get(), w.Camera(camera), rgb.data());
  return rgb;
}

struct Difference {
  double mean = 0;   // mean absolute difference per channel, in levels
  double share = 0;  // share of pixels with a channel more than `level` apart
};

Difference Compare(const std::vector<unsigned char>& a, const std::vector<unsigned char>& b,
                   int level) {
  Difference out;
  long far = 0;
  for (size_t p = 0; p < a.size() / 3; ++p) {
    int most = 0;
    for (int c = 0; c < 3; ++c) {
      const int diff = std::abs(a[3 * p + c] - b[3 * p + c]);
      out.mean += diff;
      most = std::max(most, diff);
    }
    far += most > level;
  }
  out.mean /= static_cast<double>(a.size());
  out.share = static_cast<double>(far) /
              static_cast<double>(a.size() / 3);  // NOLINT(bugprone-integer-division): pixels
  return out;
}

TEST(ShadowPassTest, DrawsMujocosShadowsInOnePass) {
  for (const bool buried : {false, true}) {
    // With geoms in and under the floor, a pane of glass too (blended as mjr_render does).
    World w(/*glass=*/buried, buried);
    for (const bool fit : {false, true}) {
      Renderer mujoco(w.m.get(), Options(false, fit));
      Renderer one(w.m.get(), Options(true, fit));
      for (const char* cam : {"high", "low"}) {
        SCOPED_TRACE(std::string(cam) + (fit ? ", fitted maps" : ", MuJoCo's square") +
                     (buried ? ", geoms in and under the floor, glass" : ""));
        const std::vector<unsigned char> want = Shoot(mujoco, w, cam);
        const std::vector<unsigned char> got = Shoot(one, w, cam);
        const std::vector<unsigned char> unshadowed = Shoot(mujoco, w, cam, false);
        // The scene has shadows to get right: without them a tenth of the picture changes.
        const Difference shadows = Compare(want, unshadowed, 24);
        EXPECT_GT(shadows.share, 0.05);
        const Difference d = Compare(want, got, 24);
        std::printf(
            "%s%s%s: one pass against MuJoCo: mean %.3f levels, %.4f of pixels > 24 apart"
            " (shadows change %.3f)\n",
            cam, fit ? " fitted" : "", buried ? " buried, glass" : "", d.mean, d.share,
            shadows.share);
        EXPECT_LT(d.mean, 1.0);
        EXPECT_LT(d.share, 0.005);
      }
      EXPECT_EQ(mujoco.shadow_map_renders(), 0);
      EXPECT_GT(one.shadow_map_renders(), 0);
      EXPECT_EQ(one.one_pass_frames(), one.frames());
      EXPECT_EQ(one.one_pass_missed(), "");
    }
  }
}

TEST(ShadowPassTest, DrawsTheMapsOncePerStateForAllCameras) {
  World w;
  Renderer one(w.m.get(), Options(true, true));
  const std::vector<unsigned char> high = Shoot(one, w, "high");
  Shoot(one, w, "low");
  EXPECT_EQ(one.shadow_map_renders(), 1);
  // The same state again: the maps still hold; a moved ball draws them again.
  EXPECT_EQ(Shoot(one, w, "high"), high);
  EXPECT_EQ(one.shadow_map_renders(), 1);
  w.d->qpos[0] += 0.2;
  mj_forward(w.m.get(), w.d.get());
  const std::vector<unsigned char> moved = Shoot(one, w, "high");
  EXPECT_EQ(one.shadow_map_renders(), 2);
  EXPECT_NE(moved, high);
  // And the moved ball's shadow is where MuJoCo draws it.
  Renderer mujoco(w.m.get(), Options(false, true));
  EXPECT_LT(Compare(Shoot(mujoco, w, "high"), moved, 24).share, 0.005);
  // Each of the two maps (sun, lamp) culled its casters' back faces, each time.
  EXPECT_EQ(one.one_pass_culled_draws(), 4);
}

// Camera "high" through both renderers: the shadows change more than `shadow_share` of
// mjr_render's picture, and one pass draws it as mjr_render does.
void ExpectMujocosShadows(Renderer& mujoco, Renderer& one, const World& w, double shadow_share) {
  const std::vector<unsigned char> want = Shoot(mujoco, w, "high");
  EXPECT_GT(Compare(want, Shoot(mujoco, w, "high", false), 24).share, shadow_share);
  const Difference d = Compare(want, Shoot(one, w, "high"), 24);
  std::printf("one pass against MuJoCo: mean %.3f levels, %.4f of pixels > 24 apart\n", d.mean,
              d.share);
  EXPECT_LT(d.mean, 1.0);
  EXPECT_LT(d.share, 0.005);
}

// A lamp inside its shade (an opaque ball round the light): from the lamp every face of the
// ball is a back face, and MuJoCo's map, drawn without culling, holds the ball, so that
// the lamp lights nothing. The map of a caster cut by its near plane keeps the back faces.
TEST(ShadowPassTest, KeepsBackFacesWhereTheyAreAllTheLightSees) {
  const World w(std::string(R"(
<mujoco>
  <worldbody>
    <light name="lamp" pos="0 0 1" dir="0 0 -1" cutoff="60" castshadow="true"
           diffuse="0.8 0.8 0.8"/>
    <light name="sun" pos="0 0 3" dir="0.3 0.2 -1" directional="true" castshadow="true"
           diffuse="0.3 0.3 0.3"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.6 0.6 0.6 1"/>
    <geom name="shade" type="sphere" pos="0 0 1" size="0.05" rgba="0.9 0.9 0.9 1"/>
    <geom name="box" type="box" pos="0.3 0 0.1" size="0.1 0.1 0.1" rgba="0.8 0.2 0.2 1"/>
    <camera name="high" pos="1.2 -1.4 1.3" xyaxes="0.76 0.65 0 -0.4 0.47 0.78" fovy="50"/>
  </worldbody>
</mujoco>)"));
  Renderer mujoco(w.m.get(), Options(false, true));
  Renderer one(w.m.get(), Options(true, true));
  // The shade's shadow is a tenth of the picture: without it the lamp lights the floor.
  ExpectMujocosShadows(mujoco, one, w, 0.05);
  // The sun's map culled; the lamp's did not.
  EXPECT_EQ(one.shadow_map_renders(), 1);
  EXPECT_EQ(one.one_pass_culled_draws(), 1);
}

// A closed mesh (a crate: its convex hull) and an open one (a tent roof without a floor, its
// faces turned inward, away from the sun): the maps cull the crate's back faces, never the
// roof's, which is all back faces from the sun and still casts its shadow, as in mjr_render.
TEST(ShadowPassTest, CullsTheBackFacesOfClosedMeshesOnly) {
  const World w(std::string(R"(
<mujoco>
  <asset>
    <mesh name="crate" vertex="-0.1 -0.1 0  0.1 -0.1 0  0.1 0.1 0  -0.1 0.1 0
                               -0.1 -0.1 0.2  0.1 -0.1 0.2  0.1 0.1 0.2  -0.1 0.1 0.2"/>
    <mesh name="roof" vertex="-0.3 -0.3 0  0.3 -0.3 0  0.3 0.3 0  -0.3 0.3 0  0 0 0.1"
          face="0 4 1  1 4 2  2 4 3  3 4 0" inertia="shell"/>
  </asset>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0.3 0.2 -1" directional="true" castshadow="true"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.6 0.6 0.6 1"/>
    <geom name="crate" type="mesh" mesh="crate" pos="0.4 0 0" rgba="0.8 0.2 0.2 1"/>
    <geom name="roof" type="mesh" mesh="roof" pos="-0.4 0 0.5" rgba="0.2 0.2 0.8 1"/>
    <camera name="high" pos="1.2 -1.4 1.3" xyaxes="0.76 0.65 0 -0.4 0.47 0.78" fovy="50"/>
  </worldbody>
</mujoco>)"));
  // MuJoCo's square (fitted maps bring the near plane down to the casters, which then cuts
  // the roof's bounding sphere: no culling to test).
  Renderer mujoco(w.m.get(), Options(false, false));
  Renderer one(w.m.get(), Options(true, false));
  ExpectMujocosShadows(mujoco, one, w, 0.02);
  EXPECT_EQ(one.shadow_map_renders(), 1);
  EXPECT_EQ(one.one_pass_culled_draws(), 1);  // the crate
}

TEST(ShadowPassTest, LeavesWhatItCannotDrawToMujoco) {
  World w;
  Renderer mujoco(w.m.get(), Options(false, false));
  Renderer one(w.m.get(), Options(true, false));
  // Geom labels: text, which the pass does not draw.
  mujoco.vis_option().label = one.vis_option().label = mjLABEL_GEOM;
  EXPECT_EQ(Shoot(one, w, "high"), Shoot(mujoco, w, "high"));
  EXPECT_EQ(one.shadow_map_renders(), 0);
  // It says why, naming the geom.
  EXPECT_EQ(one.frames(), 1);
  EXPECT_EQ(one.one_pass_frames(), 0);
  EXPECT_EQ(one.one_pass_missed(), "a label ('floor')");
  EXPECT_EQ(mujoco.one_pass_missed(), "");  // one pass off: nothing missed
  // Shadows off: nothing for the pass to do, and nothing missed.
  World plain;
  Renderer off(plain.m.get(), Options(true, false));
  Renderer off_mujoco(plain.m.get(), Options(false, false));
  EXPECT_EQ(Shoot(off, plain, "high", false), Shoot(off_mujoco, plain, "high", false));
  EXPECT_EQ(off.shadow_map_renders(), 0);
  EXPECT_EQ(off.one_pass_missed(), "");
  // Then fog, which the pass does not draw; without it the pass draws again.
  Shoot(off, plain, "high");
  EXPECT_EQ(off.one_pass_frames(), 1);
  off.scene().flags[mjRND_FOG] = 1;
  Shoot(off, plain, "high");
  EXPECT_EQ(off.one_pass_missed(), "fog");
  EXPECT_EQ(off.frames(), 3);
  EXPECT_EQ(off.one_pass_frames(), 1);
}

TEST(ShadowPassTest, DrawsMujocosSkyboxAndHaze) {
  World w(/*glass=*/false, /*buried=*/false, /*sky=*/true);
  World bare;
  Renderer mujoco(w.m.get(), Options(false, true));
  Renderer one(w.m.get(), Options(true, true));
  Renderer bare_mujoco(bare.m.get(), Options(false, true));
  for (const bool haze : {true, false}) {
    mujoco.scene().flags[mjRND_HAZE] = one.scene().flags[mjRND_HAZE] = haze ? 1 : 0;
    const std::vector<unsigned char> want = Shoot(mujoco, w, "low");
    const std::vector<unsigned char> got = Shoot(one, w, "low");
    const Difference d = Compare(want, got, 24);
    std::printf("skybox%s: one pass against MuJoCo: mean %.3f levels, %.4f of pixels > 24 apart\n",
                haze ? " and haze" : "", d.mean, d.share);
    EXPECT_LT(d.mean, 1.0) << "haze " << haze;
    EXPECT_LT(d.share, 0.005) << "haze " << haze;
    if (!haze) {
      // The sky fills a good part of the low camera's view (black without a skybox)...
      EXPECT_GT(Compare(want, Shoot(bare_mujoco, bare, "low"), 24).share, 0.1);
    } else {
      // ... and the haze changes the horizon.
      mujoco.scene().flags[mjRND_HAZE] = 0;
      EXPECT_GT(Compare(want, Shoot(mujoco, w, "low"), 8).share, 0.005);
    }
  }
  EXPECT_GT(one.shadow_map_renders(), 0);
}

TEST(ShadowPassTest, LeavesMujocosDepth) {
  for (const bool sky : {false, true}) {
    World w(/*glass=*/!sky, /*buried=*/!sky, sky);
    Renderer mujoco(w.m.get(), Options(false, true));
    Renderer one(w.m.get(), Options(true, true));
    for (const char* cam : {"high", "low"}) {
      std::vector<unsigned char> rgb(3 * kW * kH);
      std::vector<float> want(kW * kH), got(kW * kH);
      mujoco.RenderCamera(w.d.get(), w.Camera(cam), rgb.data(), want.data());
      one.RenderCamera(w.d.get(), w.Camera(cam), rgb.data(), got.data());
      long apart = 0;
      // A millimetre, or a thousandth beyond a metre (the skybox at 55 m: a few depth steps).
      for (size_t i = 0; i < want.size(); ++i) {
        apart += std::abs(want[i] - got[i]) > 1e-3f * std::max(1.0f, want[i]);
      }
      EXPECT_EQ(apart, 0) << cam << (sky ? " with a skybox" : "");
    }
    EXPECT_GT(one.shadow_map_renders(), 0);
  }
}

// A camera at the floor's edge, looking along +y: a red ball cut by the image's right edge, a
// green mesh bar (its vertices far from the model origin) cut by the left edge, mostly outside, and
// boxes behind the camera and beside the view.
constexpr char kEdgesXml[] = R"(
<mujoco>
  <asset>
    <material name="mirror" rgba="0.6 0.6 0.6 1" reflectance="0.3"/>
    <mesh name="block" vertex="-1.6 -0.05 0.45  -0.9 -0.05 0.45  -1.6 0.05 0.45  -0.9 0.05 0.45
                              -1.6 -0.05 0.55  -0.9 -0.05 0.55  -1.6 0.05 0.55  -0.9 0.05 0.55"/>
  </asset>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0.3 0.5 -1" directional="true" castshadow="true"/>
    <geom name="floor" type="plane" size="4 4 0.1" material="mirror"/>
    <geom name="ball" type="sphere" pos="0.97 0 0.5" size="0.25" rgba="1 0 0 1"/>
    <geom name="block" type="mesh" mesh="block" rgba="0 1 0 1"/>
    <geom name="behind" type="box" pos="0 -3 0.5" size="0.2 0.2 0.2" rgba="0 0 1 1"/>
    <geom name="beside" type="capsule" pos="-3 0 0.5" size="0.1 0.3" rgba="1 1 0 1"/>
    <camera name="edge" pos="0 -2 0.5" xyaxes="1 0 0 0 0 1" fovy="40"/>
  </worldbody>
</mujoco>)";

TEST(ShadowPassTest, LeavesOutOnlyGeomsOutsideTheView) {
  World w{std::string(kEdgesXml)};
  for (const bool fit : {false, true}) {
    SCOPED_TRACE(fit ? "fitted maps" : "MuJoCo's square");
    Renderer mujoco(w.m.get(), Options(false, fit));
    Renderer one(w.m.get(), Options(true, fit));
    const std::vector<unsigned char> want = Shoot(mujoco, w, "edge");
    const std::vector<unsigned char> got = Shoot(one, w, "edge");
    const Difference d = Compare(want, got, 24);
    EXPECT_LT(d.mean, 1.0);
    EXPECT_LT(d.share, 0.005);
    // The geoms cut by the edges are drawn: red at the right edge, green at the left.
    auto pixel = [&](int x, int y) { return &got[3 * (static_cast<size_t>(y) * kW + x)]; };
    const unsigned char* ball = pixel(kW - 8, kH / 2);
    const unsigned char* block = pixel(4, kH / 2);
    EXPECT_GT(ball[0], 60);
    EXPECT_LT(2 * ball[1], ball[0]);
    EXPECT_LT(2 * ball[2], ball[0]);
    EXPECT_GT(block[1], 60);
    EXPECT_LT(2 * block[0], block[1]);
    EXPECT_LT(2 * block[2], block[1]);
    // The boxes behind and beside the camera are left out (of the view and its reflection).
    EXPECT_GE(one.one_pass_left_out(), 4);
    EXPECT_EQ(mujoco.one_pass_left_out(), 0);
    EXPECT_EQ(one.one_pass_frames(), 1);
  }
}

// Straight-sided geoms of several sizes (a robot-like arm of capsules, cylinders, small boxes
// and a big table), shiny, under a sun and a spot lamp, over a reflective floor; a far camera
// and one close to the table's edge.
constexpr char kSidesXml[] = R"(
<mujoco>
  <asset>
    <material name="mirror" rgba="0.6 0.6 0.6 1" reflectance="0.3"/>
    <material name="shiny" rgba="0.8 0.8 0.85 1" specular="0.9" shininess="0.8"/>
    <material name="red" rgba="0.8 0.2 0.2 1" specular="0.7"/>
  </asset>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0.3 0.4 -1" directional="true" castshadow="true"/>
    <light name="lamp" pos="-0.8 -0.6 1.4" dir="0.5 0.4 -1" cutoff="60" exponent="4"
           castshadow="true" diffuse="0.5 0.45 0.4"/>
    <geom name="floor" type="plane" size="3 3 0.1" material="mirror"/>
    <geom name="table" type="box" pos="0.5 0.6 0.35" size="0.6 0.4 0.02" material="shiny"/>
    <geom name="link1" type="capsule" fromto="0 0 0 0 0 0.4" size="0.06" material="shiny"/>
    <geom name="link2" type="capsule" fromto="0 0 0.4 0.3 0.1 0.6" size="0.05" material="shiny"/>
    <geom name="link3" type="cylinder" fromto="0.3 0.1 0.6 0.45 0.2 0.45" size="0.04"
          material="shiny"/>
    <geom name="hand" type="box" pos="0.47 0.22 0.42" size="0.03 0.08 0.02" material="shiny"/>
    <geom name="can" type="cylinder" pos="0.7 0.5 0.45" size="0.04 0.08" material="red"/>
    <geom name="block" type="box" pos="0.3 0.7 0.4" size="0.03 0.03 0.03" rgba="0.2 0.7 0.3 1"/>
    <camera name="far" pos="1.8 -1.6 1.3" xyaxes="0.7 0.7 0 -0.35 0.35 0.87" fovy="50"/>
    <camera name="near" pos="0.2 0.1 0.5" xyaxes="0.8 -0.6 0 0.35 0.47 0.81" fovy="60"/>
  </worldbody>
</mujoco>)";

TEST(ShadowPassTest, CoarseSidesCoverMujocosPixels) {
  World w{std::string(kSidesXml)};
  RenderOptions coarse_options = Options(true, true);
  coarse_options.coarse_sides = true;
  Renderer exact(w.m.get(), Options(true, true));
  Renderer coarse(w.m.get(), coarse_options);
  for (const char* cam : {"far", "near"}) {
    SCOPED_TRACE(cam);
    std::vector<unsigned char> want(3 * kW * kH), got(3 * kW * kH);
    std::vector<float> want_depth(kW * kH), got_depth(kW * kH);
    const long long before = coarse.one_pass_coarse_draws();
    exact.RenderCamera(w.d.get(), w.Camera(cam), want.data(), want_depth.data());
    coarse.RenderCamera(w.d.get(), w.Camera(cam), got.data(), got_depth.data());
    // Some geoms went coarse (the arm and the small boxes from afar)...
    EXPECT_GT(coarse.one_pass_coarse_draws(), before);
    // ... covering the same pixels at the same depths (but for a pixel whose centre lies on
    // a silhouette: MuJoCo's stacked edge has more vertices, collinear up to float rounding)...
    long apart = 0;
    for (size_t i = 0; i < want_depth.size(); ++i) {
      apart += std::abs(want_depth[i] - got_depth[i]) > 1e-4f * std::max(1.0f, want_depth[i]);
    }
    std::printf("%s: %ld of %d pixels at another depth\n", cam, apart, kW * kH);
    EXPECT_LE(apart, 4);
    // ... in nearly the same colours (only the lighting along a side is sampled less often:
    // 0.006 and 0.002 levels; every geom coarse, the table under the lamp and the near
    // camera's too, gives 0.13 on the far camera).
    const Difference d = Compare(want, got, 24);
    std::printf("%s: coarse sides against MuJoCo's: mean %.3f levels, %.4f of pixels > 24 apart\n",
                cam, d.mean, d.share);
    EXPECT_LT(d.mean, 0.05);
    EXPECT_LT(d.share, 0.002);
  }
  EXPECT_EQ(exact.one_pass_coarse_draws(), 0);
  EXPECT_EQ(coarse.one_pass_frames(), coarse.frames());
}

TEST(ShadowPassTest, CoarseSidesKeepMujocosPiecesWhereTheLightingVaries) {
  // The big table seen from close by, and lit by a spot lamp just above it: MuJoCo's quads
  // (a coarse face would lose the lamp's pool of light); a directional light and a far camera
  // let it go coarse.
  auto draws = [](const char* light, const char* camera_pos) {
    const std::string xml = std::string(R"(
<mujoco>
  <worldbody>
    )") + light + R"(
    <geom name="table" type="box" pos="0 0 0.4" size="0.6 0.4 0.02" rgba="0.7 0.6 0.5 1"/>
    <camera name="cam" pos=")" +
                            camera_pos + R"(" xyaxes="1 0 0 0 0.6 0.8" fovy="60"/>
  </worldbody>
</mujoco>)";
    World w{xml};
    RenderOptions o = Options(true, true);
    o.coarse_sides = true;
    Renderer r(w.m.get(), o);
    std::vector<unsigned char> rgb(3 * kW * kH);
    r.RenderCamera(w.d.get(), w.Camera("cam"), rgb.data());
    EXPECT_EQ(r.one_pass_frames(), 1);
    return r.one_pass_coarse_draws();
  };
  constexpr char kSun[] =
      R"(<light pos="0 0 3" dir="0 0 -1" directional="true" castshadow="true"/>)";
  constexpr char kLamp[] = R"(<light pos="0.1 0 0.8" dir="0 0 -1" cutoff="40" castshadow="true"/>)";
  EXPECT_GT(draws(kSun, "0 -8 6"), 0);      // far, directional: one quad a face
  EXPECT_EQ(draws(kLamp, "0 -8 6"), 0);     // far, but the lamp is close
  EXPECT_EQ(draws(kSun, "0 -1.2 1.1"), 0);  // directional, but the camera is close
}

// A lit slab at one end of the casters and a ball at the other, with nothing for their shadows
// to fall on: with shadows the picture is the picture without them. The fitted square puts
// the slab at the map's edge, where mjr_render's lookup (as if the map filled its texture)
// misses the point drawn by up to a texel; on the slab, lit at a slant, that gave shadow acne
// (next_to's bowl in the examples lost 0.02 of wrist SSIM to it).
TEST(ShadowPassTest, LooksTheMapsUpWhereTheyWereDrawn) {
  const World w(std::string(R"(
<mujoco>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0.3 0.2 -1" directional="true" castshadow="true"
           diffuse="0.8 0.8 0.8"/>
    <geom name="slab" type="box" pos="-0.6 0 0.3" euler="0 50 0" size="0.3 0.3 0.02"
          rgba="0.9 0.9 0.9 1"/>
    <geom name="ball" type="sphere" pos="0.8 0.5 0.3" size="0.05" rgba="0.9 0.2 0.2 1"/>
    <camera name="high" pos="-0.2 -1.0 0.9" xyaxes="1 0 0 0 0.6 0.8" fovy="50"/>
  </worldbody>
</mujoco>)"));
  for (const int size : {1024, 256}) {
    SCOPED_TRACE("shadow_size " + std::to_string(size));
    RenderOptions o = Options(true, true);
    o.shadow_size = size;
    Renderer one(w.m.get(), o);
    const std::vector<unsigned char> lit = Shoot(one, w, "high", false);
    const std::vector<unsigned char> got = Shoot(one, w, "high");
    EXPECT_EQ(one.one_pass_frames(), 1);  // the shadowed frame; without shadows mjr_render
    // The slab fills a good part of the picture, lit.
    const std::vector<unsigned char> black(lit.size(), 0);
    EXPECT_GT(Compare(lit, black, 100).share, 0.1);
    const Difference d = Compare(got, lit, 24);
    std::printf("size %d: with shadows against without: %.4f of pixels > 24 apart\n", size,
                d.share);
    EXPECT_LT(d.share, 0.0003);  // 0.0008 and 0.0035 with mjr_render's lookup
  }
}

TEST(ShadowPassTest, RendersTheSameBytesEachTime) {
  World w;
  Renderer a(w.m.get(), Options(true, true));
  Renderer b(w.m.get(), Options(true, true));
  EXPECT_EQ(Shoot(a, w, "low"), Shoot(b, w, "low"));
  EXPECT_EQ(Shoot(a, w, "high"), Shoot(b, w, "high"));
}

// nearest_mipmap: the floor's checker and the crate's cube texture from one mipmap level, close
// to MuJoCo's trilinear filter; MuJoCo's own passes in the same context keep their filter.
TEST(ShadowPassTest, NearestMipmapSamplesOneLevelAndLeavesMujocosFilter) {
  World w(/*glass=*/true, /*buried=*/false, /*sky=*/true);
  Renderer mujoco(w.m.get(), Options(false, true));
  Renderer trilinear(w.m.get(), Options(true, true));
  RenderOptions o = Options(true, true);
  o.nearest_mipmap = true;
  Renderer nearest(w.m.get(), o);
  for (const char* cam : {"high", "low"}) {
    SCOPED_TRACE(cam);
    const std::vector<unsigned char> want = Shoot(mujoco, w, cam);
    const std::vector<unsigned char> tri = Shoot(trilinear, w, cam);
    const std::vector<unsigned char> got = Shoot(nearest, w, cam);
    // The filter changed some texels (the floor recedes through several mipmap levels)...
    const Difference filter = Compare(tri, got, 0);
    std::printf(
        "%s: nearest mipmap against trilinear: mean %.3f levels, %.4f of pixels differ;"
        " against MuJoCo: mean %.3f\n",
        cam, filter.mean, filter.share, Compare(want, got, 24).mean);
    EXPECT_GT(filter.share, 0.01);
    // ... by little: the picture stays MuJoCo's.
    EXPECT_LT(Compare(tri, got, 24).share, 0.002);
    const Difference d = Compare(want, got, 24);
    EXPECT_LT(d.mean, 1.0);
    EXPECT_LT(d.share, 0.005);
    // MuJoCo's passes (a frame without shadows) in the renderer that just drew one pass:
    // the samplers are unbound, the textures' own filter samples as before.
    EXPECT_EQ(Shoot(nearest, w, cam, false), Shoot(mujoco, w, cam, false));
  }
  EXPECT_EQ(nearest.one_pass_nearest_mipmap_frames(), 2);  // llvmpipe has sampler objects
  EXPECT_EQ(trilinear.one_pass_nearest_mipmap_frames(), 0);
  EXPECT_EQ(mujoco.one_pass_nearest_mipmap_frames(), 0);
}

}  // namespace
}  // namespace mlspaces::sim
