// Headless renderings for pictures: orbit views, an asset alone in a studio, an asset with its
// grasps drawn as gripper outlines (capsule geoms added to the composed spec, so MuJoCo's own
// renderer draws them with depth and lighting), a model from several views.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mjcf_composer.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/pictures.h"

namespace mlspaces::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Lights for an asset alone: the headlight plus one directional key light, no floor, no
/// shadows (an asset of any size renders the same way).
constexpr char kStudioXml[] = R"(<mujoco model="mlspaces_studio">
  <visual>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.45 0.45 0.45" specular="0.05 0.05 0.05"/>
  </visual>
  <worldbody>
    <light name="mlspaces_key" directional="true" pos="1 -1 2" dir="-1 1 -2" castshadow="false"
           diffuse="0.5 0.5 0.5" specular="0.1 0.1 0.1"/>
  </worldbody>
</mujoco>
)";

/// The asset `uid` attached alone into the studio; `body` gets the name of its first top-level
/// body (the asset body grasps refer to).
MjcfComposer ComposeAsset(const Registry& registry, std::string_view uid, std::string* body) {
  const AssetLocation loc = registry.LocateOrThrow(uid);
  if (!loc.installed) {
    throw Error("asset is not installed (mlspaces install " + std::string(uid) + ")",
                loc.mjcf_path.string(), "", std::string(uid));
  }
  MjcfComposer studio =
      MjcfComposer::FromString(kStudioXml, loc.mjcf_path.parent_path() / "mlspaces_studio.xml");
  const MjcfComposer asset(loc.mjcf_path);
  const std::vector<std::string> bodies = studio.Attach(asset, "world", "asset/", Pose{});
  if (bodies.empty()) {
    throw Error("the asset has no body to render", loc.mjcf_path.string(), "", std::string(uid));
  }
  if (body != nullptr) *body = bodies[0];
  return studio;
}

/// p' = R p + t for the 4x4 `T`.
std::array<double, 3> Apply(const Mat4& t, const std::array<double, 3>& p) {
  std::array<double, 3> out{};
  for (int r = 0; r < 3; ++r) {
    out[r] = t(r, 0) * p[0] + t(r, 1) * p[1] + t(r, 2) * p[2] + t(r, 3);
  }
  return out;
}

/// Adds the outline of each grasp as capsules on a massless body welded to `body_name`.
void AddGraspOutlines(MjcfComposer& composer, const std::string& body_name,
                      const std::vector<Mat4>& grasps, const GripperOutline& o) {
  mjSpec* spec = composer.spec();
  mjsBody* body = mjs_findBody(spec, body_name.c_str());
  if (body == nullptr) throw Error("grasp picture: body '" + body_name + "' not found");
  mjsBody* holder = mjs_addBody(body, nullptr);
  mjs_setName(holder->element, "mlspaces_grasp_outlines");
  const double w = o.opening / 2, l = o.finger_length, s = o.stem_length;
  // Segments in the grasp frame: the two fingers, the palm bar, the stem.
  const std::array<std::array<std::array<double, 3>, 2>, 4> segments{{
      {{{0, -w, 0}, {0, -w, -l}}},
      {{{0, w, 0}, {0, w, -l}}},
      {{{0, -w, -l}, {0, w, -l}}},
      {{{0, 0, -l}, {0, 0, -l - s}}},
  }};
  for (size_t i = 0; i < grasps.size(); ++i) {
    const Rgb8 c = GraspColor(i);
    for (const auto& seg : segments) {
      mjsGeom* g = mjs_addGeom(holder, nullptr);
      g->type = mjGEOM_CAPSULE;
      const std::array<double, 3> a = Apply(grasps[i], seg[0]), b = Apply(grasps[i], seg[1]);
      for (int k = 0; k < 3; ++k) {
        g->fromto[k] = a[k];
        g->fromto[3 + k] = b[k];
      }
      g->size[0] = o.radius;
      g->contype = 0;
      g->conaffinity = 0;
      g->density = 0;
      g->group = 0;
      for (int k = 0; k < 3; ++k) g->rgba[k] = static_cast<float>(c[k]) / 255.0f;
      g->rgba[3] = 1;
    }
  }
}

