// The MJCF composer: a scene file and the models attached to it at run time, composed by
// MuJoCo 3's own parser and model-editing API (mjSpec).
//
// MuJoCo does the composing: mj_parseXML reads the file with its <include>s, <default>s,
// <frame>s, <model> assets and <attach>es (each attached model keeps its own compiler
// settings and defaults, its names get the attach prefix, its keyframes come along, prefixed
// and padded to the whole model); Attach parses another model file and mjs_attach-es it (its
// whole worldbody, or one body's subtree) into a new frame under a body of this one;
// Compile is mj_compile of the spec (which leaves it as it was: compiling again, attaching
// more, copying all still work); Emit compiles and writes the spec with mj_saveXMLString
// (plain MJCF: frames folded into the bodies, attachments expanded, angles in radians; MuJoCo
// writes numbers with 6 significant digits, so re-parsing Emit's text is not the same model:
// edit spec() and Compile instead). Asset file paths of a model without <model>/<include>
// are made absolute at parse time, so the emitted MJCF of such models loads from any folder.
//
// MuJoCo 3.5's attach and mj_copySpec silently drop an element whose reference does not
// resolve (an actuator on a joint the model lacks); the composer checks every attached model
// and every copy for that and reports MuJoCo's error for the model on its own instead.
//
// Errors are mlspaces::Error on one line with path = the source file and field = "line N,
// element <tag>": MuJoCo's message, located in the file it is about (the scene, an included
// file, an attached model's file; see src/sim/mjcf_source_map.h for how), and for a name
// defined twice, both places.
//
// Lifetimes: a compiled model (ModelPtr) is owned by the caller and independent of the
// composer. spec(), warnings() and path() refer into the composer: valid until it is destroyed
// or assigned to (a moved-to composer carries them along).
#pragma once

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/export.h"

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/transform.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {

struct MLSPACES_API ComposeOptions {
  /// Keep only what body masses and geometry need: drop textures, materials, skins and
  /// lights, and turn collisions off (no convex hulls to build). Masses, inertias and
  /// geom/mesh vertex data equal a full compile's; rendering and contacts do not.
  bool physics_only = false;
};

/// A composed model (an mjSpec). Copying copies the spec (mj_copySpec), cheap next to a
/// compile; a copy of a model with a reference MuJoCo cannot resolve throws its Error.
class MLSPACES_API MjcfComposer {
 public:
  // ===========================================================================================
  // Construction

  /// Composes an MJCF file. @throws Error naming the file, line and element.
  explicit MjcfComposer(const std::filesystem::path& file, ComposeOptions options = {});
  /// Composes MJCF text; relative paths resolve against `path_for_errors`'s folder.
  static MjcfComposer FromString(std::string_view xml, const std::filesystem::path& path_for_errors,
                                 ComposeOptions options = {});
  MjcfComposer(const MjcfComposer& other);
  MjcfComposer& operator=(const MjcfComposer& other);
  MjcfComposer(MjcfComposer&&) noexcept;
  MjcfComposer& operator=(MjcfComposer&&) noexcept;
  ~MjcfComposer();

  // ===========================================================================================
  // Attaching

  /// Attaches a model file at run time, as <attach> would: under body `parent_body` ("" or
  /// "world" for the worldbody), at `pose` relative to that body, with `prefix` on every name.
  /// `body` picks one body's subtree of the model; empty takes its whole worldbody.
  /// @returns the (prefixed) names of the top-level bodies inserted.
  /// @throws Error for an unknown parent body or a bad model file.
  std::vector<std::string> Attach(const std::filesystem::path& file, std::string_view parent_body,
                                  std::string_view prefix, const Pose& pose,
                                  std::string_view body = {});

  /// Attach for a model given as MJCF text; its relative paths resolve against
  /// `path_for_errors`'s folder, and errors name that path.
  std::vector<std::string> AttachString(std::string_view xml,
                                        const std::filesystem::path& path_for_errors,
                                        std::string_view parent_body, std::string_view prefix,
                                        const Pose& pose, std::string_view body = {});

  /// Attach for a model composed already (parsed once, attached as often as wanted; `model`
  /// must have the same ComposeOptions). @throws Error as Attach.
  std::vector<std::string> Attach(const MjcfComposer& model, std::string_view parent_body,
                                  std::string_view prefix, const Pose& pose,
                                  std::string_view body = {});

  // ===========================================================================================
  // Queries

  /// The names of the worldbody's child bodies ("" for an unnamed one), in order.
  std::vector<std::string> TopLevelBodies() const;

  /// True when a body of that name exists (mjs_findBody; names as prefixed).
  bool HasBody(std::string_view name) const;

  // ===========================================================================================
  // Compiling and emitting

  /// The composed model as plain MJCF (compiled, then written by MuJoCo). @throws Error as
  /// Compile.
  std::string Emit() const;

  /// Compiles the composed model (the spec stays as it was): never null, owned by the caller.
  /// @throws Error with the source file, line and element; for a name defined twice, naming
  /// both files and lines.
  ModelPtr Compile() const { return Compile(nullptr); }
  /// Compile where files in `vfs` take precedence over the disk (e.g. meshes given in memory);
  /// `vfs` may be null (the disk only) and is read during the call only.
  ModelPtr Compile(const mjVFS* vfs) const;

  // ===========================================================================================
  // Access

  /// The composed model's mjSpec, for edits with MuJoCo's API before compiling: never null,
  /// owned by the composer (do not delete it). Edits show in Compile, Emit and copies.
  mjSpec* spec();
  const mjSpec* spec() const;

  /// MuJoCo's compile warnings, of every Compile/Emit so far: severity kWarning, path = the
  /// file this composer was built from, message = MuJoCo's text. Printed as
  /// MujocoWarningLine. The reference lives as long as the composer; a Compile/Emit appends.
  const std::vector<Diagnostic>& warnings() const;

  /// The file this composer was built from (FromString: `path_for_errors`).
  const std::filesystem::path& path() const;

 private:
  MjcfComposer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// A MuJoCo warning of MjcfComposer::warnings on one line: "MuJoCo: <message>".
MLSPACES_API std::string MujocoWarningLine(const Diagnostic& warning);

/// Convenience: compose and compile a file; never null, owned by the caller. @throws Error.
ModelPtr ComposeAndCompile(const std::filesystem::path& file, ComposeOptions options = {});

}  // namespace mlspaces::sim
