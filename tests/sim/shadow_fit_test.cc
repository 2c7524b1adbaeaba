// Shadow maps fitted to the casters: the square holds every caster as the light sees it, the
// floor stops casting only when nothing is behind it, and the rendered shadows are MuJoCo's.
#include "mlspaces/sim/shadow_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::sim {
namespace {

// A ball high above the floor, out of the camera's view, whose shadow falls on the floor in
// view (at (-0.5, 0.5): 3 m from it toward the sun); a ball parked 35 m up, far from all, and
// a camera that sees it and nothing else.
constexpr const char* kHigh =
    R"(<geom name="high" type="sphere" pos="-1.573 -0.305 2.683" size="0.2"/>)";
constexpr const char* kParked = R"(<geom name="parked" type="sphere" pos="20 20 35" size="0.2"/>
    <camera name="up" pos="20 20 36" xyaxes="1 0 0 0 1 0" fovy="30"/>)";

// A box and a tilted capsule on a floor, lit from the side by a shadow-casting directional
// light; `below` adds a ball under the floor, `extra` more.
std::string Xml(bool below, const std::string& extra = "") {
  return std::string(R"(
<mujoco>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0.4 0.3 -1" directional="true" castshadow="true"/>
    <light name="fill" pos="0 0 3" dir="0 0 -1" directional="true" castshadow="false"
           diffuse="0.2 0.2 0.2"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.8 0.8 0.8 1"/>
    <geom name="box" type="box" pos="0 0 0.15" size="0.1 0.1 0.15" rgba="1 0 0 1"/>
    <geom name="arm" type="capsule" fromto="0.4 0.2 0.3 0.7 0.1 0.6" size="0.04"
          rgba="0 0 1 1"/>
    <camera name="view" pos="1.2 -1.4 1.3" xyaxes="0.76 0.65 0 -0.4 0.47 0.78" fovy="50"/>)") +
         (below ? R"(<geom name="under" type="sphere" pos="0 0 -0.5" size="0.1"/>)" : "") + extra +
         R"(
  </worldbody>
</mujoco>)";
}

struct Scene {
  ModelPtr m;
  DataPtr d;
  mjvOption opt{};
  mjvCamera cam{};
  mjvScene scn{};
  mjrContext con{};
  explicit Scene(bool below = false, const std::string& extra = "") {
    m = LoadModelFromMemory(Xml(below, extra));
    d = MakeData(m.get());
    mj_forward(m.get(), d.get());
    mjv_defaultOption(&opt);
    mjv_defaultCamera(&cam);
    mjv_defaultScene(&scn);
    mjv_makeScene(m.get(), &scn, 100);
    mjv_updateScene(m.get(), d.get(), &opt, nullptr, &cam, mjCAT_ALL, &scn);
    mjr_defaultContext(&con);
    con.shadowSize = 1024;
  }
  ~Scene() { mjv_freeScene(&scn); }
  float DefaultClip() const { return static_cast<float>(m->stat.extent); }
  // Model camera `name` as FitShadowMaps' views take it (the scene's camera, one eye); the
  // scene is updated from it.
  ShadowView View(const char* name, double aspect) {
    mjvCamera fixed;
    mjv_defaultCamera(&fixed);
    fixed.type = mjCAMERA_FIXED;
    fixed.fixedcamid = mj_name2id(m.get(), mjOBJ_CAMERA, name);
    mjv_updateScene(m.get(), d.get(), &opt, nullptr, &fixed, mjCAT_ALL, &scn);
    return {mjv_averageCamera(&scn.camera[0], &scn.camera[1]), aspect};
  }
  const mjvGeom* Geom(const char* name) const {
    const int id = mj_name2id(m.get(), mjOBJ_GEOM, name);
    for (int i = 0; i < scn.ngeom; ++i) {
      if (scn.geoms[i].objtype == mjOBJ_GEOM && scn.geoms[i].objid == id) return &scn.geoms[i];
    }
    return nullptr;
  }
};

