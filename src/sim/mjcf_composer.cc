#include "mlspaces/sim/mjcf_composer.h"

#include <mutex>

#include <mujoco/mjspec.h>

#include "mjcf_source_map.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
using internal::SourceRoot;

struct SpecDeleter {
  void operator()(mjSpec* s) const { mj_deleteSpec(s); }
};
using SpecPtr = std::unique_ptr<mjSpec, SpecDeleter>;

struct VfsDeleter {
  void operator()(mjVFS* v) const {
    mj_deleteVFS(v);
    delete v;
  }
};

/// An mjString's text ("" for none).
std::string Str(const mjString* s) {
  const char* c = s ? mjs_getString(s) : nullptr;
  return c ? c : "";
}

/// The spec's compiler error or warning ("" for none).
std::string SpecError(mjSpec* spec) {
  const char* e = mjs_getError(spec);
  return e ? e : "";
}

fs::path Absolute(const fs::path& p) { return fs::absolute(p).lexically_normal(); }

/// Parses MJCF text as the file `path` (relative paths resolve against its folder; <include>
/// and <model> files are read from disk). @throws Error naming the file and line at fault.
SpecPtr Parse(const SourceRoot& root) {
  InstallMujocoHandlers();
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  const std::string name = root.path.string();
  if (mj_addBufferVFS(vfs.get(), name.c_str(), root.text.data(),
                      static_cast<int>(root.text.size())) != 0) {
    throw Error("cannot hand the model text to MuJoCo", name);
  }
  char error[2048] = "";
  mjSpec* spec = nullptr;
  try {
    spec = mj_parseXML(name.c_str(), vfs.get(), error, sizeof error);
  } catch (const MujocoError& e) {
    internal::ThrowParseError(e.what(), root);
  }
  if (!spec) internal::ThrowParseError(error[0] ? error : "mj_parseXML failed", root);
  // Attach copies the attached model (so a child spec may be freed right after mjs_attach,
  // and a whole-model attach works; MuJoCo's default attaches a spec by reference).
  mjs_setDeepCopy(spec, 1);
  return SpecPtr(spec);
}

fs::path ResolveIn(const fs::path& dir, const std::string& sub, const std::string& file) {
  const fs::path base = sub.empty() ? dir : fs::path(sub).is_absolute() ? fs::path(sub) : dir / sub;
  return (base / file).lexically_normal();
}

void DropRendering(mjSpec* spec);

/// Gives the asset files of a freshly parsed spec absolute paths, so that Emit's MJCF (which
/// writes file names as they are in the spec) loads from anywhere and attached models keep
/// their files. Only for a model without <model> assets (its own or its includes'; included
/// files' paths are relative to the including model, as MuJoCo reads them): MuJoCo resolves an
/// attached model's files against that model's folder and meshdir, which the spec does not
/// expose once attached, so those are left as MuJoCo keeps them.
void AbsolutizeFiles(mjSpec* spec, const SourceRoot& root) {
  const fs::path dir = root.path.parent_path();
  const std::string meshdir = Str(spec->compiler.meshdir);
  const std::string texturedir = Str(spec->compiler.texturedir);
  auto fix = [&](mjString* file, const std::string& sub) {
    const std::string f = Str(file);
    if (f.empty() || fs::path(f).is_absolute()) return;
    mjs_setString(file, ResolveIn(dir, sub, f).string().c_str());
  };
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_MESH); e; e = mjs_nextElement(spec, e)) {
    fix(mjs_asMesh(e)->file, meshdir);
  }
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_HFIELD); e; e = mjs_nextElement(spec, e)) {
    fix(mjs_asHField(e)->file, meshdir);
  }
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_SKIN); e; e = mjs_nextElement(spec, e)) {
    fix(mjs_asSkin(e)->file, meshdir);
  }
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_TEXTURE); e; e = mjs_nextElement(spec, e)) {
    // (A cube texture's six separate files stay as written: the C API has no getter for
    // them, and mjString is MuJoCo's std::string, not necessarily ours to read directly.)
    fix(mjs_asTexture(e)->file, texturedir);
  }
}

