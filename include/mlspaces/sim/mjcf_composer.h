// The MJCF composer: MuJoCo 3 scene syntax (<model> assets, <attach>, <frame>, <include>)
// flattened into one model that MuJoCo 2.2.2 compiles.
//
// What it does to each model file (a "model instance": the scene, or one <attach>):
//  - expands <include> (paths relative to the instance's main file, as MuJoCo does);
//  - reads the instance's <compiler> (angle, eulerseq, meshdir/texturedir/assetdir) and puts
//    every angle in radians and every orientation (quat, euler + eulerseq, axisangle, xyaxes,
//    zaxis) in `quat` form, so instances with different compiler settings can share one model;
//  - gives every element that takes a default class its effective class explicitly, under a
//    name unique to the instance ("__mK__" for the instance's root default, "__mK__/name" for
//    its classes; the scene keeps its class names), so each instance keeps its own defaults
//    and never inherits another's, as with MuJoCo 3's attach;
//  - rebases mesh/texture/hfield/skin files to absolute paths (names default to file stems);
//  - expands each <attach model=... [body=...] prefix=...>: the model's worldbody (or the named
//    body's subtree) goes where the <attach> stands, and its assets, defaults, contact,
//    equality, tendon, actuator, sensor and custom sections are merged, with the prefix put on
//    every name and every reference (keyframes of attached models are dropped, with a warning);
//  - folds every <frame> (nested too) into its children's poses (pos, quat, fromto, light dir).
// The emitted model uses <compiler angle="radian" autolimits="true"> (autolimits is MuJoCo 3's
// default) unless the scene's own compiler says otherwise for autolimits; mesh inertia is
// MuJoCo's default (each <mesh inertia=...> as the source says).
//
// Errors are mlspaces::Error with path = the source file and field = "line N, element <tag>",
// also for errors MuJoCo reports on the flat model (its line is mapped back to the source).
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {

/// A rigid pose: position (m) and unit quaternion (w, x, y, z), MuJoCo's order.
struct Pose {
  std::array<double, 3> pos{0, 0, 0};
  std::array<double, 4> quat{1, 0, 0, 0};
};

struct ComposeOptions {
  /// Keep only what body masses and geometry need: drop textures, materials, skins and
  /// lights. Masses, inertias and geom/mesh vertex data equal a full compile's; rendering
  /// does not.
  bool physics_only = false;
};

/// A composed model. Cheap to copy relative to a compile (the XML tree is deep-copied).
class MjcfComposer {
 public:
  /// Composes an MJCF file. @throws Error naming the file, line and element.
  explicit MjcfComposer(const std::filesystem::path& file, ComposeOptions options = {});
  /// Composes MJCF text; relative paths resolve against `path_for_errors`'s folder.
  static MjcfComposer FromString(std::string_view xml,
                                 const std::filesystem::path& path_for_errors,
                                 ComposeOptions options = {});
  MjcfComposer(const MjcfComposer& other);
  MjcfComposer& operator=(const MjcfComposer& other);
  MjcfComposer(MjcfComposer&&) noexcept;
  MjcfComposer& operator=(MjcfComposer&&) noexcept;
  ~MjcfComposer();

  /// Attaches a model file at run time, as <attach> would: under body `parent_body` ("" or
  /// "world" for the worldbody), at `pose` relative to that body, with `prefix` on every name.
  /// `body` picks one body's subtree of the model; empty takes its whole worldbody.
  /// @returns the (prefixed) names of the top-level bodies inserted.
  /// @throws Error for an unknown parent body or a bad model file.
  std::vector<std::string> Attach(const std::filesystem::path& file, std::string_view parent_body,
                                  std::string_view prefix, const Pose& pose,
                                  std::string_view body = {});

  /// True when a body of that name exists (before compiling).
  bool HasBody(std::string_view name) const;

  /// The flat MJCF handed to MuJoCo. @throws Error for a name defined twice (naming both
  /// files and lines).
  std::string Emit() const;

  /// Emits and compiles with MuJoCo. @throws Error with the source file, line and element.
  ModelPtr Compile() const;

  /// Composition warnings (dropped keyframes, ...) and MuJoCo compile warnings.
  const std::vector<std::string>& warnings() const;

  /// The file this composer was built from.
  const std::filesystem::path& path() const;

 private:
  MjcfComposer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Convenience: compose and compile a file. @throws Error.
ModelPtr ComposeAndCompile(const std::filesystem::path& file, ComposeOptions options = {});

}  // namespace mlspaces::sim