// The corners of the box and points on the capsule's surface (its two end spheres sampled):
// what the light must see inside the square, found without the code under test.
std::vector<Vec3> CasterPoints(const mjModel* m, const mjData* d) {
  std::vector<Vec3> pts;
  const int box = mj_name2id(m, mjOBJ_GEOM, "box");
  for (int k = 0; k < 8; ++k) {
    Vec3 p;
    for (int i = 0; i < 3; ++i) {
      p[i] = d->geom_xpos[3 * box + i];
      for (int a = 0; a < 3; ++a) {
        const double sign = (k >> a) & 1 ? 1 : -1;
        p[i] += sign * m->geom_size[3 * box + a] * d->geom_xmat[9 * box + 3 * i + a];
      }
    }
    pts.push_back(p);
  }
  const int arm = mj_name2id(m, mjOBJ_GEOM, "arm");
  const double r = m->geom_size[3 * arm], half = m->geom_size[3 * arm + 1];
  for (const double end : {-1.0, 1.0}) {
    for (int s = 0; s < 26; ++s) {  // the directions of a cube's faces, edges and corners
      Vec3 dir = {double(s % 3) - 1, double(s / 3 % 3) - 1,
                  double(s / 9) - 1};  // NOLINT(bugprone-integer-division)
      if (s == 13) dir = {0, 0, 1};
      const double n = Norm(dir);
      Vec3 p;
      for (int i = 0; i < 3; ++i) {
        p[i] = d->geom_xpos[3 * arm + i] + end * half * d->geom_xmat[9 * arm + 3 * i + 2] +
               r * dir[i] / n;
      }
      pts.push_back(p);
    }
  }
  return pts;
}

TEST(ShadowFitTest, TheSquareHoldsEveryCasterAndTheFloorStopsCasting) {
  Scene s;
  const mjvGeom* floor = s.Geom("floor");
  ASSERT_NE(floor, nullptr);
  ASSERT_NE(floor->category, mjCAT_DECOR);
  const ShadowFit fit = FitShadowMaps(s.m.get(), &s.scn, &s.con, s.DefaultClip());
  ASSERT_TRUE(fit.fitted);
  EXPECT_EQ(fit.planes_skipped, 1);
  EXPECT_EQ(floor->category, mjCAT_DECOR);
  EXPECT_NE(s.Geom("box")->category, mjCAT_DECOR);
  EXPECT_FLOAT_EQ(s.con.shadowClip, fit.clip);
  EXPECT_LT(fit.clip, 0.5 * s.DefaultClip());

  // The light frame mjr_render uses (mjr_lookAt along the light, up from mjr_orthoVec).
  ASSERT_GE(s.scn.nlight, 3);  // the headlight, then the model's lights
  const mjvLight& sun = s.scn.lights[1];
  ASSERT_TRUE(sun.castshadow);
  Vec3 f = {sun.dir[0], sun.dir[1], sun.dir[2]};
  f = {f[0] / Norm(f), f[1] / Norm(f), f[2] / Norm(f)};
  Vec3 side = Cross(f, Cross(f, {-1, 0, 0}));
  side = {side[0] / Norm(side), side[1] / Norm(side), side[2] / Norm(side)};
  const Vec3 top = Cross(side, f);
  const Vec3 pos = {sun.pos[0], sun.pos[1], sun.pos[2]};
  double widest = 0;
  for (const Vec3& p : CasterPoints(s.m.get(), s.d.get())) {
    const Vec3 q = Sub(p, pos);
    EXPECT_LE(std::abs(Dot(q, side)), fit.clip) << "outside the square along x";
    EXPECT_LE(std::abs(Dot(q, top)), fit.clip) << "outside the square along y";
    EXPECT_GT(Dot(q, f), 0.05) << "not in front of the light";
    widest = std::max({widest, std::abs(Dot(q, side)), std::abs(Dot(q, top))});
  }
  EXPECT_LT(fit.clip, 1.05 * widest) << "the square is not tight";
  // The other light casts nothing and keeps its place.
  EXPECT_FLOAT_EQ(s.scn.lights[2].pos[2], 3.0f);
}