/// Elements that refer to others by name: what MuJoCo 3.5's mj_copySpec (like its attach)
/// silently drops when the reference does not resolve.
int CountReferrers(mjSpec* spec) {
  int n = 0;
  for (mjtObj type :
       {mjOBJ_ACTUATOR, mjOBJ_SENSOR, mjOBJ_TENDON, mjOBJ_EQUALITY, mjOBJ_PAIR, mjOBJ_EXCLUDE}) {
    for (mjsElement* e = mjs_firstElement(spec, type); e; e = mjs_nextElement(spec, e)) ++n;
  }
  return n;
}

/// Compiles `spec` on its own. @throws Error located in `root`'s files.
void CompileAlone(mjSpec* spec, const SourceRoot& root) {
  mjModel* m = nullptr;
  try {
    m = mj_compile(spec, nullptr);
  } catch (const MujocoError& e) {
    internal::ThrowCompileError(e.what(), {root});
  }
  if (!m) internal::ThrowCompileError(SpecError(spec), {root});
  mj_deleteModel(m);
  TakeMujocoWarnings();
}

/// MuJoCo 3.5's attach (and mj_copySpec) drops, without a word, whatever in the attached
/// model refers to an element the model lacks (an actuator on a missing joint, ...): the
/// composed model compiles without it. A copy drops the same, so a copy with fewer referring
/// elements means such a reference; compiling the model on its own then reports it.
/// @throws Error located in `root`'s files.
void CheckReferences(mjSpec* spec, const SourceRoot& root) {
  SpecPtr copy(mj_copySpec(spec));
  if (copy && CountReferrers(copy.get()) == CountReferrers(spec)) return;
  CompileAlone(spec, root);
  throw Error("MuJoCo cannot resolve a reference of this model", root.path.string());
}

/// The <model> assets of `root` and its includes (only files that have a <model> or an
/// <include> are read for this).
std::vector<std::pair<std::string, fs::path>> ModelAssetsOf(const SourceRoot& root) {
  if (root.text.find("<model") == std::string::npos &&
      root.text.find("<include") == std::string::npos) {
    return {};
  }
  return internal::ModelAssets(root);
}

/// CheckReferences for each <model> asset of `spec` (as parsed from `root`, `models` its
/// assets): MuJoCo's parser has attached them already.
void CheckModelAssets(mjSpec* spec, const std::vector<std::pair<std::string, fs::path>>& models,
                      int depth = 0) {
  if (depth > 32) return;
  for (const auto& [name, file] : models) {
    mjSpec* child = mjs_findSpec(spec, name.c_str());
    if (!child) continue;
    SourceRoot child_root{file, "", ""};
    try {
      child_root.text = ReadFile(file);
    } catch (const Error&) {
      continue;  // the parser has read it; nothing to locate errors in
    }
    CheckModelAssets(child, ModelAssetsOf(child_root), depth + 1);
    CheckReferences(child, child_root);
  }
}

SpecPtr ParseRoot(const SourceRoot& root, const ComposeOptions& options) {
  SpecPtr spec = Parse(root);
  const auto models = ModelAssetsOf(root);
  CheckModelAssets(spec.get(), models);
  if (models.empty()) AbsolutizeFiles(spec.get(), root);
  if (options.physics_only) DropRendering(spec.get());
  return spec;
}

SourceRoot ReadRoot(const fs::path& file, std::string prefix) {
  SourceRoot root{Absolute(file), "", std::move(prefix)};
  root.text = ReadFile(root.path);
  return root;
}

