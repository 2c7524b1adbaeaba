#include "mlspaces/sim/mujoco_handlers.h"

#include <cstring>
#include <mutex>

namespace mlspaces::sim {
namespace {

thread_local std::vector<std::string> tls_warnings;

void ThrowingErrorHandler(const char* msg) { throw MujocoError(msg ? msg : "MuJoCo error"); }

void CollectingWarningHandler(const char* msg) {
  if (tls_warnings.size() < 1000) tls_warnings.emplace_back(msg ? msg : "");
}

struct VfsHolder {
  mjVFS vfs;
  VfsHolder() { mj_defaultVFS(&vfs); }
  ~VfsHolder() { mj_deleteVFS(&vfs); }
  VfsHolder(const VfsHolder&) = delete;
  VfsHolder& operator=(const VfsHolder&) = delete;
  void Add(const std::string& name, std::string_view data) {
    if (name.empty()) throw MujocoError("VFS file name is empty");
    int rc = mj_addBufferVFS(&vfs, name.c_str(), data.data(), static_cast<int>(data.size()));
    if (rc != 0) {
      throw MujocoError("cannot add '" + name + "' to the MuJoCo VFS (" +
                        (rc == 2 ? std::string("repeated name") : "code " + std::to_string(rc)) +
                        ")");
    }
  }
};

}  // namespace

void InstallMujocoHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = ThrowingErrorHandler;
    mju_user_warning = CollectingWarningHandler;
    // MuJoCo 3's compiler keeps decoded meshes and textures in a process-wide asset cache,
    // keyed by file name and the file's timestamp; a file rewritten within the timestamp's
    // granularity (an asset fixed and re-indexed, a test's scratch mesh) would compile from
    // the stale entry. Every file is read afresh instead.
    mj_setCacheCapacity(mj_getCache(), 0);
  });
}

std::vector<std::string> TakeMujocoWarnings() {
  std::vector<std::string> out;
  out.swap(tls_warnings);
  return out;
}

ModelPtr LoadModelFromMemory(std::string_view xml, const std::string& main_name,
                             const std::vector<VfsFile>& extra) {
  InstallMujocoHandlers();
  VfsHolder holder;
  holder.Add(main_name, xml);
  for (const VfsFile& f : extra) holder.Add(f.name, f.data);
  char error[1024] = "";
  mjModel* m = mj_loadXML(main_name.c_str(), &holder.vfs, error, sizeof error);
  if (!m) throw MujocoError(error[0] ? error : "mj_loadXML failed");
  return ModelPtr(m);
}

DataPtr MakeData(const mjModel* m) {
  InstallMujocoHandlers();
  mjData* d = mj_makeData(m);
  if (!d) throw MujocoError("mj_makeData failed");
  return DataPtr(d);
}

std::string MjName(const mjModel* m, mjtObj type, int id) {
  const char* name = mj_id2name(m, type, id);
  return name ? name : "";
}

bool InSubtree(const mjModel* m, int body, int root) {
  while (body > 0 && body != root) body = m->body_parentid[body];
  return body == root;
}

std::vector<int> CollisionGeoms(const mjModel* m, int root) {
  std::vector<int> out;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_contype[g] == 0 && m->geom_conaffinity[g] == 0) continue;
    if (InSubtree(m, m->geom_bodyid[g], root)) out.push_back(g);
  }
  return out;
}

}  // namespace mlspaces::sim