TEST(ShadowFitTest, LeavesTheSceneWhenSomethingIsBehindThePlane) {
  Scene s(/*below=*/true);
  const mjvLight before = s.scn.lights[1];
  const ShadowFit fit = FitShadowMaps(s.m.get(), &s.scn, &s.con, s.DefaultClip());
  EXPECT_FALSE(fit.fitted);
  EXPECT_NE(s.Geom("floor")->category, mjCAT_DECOR);
  EXPECT_FLOAT_EQ(s.con.shadowClip, s.DefaultClip());
  for (int i = 0; i < 3; ++i) EXPECT_EQ(s.scn.lights[1].pos[i], before.pos[i]);
}

TEST(ShadowFitTest, LeavesTheSceneWithoutShadowsOrShadowCastingDirectionalLights) {
  Scene off;
  off.scn.flags[mjRND_SHADOW] = 0;
  EXPECT_FALSE(FitShadowMaps(off.m.get(), &off.scn, &off.con, off.DefaultClip()).fitted);
  EXPECT_NE(off.Geom("floor")->category, mjCAT_DECOR);
  Scene spot;
  spot.scn.lights[1].type = mjLIGHT_SPOT;
  spot.con.shadowClip = 123;
  EXPECT_FALSE(FitShadowMaps(spot.m.get(), &spot.scn, &spot.con, spot.DefaultClip()).fitted);
  EXPECT_FLOAT_EQ(spot.con.shadowClip, spot.DefaultClip());
}

TEST(ShadowFitTest, TheViewsLeaveOutTheCastersWhoseShadowsNoViewSees) {
  Scene s(false, std::string(kHigh).append(kParked));
  // The high ball is out of the view: above its top edge.
  const CameraView cam =
      Renderer::ModelCamera(s.m.get(), s.d.get(), mj_name2id(s.m.get(), mjOBJ_CAMERA, "view"));
  const int high = mj_name2id(s.m.get(), mjOBJ_GEOM, "high");
  const Vec3 q =
      Sub({s.d->geom_xpos[3 * high], s.d->geom_xpos[3 * high + 1], s.d->geom_xpos[3 * high + 2]},
          cam.pos);
  const Vec3 up = {cam.xmat[1], cam.xmat[4], cam.xmat[7]};
  const Vec3 back = {cam.xmat[2], cam.xmat[5], cam.xmat[8]};
  ASSERT_GT(Dot(q, up) - 0.2, -Dot(q, back) * std::tan(cam.fovy_deg * M_PI / 360));

  const ShadowFit all = FitShadowMaps(s.m.get(), &s.scn, &s.con, s.DefaultClip());
  ASSERT_TRUE(all.fitted);
  EXPECT_EQ(all.casters_unseen, 0);
  EXPECT_GT(all.clip, 10) << "the parked ball stretches the square";

  const ShadowView view = s.View("view", 4.0 / 3);
  const ShadowFit seen = FitShadowMaps(s.m.get(), &s.scn, &s.con, s.DefaultClip(), {view});
  ASSERT_TRUE(seen.fitted);
  EXPECT_EQ(seen.casters_unseen, 1) << "the parked ball";
  // The square of the casters without the parked ball: the high one's shadow is in view.
  Scene unparked(false, kHigh);
  const ShadowFit want =
      FitShadowMaps(unparked.m.get(), &unparked.scn, &unparked.con, unparked.DefaultClip());
  EXPECT_FLOAT_EQ(seen.clip, want.clip);
  Scene bare;
  const ShadowFit without_high = FitShadowMaps(bare.m.get(), &bare.scn, &bare.con, 1);
  EXPECT_GT(seen.clip, 1.5 * without_high.clip) << "the high ball counts";

  // Looking at the parked ball as well: it counts again; the high one's shadow is not seen
  // from up there but is from the view.
  const ShadowView parked = s.View("up", 1);
  const ShadowFit both = FitShadowMaps(s.m.get(), &s.scn, &s.con, s.DefaultClip(), {view, parked});
  EXPECT_EQ(both.casters_unseen, 0);
  EXPECT_FLOAT_EQ(both.clip, all.clip);
  const ShadowFit only_up = FitShadowMaps(s.m.get(), &s.scn, &s.con, s.DefaultClip(), {parked});
  EXPECT_EQ(only_up.casters_unseen, 3) << "box, arm and high ball";
}

