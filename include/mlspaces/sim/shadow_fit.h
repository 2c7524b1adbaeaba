#pragma once
// Shadow maps fitted to the shadow casters, for MuJoCo's own renderer (mjr_render).
//
// MuJoCo maps each directional light's shadows over a fixed square of side
// 2 * stat.extent * vis.map.shadowclip centred on the light's position, and draws every geom
// into it, the floor plane too. A caster's shadow under an orthographic light lies inside the
// caster's own outline as the light sees it, so a square around the casters' outlines loses no
// shadow: the same map then has far smaller texels, and a smaller map gives MuJoCo's
// sharpness for a fraction of the cost (docs/sim.md, "Render speed and quality").
#include <mujoco/mujoco.h>

#include <vector>

#include "mlspaces/core/export.h"

namespace mlspaces::sim {

/// What FitShadowMaps did to a scene.
struct ShadowFit {
  bool fitted = false;     ///< false: the scene is left as mjv_updateScene made it
  float clip = 0;          ///< half side of the shadow square (mjrContext::shadowClip), metres
  int planes_skipped = 0;  ///< planes drawn no more into the shadow maps
  int casters_unseen = 0;  ///< casters in no light's square: no view sees their shadows
};

/// A picture the fitted maps must shadow rightly: one eye of the camera mjv_updateScene (or
/// the caller) put in the scene, and the picture's width / height.
struct ShadowView {
  mjvGLCamera camera{};
  double aspect = 1;
};

/// Fits the shadow maps of `scn`'s shadow-casting directional lights to its casters, for the
/// next mjr_render(…, scn, con) only (call it after each mjv_updateScene):
///  - a plane with nothing behind it (every other geom's box in front of it, 1 mm allowed)
///    casts no shadow on anything; it becomes mjCAT_DECOR, which mjr_render leaves out of the
///    shadow maps only;
///  - each such light's position (which a directional light uses for its shadows only) moves
///    to the centre of the casters' outline seen along the light, behind them all, and
///    `con->shadowClip` becomes the half side that holds every light's outline.
/// Casters are the scene's geoms that mjr_render draws into shadow maps (not lines, not
/// mjCAT_DECOR). It leaves the scene and `con->shadowClip = default_clip` unchanged (fitted
/// false) when shadows are off, no directional light casts, or a caster has no known bounds
/// (a plane with something behind it, a flex or skin, a mesh that is no model geom).
/// With `views`, a light's square holds only the casters whose shadows can fall on what one
/// of the views sees (a geom whose box meets the view's frustum, the part of a plane inside
/// it): parked or far-off casters no more stretch it. Every caster counts without views, or
/// when a geom some view may see has no known bounds.
/// `m` is the model the scene was made from (geom boxes: mjModel::geom_aabb). Never throws.
MLSPACES_API ShadowFit FitShadowMaps(const mjModel* m, mjvScene* scn, mjrContext* con,
                                     float default_clip, const std::vector<ShadowView>& views = {});

}  // namespace mlspaces::sim