/// The (prefixed) name of the body owning joint `joint` of the asset attached under "asset/".
std::string JointBody(const mjModel* m, std::string_view joint, std::string_view uid) {
  const std::string name = "asset/" + std::string(joint);
  const int id = mj_name2id(m, mjOBJ_JOINT, name.c_str());
  if (id < 0) {
    std::string joints;
    for (int j = 0; j < m->njnt; ++j) {
      const char* n = mj_id2name(m, mjOBJ_JOINT, j);
      if (n == nullptr || std::string_view(n).substr(0, 6) != "asset/") continue;
      joints += (joints.empty() ? "" : ", ") + std::string(n + 6);
    }
    throw Error("asset " + std::string(uid) + " has no joint '" + std::string(joint) +
                    "' (joints: " + (joints.empty() ? "none" : joints) + ")",
                "", "", std::string(uid));
  }
  const char* body = mj_id2name(m, mjOBJ_BODY, m->jnt_bodyid[id]);
  if (body == nullptr) throw Error("the body of joint '" + std::string(joint) + "' has no name");
  return body;
}

/// Centre and radius of the sphere around GeomBounds (radius at least 1 mm).
std::pair<std::array<double, 3>, double> BoundingSphere(const mjModel* m, const mjData* d) {
  const std::array<double, 6> b = GeomBounds(m, d);
  std::array<double, 3> c{};
  double r2 = 0;
  for (int k = 0; k < 3; ++k) {
    c[k] = (b[k] + b[3 + k]) / 2;
    r2 += (b[3 + k] - b[k]) * (b[3 + k] - b[k]) / 4;
  }
  return {c, std::max(std::sqrt(r2), 1e-3)};
}

/// "<uid>: <message>" for errors that do not name the UID yet.
[[noreturn]] void RethrowWithUid(const Error& e, std::string_view uid) {
  const std::string u(uid);
  if (e.uid() == u || e.message().find(u) != std::string::npos) throw e;
  throw Error("asset " + u + ": " + e.message(), e.path(), e.field(), u);
}

}  // namespace

std::vector<CameraView> OrbitViews(const std::array<double, 3>& center, double radius, int n,
                                   double elevation_deg, double azimuth_deg, double fovy_deg) {
  if (n < 1) throw UsageError("orbit views: need at least one view");
  if (!(radius > 0)) throw UsageError("orbit views: radius must be positive");
  const double half = 0.4 * fovy_deg * kPi / 180;  // the sphere fills ~80% of the fovy
  const double dist = radius / std::sin(half);
  const double el = elevation_deg * kPi / 180;
  std::vector<CameraView> views;
  for (int k = 0; k < n; ++k) {
    const double az = (azimuth_deg + 360.0 * k / n) * kPi / 180;
    const std::array<double, 3> eye{center[0] + dist * std::cos(el) * std::cos(az),
                                    center[1] + dist * std::cos(el) * std::sin(az),
                                    center[2] + dist * std::sin(el)};
    views.push_back(LookAt(eye, center, fovy_deg));
  }
  return views;
}

std::array<double, 6> GeomBounds(const mjModel* m, const mjData* d) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::array<double, 6> b{kInf, kInf, kInf, -kInf, -kInf, -kInf};
  bool any = false;
  for (int g = 0; g < m->ngeom; ++g) {
    // Only what the default visual options draw: groups 0-2, not transparent, not planes.
    if (m->geom_type[g] == mjGEOM_PLANE || m->geom_group[g] > 2 || m->geom_rgba[4 * g + 3] == 0) {
      continue;
    }
    const mjtNum* aabb = m->geom_aabb + 6 * g;
    const mjtNum* xpos = d->geom_xpos + 3 * g;
    const mjtNum* xmat = d->geom_xmat + 9 * g;
    for (int corner = 0; corner < 8; ++corner) {
      double local[3];
      for (int k = 0; k < 3; ++k) {
        local[k] = aabb[k] + ((corner >> k) & 1 ? aabb[3 + k] : -aabb[3 + k]);
      }
      for (int r = 0; r < 3; ++r) {
        const double w = xpos[r] + xmat[3 * r] * local[0] + xmat[3 * r + 1] * local[1] +
                         xmat[3 * r + 2] * local[2];
        b[r] = std::min(b[r], w);
        b[3 + r] = std::max(b[3 + r], w);
      }
    }
    any = true;
  }
  if (!any) return {0, 0, 0, 0, 0, 0};
  return b;
}

