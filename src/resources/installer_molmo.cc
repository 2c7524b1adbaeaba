// The Installer's MolmoSpaces-format half: the original's set-up of every pinned source,
// UID -> object archive + grasp archives (install_uid), scenes
// (install_scene_with_objects_and_grasps_from_path), whole sources, the licence policy.
// The cache and install-dir work itself is MolmoSources' (molmo_remote.cc).
#include <cctype>

#include "installer_impl.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/resources/legacy_source.h"
#include "mlspaces/resources/objathor.h"
#include "mlspaces/resources/package.h"

namespace mlspaces {

using SeenArchives = std::set<std::pair<const InstalledSource*, uint32_t>>;

namespace {

/// A boolean environment variable as the original's str2bool reads it; `fallback` when unset.
/// @throws UsageError for anything else.
bool EnvBool(const char* name, bool fallback) {
  const char* raw = std::getenv(name);
  if (raw == nullptr) return fallback;
  std::string v(raw);
  for (char& c : v) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (v == "false" || v == "no" || v == "f" || v == "n" || v == "0") return false;
  if (v == "true" || v == "yes" || v == "t" || v == "y" || v == "1") return true;
  throw UsageError(std::string(name) + "='" + raw + "' is not a boolean (true/false, yes/no, 1/0)");
}

}  // namespace

MolmoSources& Installer::Impl::Molmo() {
  if (!molmo) {
    MolmoSources::Options o;
    o.note = options.note;
    o.parallel_downloads = options.parallel_downloads;
    o.retries = options.retries;
    o.force_install = EnvBool("MLSPACES_FORCE_INSTALL", o.force_install);
    o.progress = [this](uint64_t delta) {
      const uint64_t now = molmo_done += delta;
      if (options.progress) options.progress(now, molmo_total);
    };
    molmo = std::make_unique<MolmoSources>(settings, std::move(o));
  }
  return *molmo;
}

const InstalledSource* Installer::Impl::SetupMolmo(const std::string& type, const std::string& name,
                                                   const std::string& version) {
  const MolmoSource* m = Molmo().Setup(type, name, version);
  if (m == nullptr) return nullptr;
  InstalledSource src;
  src.type = type;
  src.name = name;
  src.version = version;
  src.dir = m->dir;
  src.molmo = m;
  return &sources.insert_or_assign(std::make_pair(type, name), std::move(src)).first->second;
}

const InstalledSource* Installer::Impl::TrySetup(const std::string& type, const std::string& name,
                                                 bool note) {
  const auto key = std::make_pair(type, name);
  if (not_packages.count(key) != 0) return nullptr;
  std::string version;
  try {
    version = VersionOf(type, name);
  } catch (const Error&) {
    return nullptr;  // unknown or unpinned: nothing to set up
  }
  try {
    return &Setup(type, name);
  } catch (const Error&) {
    if (not_packages.count(key) == 0) throw;
    if (note) {
      Note(type + "/" + name + " " + version + " is not on " + settings.remote_url +
           " (neither an mlspaces package nor a MolmoSpaces-format source): skipped");
    }
    return nullptr;
  }
}

void Installer::Impl::AddMolmoArchive(InstallPlan& plan, SeenArchives& seen,
                                      const InstalledSource& src, const std::string& archive,
                                      bool link) {
  const MolmoSource& m = *src.molmo;
  uint32_t index = 0;
  if (auto t = m.tries.Find(archive)) {
    index = *t;
  } else if (auto it = m.size_mb.find(archive); it != m.size_mb.end()) {
    index = static_cast<uint32_t>(m.tries.archives.size() + std::distance(m.size_mb.begin(), it));
  } else {
    throw Error("Unknown package " + archive, (m.dir / std::string(kSizeManifestFile)).string());
  }
  if (record != nullptr) (*record)[src.type][src.name].insert(archive);
  if (!seen.insert({&src, index}).second) {
    if (link && unlinked.erase({&src, archive}) != 0 && m.Extracted(archive)) {
      Molmo().LinkArchives(m, {archive});
    }
    return;
  }
  if (m.Extracted(archive)) {
    ++plan.already_installed;
    // PER_FILE: links an archive extracted unlinked (unless this is the bulk install).
    if (link) {
      Molmo().LinkArchives(m, {archive});
    } else {
      unlinked.insert({&src, archive});
    }
    return;
  }
  if (!link) unlinked.insert({&src, archive});
  const uint64_t size = m.SizeBytes(archive);
  plan.archives.push_back({&src, archive, size, 0, index});
  plan.download_bytes += size;
}

void Installer::Impl::SetupAll(InstallPlan& plan, SeenArchives& seen) {
  // Copy the keys: Setup may add to the versions' cache of sources.
  std::vector<std::pair<std::string, std::string>> pinned;
  auto collect = [&] {
    pinned.clear();
    bool missing = false;
    for (const auto& [type, srcs] : Versions()) {
      for (const auto& [name, version] : srcs) {
        if (version.empty()) continue;
        pinned.emplace_back(type, name);
        missing = missing || !SetUpInCache(type, name, version);
      }
    }
    return missing;
  };
  // A complete cache needs no network: the remote's listing only when something is missing.
  if (collect() && FetchListing()) collect();
  // post_setup's bulk mode (spec 7.5), never in a multiprocessing child.
  const bool bulk = std::getenv("_IN_MULTIPROCESSING_CHILD") == nullptr &&
                    EnvBool("MLSPACES_DOWNLOAD_EXTRACT_ALL_SCENES_OBJECTS_GRASPS", false);
  for (const auto& [type, name] : pinned) {
    try {
      ResolveSourceBehavior(type, name);
    } catch (const Error&) {
      continue;  // a data type the original has no behaviour for
    }
    const InstalledSource* src = TrySetup(type, name, /*note=*/false);
    if (src == nullptr || src->molmo == nullptr) continue;
    const MolmoSource& m = *src->molmo;
    std::set<std::string> all(m.tries.archives.begin(), m.tries.archives.end());
    for (const auto& [a, mb] : m.size_mb) all.insert(a);
    std::vector<std::string> wanted;
    bool link = true;
    if (m.behavior.mode == InstallMode::kEager) {
      wanted.assign(all.begin(), all.end());
    } else if (bulk && (type == "scenes" || type == "objects" || type == "grasps")) {
      // Every scene archive without linking; all objects and all grasps.
      wanted.assign(all.begin(), all.end());
      link = type != "scenes";
    } else if (type == "scenes") {
      // MolmoSpaces' post_setup: every scene archive of a small source, else its base
      // (unindexed) archives.
      const std::vector<std::string> names(all.begin(), all.end());
      wanted = names.size() < 10 ? names : m.index.Unindexed(names);
    }
    for (const std::string& a : wanted) AddMolmoArchive(plan, seen, *src, a, link);
  }
  all_set_up = true;
}

std::shared_ptr<const PackedLibrary> Installer::Impl::MolmoLibrary(const InstalledSource& src) {
  if (src.type != "objects" || src.name == "objathor_metadata") return nullptr;
  if (auto it = molmo_libs.find(src.name); it != molmo_libs.end()) return it->second;
  auto lib = PackedLibrary::Open(src.dir / std::string(kLegacyIndexDir), src.name, src.dir);
  molmo_libs.emplace(src.name, lib);
  return lib;
}

void Installer::Impl::InstallMolmo(const InstalledSource& src,
                                   const std::vector<std::string>& archives) {
  std::vector<std::string> linked, bulk;
  for (const std::string& a : archives) {
    (unlinked.count({&src, a}) != 0 ? bulk : linked).push_back(a);
  }
  if (!bulk.empty()) Molmo().Install(*src.molmo, bulk, /*link=*/false);
  if (!linked.empty() || bulk.empty()) Molmo().Install(*src.molmo, linked);
}

Registry& Installer::Impl::Libraries() {
  if (!registry) {
    registry = std::make_unique<Registry>(options.open_registry
                                              ? options.open_registry()
                                              : Registry(Registry::Options{settings.assets_dir}));
  }
  return *registry;
}

void Installer::Impl::PrepareAnnotations(InstallPlan& plan, SeenArchives& seen) {
  if (!options.dry_run) return;
  const InstalledSource* s = TrySetup("objects", "objathor_metadata");
  if (s == nullptr || s->molmo == nullptr) return;
  size_t missing = 0;
  for (const std::string& a : s->molmo->tries.archives) {
    if (s->molmo->Extracted(a)) continue;
    ++missing;
    AddMolmoArchive(plan, seen, *s, a);  // already in the plan when set up EAGER
  }
  if (missing == 0) return;
  annotations_unknown = true;
  Note(
      "dry run: --where and the licence policy read the annotations of "
      "objects/objathor_metadata, which is not installed; its " +
      std::to_string(missing) +
      " archives are in the plan, and every candidate is counted unfiltered");
}

Registry& Installer::Impl::Annotations() {
  if (annotations_unknown) return Libraries();  // a dry run without the annotations
  if (registry && registry_has_annotations) return *registry;
  // The objathor annotations are what GetAnnotation answers first: install them first.
  if (const InstalledSource* s = TrySetup("objects", "objathor_metadata");
      s != nullptr && s->molmo != nullptr) {
    std::vector<std::string> todo;
    for (const std::string& a : s->molmo->tries.archives) {
      if (!s->molmo->Extracted(a)) todo.push_back(a);
    }
    if (!todo.empty() && options.dry_run) {
      annotations_unknown = true;  // PrepareAnnotations said so
      return Libraries();
    }
    if (!todo.empty()) {
      Note(
          "installing objects/objathor_metadata first (annotations for --where and the "
          "licence policy)");
      InstallMolmo(*s, todo);
    }
  }
  // META's conversion of the original's store into ours, which the Registry reads.
  EnsureObjathorStore(settings.assets_dir);
  registry.reset();  // opened before the annotations were there, maybe
  registry_has_annotations = true;
  return Libraries();
}

bool Installer::Impl::Allowed(const std::string& uid, InstallPlan& plan) {
  if (options.license_policy == LicensePolicy::kAll || annotations_unknown) return true;
  const auto annotation = Annotations().GetAnnotation(uid);
  if (AllowedByLicensePolicy(options.license_policy, annotation.get())) return true;
  ++plan.left_out;
  Note(uid + ": left out by the licence policy " +
       std::string(LicensePolicyName(options.license_policy)) + " (licence " +
       AnnotationLicense(annotation.get()) + ")");
  return false;
}

namespace {

/// Records into `plan.requested` what AddMolmoArchive sees while alive.
class Recording {
 public:
  using Archives = std::map<std::string, std::map<std::string, std::set<std::string>>>;
  /// `slot` is Impl::record.
  Recording(Archives*& slot, InstallPlan& plan) : slot_(slot), plan_(plan) { slot_ = &seen_; }
  ~Recording() { slot_ = nullptr; }
  std::map<std::string, std::set<std::string>>& operator[](const std::string& type) {
    return seen_[type];
  }
  void Finish() {
    for (const auto& [type, sources] : seen_) {
      for (const auto& [source, archives] : sources) {
        plan_.requested[type][source].assign(archives.begin(), archives.end());
      }
    }
  }