// The fixed camera's image with `options`, and where MuJoCo's geometry puts shadows on the
// floor: per pixel, -1 not the floor, 1 a ray from its floor point toward the sun hits a geom,
// 0 it does not; `hit`: that geom.
struct Shot {
  std::vector<unsigned char> rgb;
  std::vector<int> truth, hit;
  int map = 0;
};

Shot Render(const Scene& s, RenderOptions options, bool shadows) {
  constexpr int kW = 480, kH = 360;
  options.width = kW;
  options.height = kH;
  Renderer r(s.m.get(), options);
  r.scene().flags[mjRND_SHADOW] = shadows ? 1 : 0;
  const int cam = mj_name2id(s.m.get(), mjOBJ_CAMERA, "view");
  Shot shot;
  shot.rgb.resize(3 * kW * kH);
  std::vector<float> depth(kW * kH);
  r.RenderCamera(s.d.get(), cam, shot.rgb.data(), depth.data());
  shot.map = r.shadow_size();
  const CameraView v = Renderer::ModelCamera(s.m.get(), s.d.get(), cam);
  const double f = 0.5 * kH / std::tan(v.fovy_deg * M_PI / 360);
  const int sun = mj_name2id(s.m.get(), mjOBJ_LIGHT, "sun");
  mjtNum to_sun[3];
  for (int i = 0; i < 3; ++i) to_sun[i] = -s.d->light_xdir[3 * sun + i];
  shot.truth.assign(kW * kH, -1);
  shot.hit.assign(kW * kH, -1);
  for (int row = 0; row < kH; ++row) {
    for (int col = 0; col < kW; ++col) {
      const double z = depth[row * kW + col];
      const double ray[3] = {(col + 0.5 - kW / 2.0) / f, -(row + 0.5 - kH / 2.0) / f, -1};
      mjtNum p[3];
      for (int i = 0; i < 3; ++i) {
        p[i] = v.pos[i];
        for (int k = 0; k < 3; ++k) p[i] += z * v.xmat[3 * i + k] * ray[k];
      }
      if (std::abs(p[2]) > 1e-2 || std::abs(p[0]) > 2.5 || std::abs(p[1]) > 2.5) continue;
      p[2] = 1e-4;
      int geom = -1;
      shot.truth[row * kW + col] =
          mj_ray(s.m.get(), s.d.get(), p, to_sun, nullptr, 1, -1, &geom, nullptr) >= 0 ? 1 : 0;
      shot.hit[row * kW + col] = geom;
    }
  }
  return shot;
}

// Pixel i is shadowed in the render: at least 40 levels darker than without shadows.
bool Drawn(const Shot& lit, const Shot& unlit, size_t i) {
  int shade = 0;
  for (int c = 0; c < 3; ++c) shade = std::max(shade, unlit.rgb[3 * i + c] - lit.rgb[3 * i + c]);
  return shade > 40;
}

// Floor pixels shadowed in the render and by the geometry: intersection over union.
double ShadowAgreement(const Shot& lit, const Shot& unlit) {
  long both = 0, either = 0;
  for (size_t i = 0; i < lit.truth.size(); ++i) {
    if (lit.truth[i] < 0) continue;
    const bool drawn = Drawn(lit, unlit, i), real = lit.truth[i] == 1;
    both += drawn && real;
    either += drawn || real;
  }
  return either == 0 ? 0 : static_cast<double>(both) / either;
}