/// physics_only: drops textures, materials, skins and lights (and every reference to a
/// material), which masses, inertias and geometry do not depend on, and turns collisions
/// off: MuJoCo 3.5 then builds no convex hull for a mesh whose inertia does not need one
/// (the default "legacy" inertia does not; measured 15% of a 1,000-vertex asset's compile).
void DropRendering(mjSpec* spec) {
  for (mjtObj type : {mjOBJ_GEOM, mjOBJ_SITE, mjOBJ_TENDON, mjOBJ_FLEX}) {
    for (mjsElement* e = mjs_firstElement(spec, type); e; e = mjs_nextElement(spec, e)) {
      if (mjsGeom* g = mjs_asGeom(e)) {
        mjs_setString(g->material, "");
        g->contype = 0;
        g->conaffinity = 0;
      }
      if (mjsSite* s = mjs_asSite(e)) mjs_setString(s->material, "");
      if (mjsTendon* t = mjs_asTendon(e)) mjs_setString(t->material, "");
      if (mjsFlex* f = mjs_asFlex(e)) mjs_setString(f->material, "");
    }
  }
  for (mjtObj type : {mjOBJ_SKIN, mjOBJ_MATERIAL, mjOBJ_TEXTURE, mjOBJ_LIGHT}) {
    while (mjsElement* e = mjs_firstElement(spec, type)) {
      if (mjs_delete(spec, e) != 0) throw Error("MuJoCo: " + SpecError(spec));
    }
  }
}

/// MuJoCo 3.5 writes the default classes of a model attached with an empty prefix as nested
/// <default> elements without a class name, which its own parser rejects ("empty class
/// name"). This names them (nothing refers to them: the writer gives every element its
/// values or a named class), so the emitted MJCF loads.
std::string NameUnnamedDefaults(std::string xml) {
  int depth = 0, named = 0;
  for (size_t at = xml.find('<'); at != std::string::npos; at = xml.find('<', at + 1)) {
    if (xml.compare(at, 10, "</default>") == 0) {
      --depth;
      continue;
    }
    if (xml.compare(at, 8, "<default") != 0 ||
        (xml[at + 8] != '>' && xml[at + 8] != '/' && xml[at + 8] != ' ')) {
      continue;
    }
    const size_t end = xml.find('>', at);
    if (end == std::string::npos) break;
    const bool closed = xml[end - 1] == '/';
    if (depth > 0 && xml.substr(at, end - at).find(" class=") == std::string::npos) {
      xml.insert(at + 8, " class=\"mlspaces_unnamed_" + std::to_string(named++) + "\"");
    }
    if (!closed) ++depth;
  }
  return xml;
}

}  // namespace

struct MjcfComposer::Impl {
  SpecPtr spec;
  ComposeOptions options;
  fs::path path;
  std::vector<SourceRoot> roots;  // the composed file, then each run-time attach
  mutable std::vector<Diagnostic> warnings;
  mutable std::mutex mutex;

  /// Compiles the spec itself. A compile leaves the spec as it was, and a spec compiles again
  /// after more attaches; the lock keeps concurrent Compile/Emit calls of one (const) composer
  /// apart. (Not a copy: mj_copySpec of MuJoCo 3.5 drops an unresolvable reference, e.g. an
  /// actuator on a missing joint, and the copy would compile without the error.)
  ModelPtr CompileSpec(const mjVFS* vfs = nullptr) const {
    TakeMujocoWarnings();
    mjModel* m = nullptr;
    try {
      m = mj_compile(spec.get(), vfs);
    } catch (const MujocoError& e) {
      internal::ThrowCompileError(e.what(), roots);
    }
    if (!m) internal::ThrowCompileError(SpecError(spec.get()), roots);
    ModelPtr model(m);
    if (mjs_isWarning(spec.get()) && !SpecError(spec.get()).empty()) {
      warnings.emplace_back(path.string(), "", internal::OneLine(SpecError(spec.get())), "",
                            Severity::kWarning);
    }
    for (std::string& w : TakeMujocoWarnings()) {
      warnings.emplace_back(path.string(), "", std::move(w), "", Severity::kWarning);
    }
    return model;
  }

  mjsBody* Parent(std::string_view parent_body) const {
    const std::string parent_name =
        parent_body.empty() || parent_body == "world" ? "world" : std::string(parent_body);
    mjsBody* parent = mjs_findBody(spec.get(), parent_name.c_str());
    if (!parent) {
      throw Error("no body named '" + parent_name + "' to attach under", path.string());
    }
    return parent;
  }

