// Pick success and reward, judged on one simulation state (spec section 6.2).
//
// success = the object's body origin rose at least `min_lift` above its start height, and every
// contact of the object (its body and the bodies below it) is with the robot, with at least one
// robot contact: an object in free fall is not picked. A body belongs to the robot when its name
// starts with the robot prefix or it hangs below the robot's root body (`<prefix>base`, the mocap
// base), so unprefixed bodies attached under the robot count too.
#pragma once

#include "mlspaces/core/export.h"

#include <string>
#include <string_view>
#include <vector>

// MuJoCo's structs, declared as <mujoco/mujoco.h> declares them (include it to use them).
// NOLINTBEGIN(modernize-use-using): MuJoCo's own form of these declarations
struct mjModel_;
typedef struct mjModel_ mjModel;
struct mjData_;
typedef struct mjData_ mjData;
// NOLINTEND(modernize-use-using)

namespace mlspaces::datagen {

/// The verdict on one state, with everything it was made from.
struct MLSPACES_API PickSuccess {
  /// Object body origin height (xpos z) minus `start_z`, in metres (negative when it sank).
  double lift = 0;
  /// lift >= min_lift.
  bool lifted = false;
  /// Contacts between the object and robot geoms.
  int robot_contacts = 0;
  /// Contacts between the object and anything else (floor, other objects, world geoms).
  int other_contacts = 0;
  /// Names of the non-robot geoms the object touches, unique, in contact order ("geom 7" for
  /// an unnamed geom).
  std::vector<std::string> non_robot_geoms;
  /// other_contacts == 0 and robot_contacts >= 1.
  bool only_robot_contact = false;
  /// The verdict: lifted and only_robot_contact.
  bool success = false;
  /// The supporting geom: the touching geom whose contact normal points most upward into the
  /// object (normal z >= 0.5), or -1 when nothing supports it from below.
  int supporting_geom = -1;
  /// The reward (docs/datagen.md): clip(lift, 0, 1000) when nothing supports the object or its
  /// support is a visible robot geom (group 0-2), else 0.
  double reward = 0;
};

/// Judges the pick on `d` (positions and contacts must be current: after mj_forward or a step).
/// `object_body` is the picked object's body id; its subtree counts as the object, and contacts
/// inside it are ignored. @throws UsageError for a bad body id, min_lift < 0, or an empty prefix.
MLSPACES_API PickSuccess EvaluatePickSuccess(const mjModel* m, const mjData* d, int object_body,
                                             double start_z,
                                             std::string_view robot_prefix = "robot_0/",
                                             double min_lift = 0.01);

/// True when body `body` belongs to the robot named by `robot_prefix` (see the file comment).
MLSPACES_API bool IsRobotBody(const mjModel* m, int body, std::string_view robot_prefix);

}  // namespace mlspaces::datagen