// The scene's camera without shadows, with fitted maps and with MuJoCo's square, both at
// shadow_size 2048; the fitted shadows agree with the geometry (IoU > 0.85).
struct Shots {
  Shot none, fit, own;
};
Shots ShootAndCompare(const Scene& s, const char* what) {
  RenderOptions mujoco;
  mujoco.shadow_size = 2048;
  RenderOptions fitted = mujoco;
  fitted.fit_shadows = true;
  Shots out{Render(s, mujoco, false), Render(s, fitted, true), Render(s, mujoco, true)};
  EXPECT_GT(std::count(out.fit.truth.begin(), out.fit.truth.end(), 1), 1000)
      << "the view holds too little shadow to compare";
  const double agreement = ShadowAgreement(out.fit, out.none);
  EXPECT_GT(agreement, 0.85);
  // MuJoCo's own square (its floor in the map: acne here) for comparison.
  std::printf(
      "shadow agreement with the geometry%s: fitted (%d texels) %.3f, MuJoCo's square (2048) "
      "%.3f\n",
      what, out.fit.map, agreement, ShadowAgreement(out.own, out.none));
  return out;
}

TEST(ShadowFitTest, DrawsTheShadowsWhereTheGeometryPutsThemWithASmallerMap) {
  Scene s;
  const Shots shots = ShootAndCompare(s, "");
  // The texel size of 2048 texels over MuJoCo's square, on a far smaller square.
  EXPECT_GE(shots.fit.map, 64);
  EXPECT_LT(shots.fit.map, 2048 * 2 / 3);
}

// The shadow of a ball out of view stays; a ball parked far away is left out.
TEST(ShadowFitTest, DrawsTheShadowsOfCastersOutOfViewAndNotThoseNoViewSees) {
  Scene s(false, std::string(kHigh).append(kParked));
  const Shots shots = ShootAndCompare(s, ", a ball out of view, a ball parked 35 m up");
  // The high ball's shadow: in view, and drawn.
  const int high = mj_name2id(s.m.get(), mjOBJ_GEOM, "high");
  long high_real = 0, high_drawn = 0;
  for (size_t i = 0; i < shots.fit.hit.size(); ++i) {
    if (shots.fit.truth[i] != 1 || shots.fit.hit[i] != high) continue;
    ++high_real;
    high_drawn += Drawn(shots.fit, shots.none, i);
  }
  EXPECT_GT(high_real, 500);
  EXPECT_GT(high_drawn, 0.9 * static_cast<double>(high_real));
}

TEST(ShadowFitTest, TheCamerasOfAStateShareTheirMapsWhenTheRendererKnowsThem) {
  Scene s(false, std::string(kHigh).append(kParked));
  RenderOptions o;
  o.width = 160;
  o.height = 120;
  o.shadow_size = 512;
  o.fit_shadows = true;
  o.one_pass_shadows = true;
  std::vector<CameraView> views;
  for (const char* name : {"view", "up"}) {
    views.push_back(
        Renderer::ModelCamera(s.m.get(), s.d.get(), mj_name2id(s.m.get(), mjOBJ_CAMERA, name)));
  }
  std::vector<unsigned char> rgb(3 * 160 * 120);
  Renderer apart(s.m.get(), o);
  for (const CameraView& v : views) apart.Render(s.d.get(), v, rgb.data());
  EXPECT_EQ(apart.shadow_map_renders(), 2) << "each view's own square";
  Renderer shared(s.m.get(), o);
  shared.SetShadowViews(views);
  for (const CameraView& v : views) shared.Render(s.d.get(), v, rgb.data());
  EXPECT_EQ(shared.shadow_map_renders(), 1);
  CameraView bad = views[0];
  bad.fovy_deg = 0;
  EXPECT_THROW(shared.SetShadowViews({bad}), UsageError);
}

}  // namespace
}  // namespace mlspaces::sim
