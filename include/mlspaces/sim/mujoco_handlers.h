// MuJoCo plumbing: error/warning handlers, owning pointers, loading from memory.
//
// Error policy. MuJoCo's default error handler prints and then waits for Enter; we replace it
// (InstallMujocoHandlers) with one that throws MujocoError. That unwinds through MuJoCo's C
// frames, which is what MuJoCo's own model compiler does with its thread-local handler
// (_mjPRIVATE__set_tls_error_fn); on x86-64 Linux, GCC emits unwind tables for C code, and the
// C frames hold no resources of ours. mj_loadXML itself never calls the global handler for bad
// XML: it returns null plus a message, which LoadModelFromMemory turns into MujocoError.
// Warnings go to a thread-local collector (TakeMujocoWarnings) instead of stdout.
#pragma once

#include "mlspaces/core/export.h"

#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"

namespace mlspaces::sim {

/// An error reported by MuJoCo: an mlspaces::Error whose message is MuJoCo's, unchanged
/// (it may span lines; the layers above turn it into a located one-line Error where they can).
class MLSPACES_API MujocoError : public Error {
 public:
  explicit MujocoError(const std::string& message) : Error(message) {}
};

/// Installs mlspaces' global mju_user_error (throws MujocoError) and mju_user_warning
/// (collects). Idempotent and thread-safe; every function of this layer calls it.
MLSPACES_API void InstallMujocoHandlers();

/// Returns and clears the MuJoCo warnings collected on this thread.
MLSPACES_API std::vector<std::string> TakeMujocoWarnings();

struct MLSPACES_API ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct MLSPACES_API DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

/// One in-memory file for the VFS: a bare file name (no folders) and its bytes.
struct MLSPACES_API VfsFile {
  std::string name;
  std::string data;
};

/// Compiles an MJCF document from memory through an mjVFS; never null, owned by the caller.
/// `xml` is stored as `main_name`; `extra` files (meshes, textures, includes) are added under
/// their names. Files not in the VFS are read from disk as MuJoCo does (absolute paths work).
/// @throws MujocoError with MuJoCo's message (e.g. "XML Error: ...\nElement 'geom', line 3").
ModelPtr LoadModelFromMemory(std::string_view xml, const std::string& main_name = "model.xml",
                             const std::vector<VfsFile>& extra = {});

/// mj_makeData with a null check: never null, owned by the caller, for use with `m`.
/// @throws MujocoError.
MLSPACES_API DataPtr MakeData(const mjModel* m);

/// Name of object `id` of type `type`, or "" when unnamed.
MLSPACES_API std::string MjName(const mjModel* m, mjtObj type, int id);

/// True when `body` is `root` or lies below it (the world body 0 holds every body).
MLSPACES_API bool InSubtree(const mjModel* m, int body, int root);

/// Ids of the collision geoms (contype or conaffinity non-zero) of body `root` and below, in
/// id order.
MLSPACES_API std::vector<int> CollisionGeoms(const mjModel* m, int root);

}  // namespace mlspaces::sim