std::vector<Image> RenderViews(const mjModel* m, const mjData* d,
                               const std::vector<CameraView>& views,
                               const PictureOptions& options) {
  RenderOptions ro;
  ro.width = options.width;
  ro.height = options.height;
  ro.backend = options.backend;
  ro.egl_platform = options.egl_platform;
  Renderer renderer(m, ro);
  const double far = m->vis.map.zfar * m->stat.extent;
  std::vector<Image> tiles;
  std::vector<float> depth(static_cast<size_t>(options.width) * options.height);
  for (const CameraView& view : views) {
    Image tile = Image::Filled(options.width, options.height);
    renderer.Render(d, view, tile.rgb.data(), depth.data());
    if (options.plain_background) {
      for (size_t i = 0; i < depth.size(); ++i) {
        if (depth[i] >= far * 0.999) {
          for (int k = 0; k < 3; ++k) tile.rgb[3 * i + k] = options.background[k];
        }
      }
    }
    tiles.push_back(std::move(tile));
  }
  return tiles;
}

Rgb8 GraspColor(size_t i) {
  static constexpr std::array<Rgb8, 6> kColors{
      {{20, 200, 40}, {30, 90, 240}, {250, 150, 0}, {200, 40, 200}, {0, 200, 210}, {230, 210, 0}}};
  return kColors[i % kColors.size()];
}

Image RenderAsset(const Registry& registry, std::string_view uid, const PictureOptions& options) {
  try {
    const MjcfComposer composer = ComposeAsset(registry, uid, nullptr);
    ModelPtr m = composer.Compile();
    DataPtr d = MakeData(m.get());
    mj_forward(m.get(), d.get());
    const auto [center, radius] = BoundingSphere(m.get(), d.get());
    return RenderViews(m.get(), d.get(), OrbitViews(center, radius, 1), options)[0];
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    RethrowWithUid(e, uid);
  }
}

Image AssetSheet(const Registry& registry, const std::vector<std::string>& uids,
                 const PictureOptions& options, int columns,
                 const std::function<void(size_t, size_t)>& progress) {
  if (uids.empty()) throw UsageError("a contact sheet needs at least one asset");
  GridSize(uids.size(), options.width, options.height, columns);  // too large: before rendering
  std::vector<Image> tiles;
  for (size_t i = 0; i < uids.size(); ++i) {
    if (progress) progress(i, uids.size());
    tiles.push_back(RenderAsset(registry, uids[i], options));
  }
  return ComposeGrid(tiles, uids, columns);
}

Image GraspPicture(const Registry& registry, std::string_view uid, const std::vector<Mat4>& grasps,
                   const GripperOutline& outline, const PictureOptions& options, int views,
                   std::string_view joint) {
  if (views < 1) throw UsageError("a grasp picture needs at least one view");
  std::vector<Image> tiles;
  std::vector<std::string> labels;
  try {
    std::string body;
    MjcfComposer composer = ComposeAsset(registry, uid, &body);
    GripperOutline o = outline;
    {
      // The asset alone: the joint's body, and the capsules at least ~1.5 pixels thick when
      // framed as below (the orbit distance R / sin(0.4 fovy), 45 degrees fovy).
      const ModelPtr alone = composer.Compile();
      if (!joint.empty()) body = JointBody(alone.get(), joint, uid);
      DataPtr d = MakeData(alone.get());
      mj_forward(alone.get(), d.get());
      const double r = BoundingSphere(alone.get(), d.get()).second;
      const double fovy = 45 * kPi / 180;
      const double pixel = 2 * r / std::sin(0.4 * fovy) * std::tan(fovy / 2) / options.height;
      o.radius = std::max(o.radius, 0.75 * pixel);
    }
    if (!grasps.empty()) AddGraspOutlines(composer, body, grasps, o);
    ModelPtr m = composer.Compile();
    DataPtr d = MakeData(m.get());
    mj_forward(m.get(), d.get());
    const auto [center, radius] = BoundingSphere(m.get(), d.get());
    tiles = RenderViews(m.get(), d.get(), OrbitViews(center, radius, views), options);
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    RethrowWithUid(e, uid);
  }
  for (int k = 0; k < views; ++k) {
    char label[48];
    std::snprintf(label, sizeof label, "azimuth %.0f deg", -45 + 360.0 * k / views);
    labels.emplace_back(label);
  }
  const std::string title = std::string(uid) + (joint.empty() ? "" : "/" + std::string(joint)) +
                            ": " + std::to_string(grasps.size()) +
                            (grasps.size() == 1 ? " grasp" : " grasps");
  return ComposeGrid(tiles, labels, std::min(views, 4), title);
}

}  // namespace mlspaces::sim
