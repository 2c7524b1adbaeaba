// What MuJoCo made of a composed model: bodies with their world pose at qpos0, mass and geom
// box; joints; actuators; cameras; the compile warnings. `mlspaces inspect` prints it.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mlspaces/core/json.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::sim {

struct MLSPACES_API BodyDescription {
  std::string name;    ///< "" when unnamed
  std::string parent;  ///< the parent body's name ("world" for top-level bodies)
  Pose pose;           ///< world pose at qpos0 (xpos, xquat after mj_kinematics)
  double mass = 0;
  int ngeom = 0;
  /// World-axes box of the body's own geoms (BodyGeomBox); nullopt when it has none.
  std::optional<std::array<Vec3, 2>> box;
};

struct MLSPACES_API JointDescription {
  std::string name;
  std::string type;  ///< "free", "ball", "slide" or "hinge"
  std::string body;
  std::optional<std::array<double, 2>> range;  ///< nullopt when not limited
};

struct MLSPACES_API ActuatorDescription {
  std::string name;
  std::string transmission;  ///< "joint", "jointinparent", "tendon", "site", "body", ...
  std::string target;        ///< the name of the joint / tendon / site / body it drives
  std::optional<std::array<double, 2>> ctrlrange;  ///< nullopt when not limited
};

struct MLSPACES_API CameraDescription {
  std::string name;
  std::string body;
  Vec3 pos{};  ///< world position at qpos0
  double fovy = 0;
};

struct MLSPACES_API ModelDescription {
  std::string file;  ///< as given to DescribeModel
  int64_t ngeom = 0;
  std::vector<BodyDescription> bodies;  ///< every body, the world first
  std::vector<JointDescription> joints;
  std::vector<ActuatorDescription> actuators;
  std::vector<CameraDescription> cameras;
  std::vector<Diagnostic> warnings;  ///< MuJoCo's compile warnings (MjcfComposer::warnings)
};

/// MuJoCo's name of a joint type (mjtJoint): "free", "ball", "slide" or "hinge".
MLSPACES_API const char* JointTypeName(int type);

/// Compiles `composer` and describes the model at qpos0 (after mj_kinematics).
/// `file` is recorded as given. @throws Error as MjcfComposer::Compile.
MLSPACES_API ModelDescription DescribeModel(const MjcfComposer& composer, const std::string& file);

/// The JSON form (`mlspaces inspect --json`): {"file", "bodies": [{"name", "parent", "pos",
/// "quat", "mass", "ngeom", "aabb": {"min", "max"} | null}], "joints": [{"name", "type",
/// "body", "range" | null}], "actuators": [{"name", "transmission", "target",
/// "ctrlrange" | null}], "cameras": [{"name", "body", "pos", "fovy"}], "warnings":
/// [MujocoWarningLine, ...]}.
MLSPACES_API Json ToJson(const ModelDescription& description);

}  // namespace mlspaces::sim