  std::vector<std::string> Attach(SourceRoot root, std::string_view parent_body, const Pose& pose,
                                  std::string_view body) {
    Parent(parent_body);  // before reading the file: a bad parent is the caller's error
    SpecPtr child = ParseRoot(root, options);
    return AttachSpec(child.get(), std::move(root), parent_body, pose, body);
  }

  /// Attaches `child` (parsed from `root`, whose prefix is the one to put on its names).
  std::vector<std::string> AttachSpec(mjSpec* child, SourceRoot root, std::string_view parent_body,
                                      const Pose& pose, std::string_view body) {
    mjSpec* s = spec.get();
    mjsBody* parent = Parent(parent_body);
    const mjsElement* what = child->element;
    std::vector<std::string> bodies;
    auto name_of = [&](mjsElement* e) {
      const std::string n = Str(mjs_getName(e));
      return n.empty() ? n : root.prefix + n;
    };
    if (body.empty()) {
      mjsBody* world = mjs_findBody(child, "world");
      for (mjsElement* e = mjs_firstChild(world, mjOBJ_BODY, 0); e;
           e = mjs_nextChild(world, e, 0)) {
        bodies.push_back(name_of(e));
      }
    } else {
      mjsBody* b = mjs_findBody(child, std::string(body).c_str());
      if (!b) {
        throw Error("the model has no body '" + std::string(body) + "' to attach",
                    root.path.string());
      }
      what = b->element;
      bodies.push_back(name_of(b->element));
    }
    // Checked first: attach would drop a dangling reference without a word.
    CheckReferences(child, SourceRoot{root.path, root.text, ""});
    mjsFrame* frame = mjs_addFrame(parent, nullptr);
    std::copy(pose.pos.begin(), pose.pos.end(), frame->pos);
    std::copy(pose.quat.begin(), pose.quat.end(), frame->quat);
    mjsElement* attached = nullptr;
    std::string error;
    try {
      attached = mjs_attach(frame->element, what, root.prefix.c_str(), "");
    } catch (const MujocoError& e) {
      error = e.what();
    }
    if (!attached) {
      std::vector<SourceRoot> with_child = roots;
      with_child.push_back(root);
      internal::ThrowCompileError(error.empty() ? SpecError(s) : error, with_child);
    }
    roots.push_back(std::move(root));
    return bodies;
  }
};

MjcfComposer::MjcfComposer() : impl_(std::make_unique<Impl>()) {}

MjcfComposer::MjcfComposer(const fs::path& file, ComposeOptions options) : MjcfComposer() {
  SourceRoot root = ReadRoot(file, "");
  impl_->options = options;
  impl_->path = file;
  impl_->spec = ParseRoot(root, options);
  impl_->roots.push_back(std::move(root));
}

MjcfComposer MjcfComposer::FromString(std::string_view xml, const fs::path& path_for_errors,
                                      ComposeOptions options) {
  MjcfComposer c;
  SourceRoot root{Absolute(path_for_errors), std::string(xml), ""};
  c.impl_->options = options;
  c.impl_->path = path_for_errors;
  c.impl_->spec = ParseRoot(root, options);
  c.impl_->roots.push_back(std::move(root));
  return c;
}

MjcfComposer::MjcfComposer(const MjcfComposer& other) : MjcfComposer() { *this = other; }

MjcfComposer& MjcfComposer::operator=(const MjcfComposer& other) {
  if (this == &other) return *this;
  auto impl = std::make_unique<Impl>();
  impl->spec.reset(mj_copySpec(other.impl_->spec.get()));
  if (!impl->spec) throw Error("MuJoCo could not copy the model", other.impl_->path.string());
  mjs_setDeepCopy(impl->spec.get(), 1);
  if (CountReferrers(impl->spec.get()) != CountReferrers(other.impl_->spec.get())) {
    // The copy lost a dangling reference (see CheckReferences): compiling the original names it.
    other.Compile();
    throw Error("MuJoCo left out part of the model when copying it", other.impl_->path.string());
  }
  impl->options = other.impl_->options;
  impl->path = other.impl_->path;
  impl->roots = other.impl_->roots;
  impl->warnings = other.impl_->warnings;
  impl_ = std::move(impl);
  return *this;
}