 private:
  Archives*& slot_;
  InstallPlan& plan_;
  Archives seen_;
};

void SortPlan(InstallPlan& plan) {
  std::sort(plan.archives.begin(), plan.archives.end(), [](const auto& a, const auto& b) {
    return std::tie(a.source->type, a.source->name, a.archive) <
           std::tie(b.source->type, b.source->name, b.archive);
  });
}

bool IsInteger(std::string_view s) {
  if (!s.empty() && s[0] == '-') s.remove_prefix(1);
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

void Installer::Impl::AddGraspArchives(InstallPlan& plan, SeenArchives& seen,
                                       const std::string& grasp_source,
                                       const std::string& file_name) {
  const InstalledSource* g = TrySetup("grasps", grasp_source);
  if (g == nullptr || g->molmo == nullptr) return;
  for (const std::string& token : SplitQueryTokens(file_name)) {
    for (const std::string& a : g->molmo->index.QueryToken(token)) {
      AddMolmoArchive(plan, seen, *g, a);
    }
  }
}

void Installer::Impl::PlanMolmoAsset(InstallPlan& plan, SeenArchives& seen,
                                     const InstalledSource& src, const PackedLibrary& lib,
                                     const PackedAsset& asset) {
  AddMolmoArchive(plan, seen, src, lib.archives()[asset.archive]);
  const std::string stem = fs::path(std::string(asset.mjcf)).stem().string();
  // install_uid: droid_objaverse by default; THOR's grasps (droid) are EAGER, set up anyway.
  if (src.name != "thor") AddGraspArchives(plan, seen, options.grasp_source, stem);
}

InstallPlan Installer::PlanSource(const std::string& type, const std::string& name) {
  Impl& impl = *impl_;
  InstallPlan plan;
  SeenArchives seen;
  impl.SetupAll(plan, seen);
  const InstalledSource& src = impl.Setup(type, name);
  if (src.molmo != nullptr) {
    std::set<std::string> all(src.molmo->tries.archives.begin(), src.molmo->tries.archives.end());
    for (const auto& [a, mb] : src.molmo->size_mb) all.insert(a);
    for (const std::string& a : all) impl.AddMolmoArchive(plan, seen, src, a);
  } else {
    for (uint32_t i = 0; i < src.manifest.archives.size(); ++i) {
      const PackageArchive& a = src.manifest.archives[i];
      if (!seen.insert({&src, i}).second) continue;
      if (IsFile(src.dir / ExtractFlagName(a.name))) {
        ++plan.already_installed;
        continue;
      }
      plan.archives.push_back({&src, a.name, a.size, a.unpacked_bytes, i});
      plan.download_bytes += a.size;
      plan.unpacked_bytes += a.unpacked_bytes;
    }
  }
  SortPlan(plan);
  impl.NoteListing();
  return plan;
}

InstallPlan Installer::PlanScene(const std::string& scene, SceneRequest* request) {
  Impl& impl = *impl_;
  InstallPlan plan;
  SeenArchives seen;
  impl.SetupAll(plan, seen);
  std::vector<const InstalledSource*> scene_sources;
  if (auto t = impl.Versions().find("scenes"); t != impl.Versions().end()) {
    for (const auto& [name, version] : t->second) {
      if (version.empty()) continue;
      const InstalledSource* s = impl.TrySetup("scenes", name);
      if (s != nullptr && s->molmo != nullptr) scene_sources.push_back(s);
    }
  }
  if (scene_sources.empty()) {
    throw Error("no scene source is pinned and served by " + impl.settings.remote_url, "", "scenes",
                scene);
  }
  SceneRequest req;
  const InstalledSource* chosen = nullptr;
  std::vector<std::string> archives;
  // A number: "N" (one scene source) or "SOURCE:N".
  std::string source_part, number = scene;
  if (const size_t colon = scene.rfind(':'); colon != std::string::npos) {
    source_part = scene.substr(0, colon);
    number = scene.substr(colon + 1);
  }
  if (IsInteger(number) && (source_part.empty() || source_part.find('/') == std::string::npos)) {
    if (source_part.empty() && scene_sources.size() > 1) {
      throw UsageError("scene number " + number + ": several scene sources are pinned; write " +
                       "SOURCE:" + number);
    }
    for (const InstalledSource* s : scene_sources) {
      if (source_part.empty() || s->name == source_part) chosen = s;
    }
    if (chosen == nullptr) {
      throw Error("no scene source '" + source_part + "' pinned", "", "scenes", scene);
    }
    archives = chosen->molmo->index.QueryToken(number);
    if (archives.empty()) {
      throw Error("no scene " + number + " in scenes/" + chosen->name +
                      " (no archive of its NumericIndex holds that number)",
                  (chosen->dir / std::string(kTriesFile)).string(), "", scene);
    }
    for (const std::string& a : archives) {
      const auto index = chosen->molmo->tries.Find(a);
      if (!index) continue;
      for (const std::string& f : chosen->molmo->tries.files[*index]) {
        if (fs::path(f).extension() == ".xml") req.files.push_back(f);
      }
    }
  } else {
    // A path: absolute under <assets>/scenes/<source>/, "<source>/<path>", or a path inside
    // one of the scene sources.
    fs::path p(scene);
    const fs::path scenes_dir =
        fs::absolute(impl.settings.assets_dir / "scenes").lexically_normal();
    if (p.is_absolute()) {
      const fs::path rel = p.lexically_normal().lexically_relative(scenes_dir);
      if (rel.empty() || *rel.begin() == "..") {
        throw Error("not under " + scenes_dir.string(), scene, "", scene);
      }
      p = rel;
    }
    const std::string generic = p.lexically_normal().generic_string();
    for (const InstalledSource* s : scene_sources) {
      const std::string prefix = s->name + "/";
      std::string inside = generic;
      if (generic.rfind(prefix, 0) == 0 &&
          s->molmo->tries.ArchiveOf(generic.substr(prefix.size()))) {
        inside = generic.substr(prefix.size());
      }
      if (auto a = s->molmo->tries.ArchiveOf(inside)) {
        chosen = s;
        archives = {s->molmo->tries.archives[*a]};
        req.files = {inside};
        break;
      }
    }
    if (chosen == nullptr) {
      std::string names;
      for (const InstalledSource* s : scene_sources) names += (names.empty() ? "" : ", ") + s->name;
      throw Error("no scene '" + generic + "' in the tries of the scene sources [" + names + "]",
                  "", "scenes", scene);
    }
  }
  req.source = chosen->name;
  Recording recording(impl.record, plan);
  for (const std::string& a : archives) impl.AddMolmoArchive(plan, seen, *chosen, a);
  recording.Finish();
  plan.assets = req.files.size();
  if (request != nullptr) *request = std::move(req);
  SortPlan(plan);
  impl.NoteListing();
  return plan;
}

InstallPlan Installer::PlanSceneContents(const SceneRequest& request,
                                         const std::vector<std::string>& grasp_sources,
                                         bool objects, bool exclude_thor) {
  Impl& impl = *impl_;
  InstallPlan plan;
  SeenArchives seen;
  impl.SetupAll(plan, seen);
  if (impl.options.license_policy != LicensePolicy::kAll) impl.PrepareAnnotations(plan, seen);
  Recording recording(impl.record, plan);
  auto pinned = [&](const std::string& type, const std::string& name) {
    const SourceVersions& v = impl.Versions();
    auto t = v.find(type);
    return t != v.end() && t->second.count(name) != 0 && !t->second.at(name).empty();
  };
  // install_objects_for_scene does nothing unless objaverse is configured.
  objects = objects && pinned("objects", "objaverse");
  const fs::path assets = fs::absolute(impl.settings.assets_dir).lexically_normal();
  std::set<std::pair<std::string, std::string>> assets_seen;  // (source, uid)
  std::vector<SceneObjectRef> refs;
  for (const std::string& file : request.files) {
    const fs::path xml = assets / "scenes" / request.source / file;
    for (SceneObjectRef& r : FindSceneObjectRefs(xml, assets)) {
      if (exclude_thor && r.source == "thor") continue;
      if (!objects) {
        refs.push_back(std::move(r));
        continue;
      }
      const InstalledSource* src = impl.TrySetup("objects", r.source);
      if (src == nullptr) {
        throw Error("references objects/" + r.source + ", which is not pinned or not served",
                    xml.string(), r.path);
      }
      if (src->molmo == nullptr) {
        impl.Note(xml.string() + ": objects/" + r.source +
                  " is an mlspaces package: install its UIDs by name");
        continue;
      }
      const auto a = src->molmo->tries.ArchiveOf(r.path);
      if (!a) {
        throw Error(
            "No archive contains '" + r.path + "' (data_type=objects, source=" + r.source + ")",
            xml.string(), r.path);
      }
      // The object's UID: the first folder of its path.
      const std::string uid = fs::path(r.path).begin()->string();
      if (r.source != "thor" && !impl.Allowed(uid, plan)) continue;
      assets_seen.emplace(r.source, uid);
      impl.AddMolmoArchive(plan, seen, *src, src->molmo->tries.archives[*a]);
      refs.push_back(std::move(r));
    }
  }
  // install_grasps_for_scene: THOR's grasp sources (droid, rum) when THOR is excluded, and
  // grasp sources that are not configured, give nothing.
  for (const std::string& gs : grasp_sources) {
    if (exclude_thor && (gs == "droid" || gs == "rum")) continue;
    if (!pinned("grasps", gs)) continue;
    recording["grasps"][gs];
    for (const SceneObjectRef& r : refs) {
      impl.AddGraspArchives(plan, seen, gs, fs::path(r.path).filename().string());
    }
  }
  recording.Finish();
  plan.assets = assets_seen.size();
  SortPlan(plan);
  impl.NoteListing();
  return plan;
}

SceneRequest Installer::RequestForSceneFile(const fs::path& xml) const {
  const fs::path scenes = fs::absolute(impl_->settings.assets_dir / "scenes").lexically_normal();
  const fs::path rel = fs::absolute(xml).lexically_normal().lexically_relative(scenes);
  if (rel.empty() || *rel.begin() == ".." || std::distance(rel.begin(), rel.end()) < 2) {
    throw Error("not a scene file under " + scenes.string() + "/<source>/", xml.string());
  }
  SceneRequest request;
  request.source = rel.begin()->string();
  request.files = {fs::path(rel.string().substr(request.source.size() + 1)).generic_string()};
  return request;
}

}  // namespace mlspaces