MjcfComposer::MjcfComposer(MjcfComposer&&) noexcept = default;
MjcfComposer& MjcfComposer::operator=(MjcfComposer&&) noexcept = default;
MjcfComposer::~MjcfComposer() = default;

std::vector<std::string> MjcfComposer::Attach(const fs::path& file, std::string_view parent_body,
                                              std::string_view prefix, const Pose& pose,
                                              std::string_view body) {
  return impl_->Attach(ReadRoot(file, std::string(prefix)), parent_body, pose, body);
}

std::vector<std::string> MjcfComposer::AttachString(std::string_view xml,
                                                    const fs::path& path_for_errors,
                                                    std::string_view parent_body,
                                                    std::string_view prefix, const Pose& pose,
                                                    std::string_view body) {
  return impl_->Attach(SourceRoot{Absolute(path_for_errors), std::string(xml), std::string(prefix)},
                       parent_body, pose, body);
}

std::vector<std::string> MjcfComposer::Attach(const MjcfComposer& model,
                                              std::string_view parent_body, std::string_view prefix,
                                              const Pose& pose, std::string_view body) {
  if (&model == this) throw UsageError("Attach: a model cannot be attached to itself");
  if (model.impl_->options.physics_only != impl_->options.physics_only) {
    throw UsageError("Attach: the model was composed with other ComposeOptions",
                     model.impl_->path.string());
  }
  const SourceRoot& own = model.impl_->roots.front();
  std::lock_guard<std::mutex> lock(model.impl_->mutex);
  return impl_->AttachSpec(model.impl_->spec.get(),
                           SourceRoot{own.path, own.text, std::string(prefix)}, parent_body, pose,
                           body);
}

std::vector<std::string> MjcfComposer::TopLevelBodies() const {
  std::vector<std::string> out;
  mjsBody* world = mjs_findBody(impl_->spec.get(), "world");
  for (mjsElement* e = mjs_firstChild(world, mjOBJ_BODY, 0); e; e = mjs_nextChild(world, e, 0)) {
    out.push_back(Str(mjs_getName(e)));
  }
  return out;
}

bool MjcfComposer::HasBody(std::string_view name) const {
  return mjs_findBody(impl_->spec.get(), std::string(name).c_str()) != nullptr;
}

std::string MjcfComposer::Emit() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->CompileSpec();  // MuJoCo writes compiled specs only
  char error[1024] = "";
  std::string xml(1 << 16, '\0');
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int rc = mj_saveXMLString(impl_->spec.get(), xml.data(), static_cast<int>(xml.size()),
                                    error, sizeof error);
    if (rc == 0) {
      xml.resize(xml.find('\0'));
      return NameUnnamedDefaults(std::move(xml));
    }
    if (rc < 0) break;
    xml.assign(static_cast<size_t>(rc) + 1, '\0');  // rc: the size it needs
  }
  throw Error(
      std::string("MuJoCo could not write the model: ") + (error[0] ? error : "unknown error"),
      impl_->path.string());
}

ModelPtr MjcfComposer::Compile(const mjVFS* vfs) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->CompileSpec(vfs);
}

mjSpec* MjcfComposer::spec() { return impl_->spec.get(); }
const mjSpec* MjcfComposer::spec() const { return impl_->spec.get(); }

const std::vector<Diagnostic>& MjcfComposer::warnings() const { return impl_->warnings; }

std::string MujocoWarningLine(const Diagnostic& warning) { return "MuJoCo: " + warning.message; }

const fs::path& MjcfComposer::path() const { return impl_->path; }

ModelPtr ComposeAndCompile(const fs::path& file, ComposeOptions options) {
  return MjcfComposer(file, options).Compile();
}

}  // namespace mlspaces::sim
