#include "mlspaces/sim/compute_metadata.h"

#include <algorithm>
#include <mutex>
#include <optional>
#include <set>
#include <system_error>

#include <pugixml.hpp>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {

namespace fs = std::filesystem;

namespace {

constexpr int kMaxIncludeDepth = 32;

/// Adds the <include> and <model> files of `file` (and theirs) to `out`: an include resolves
/// against the including model's folder `model_dir`, as MuJoCo reads it; a <model> file's own
/// references against its folder. Unreadable files are left out (the compile reported them).
void AddReferencedModels(const fs::path& file, const fs::path& model_dir, int depth,
                         std::set<fs::path>* out) {
  if (depth > kMaxIncludeDepth) return;
  pugi::xml_document doc;
  if (!doc.load_file(file.c_str())) return;
  std::vector<std::pair<fs::path, bool>> found;  // file, is a <model>
  auto walk = [&](auto&& self, pugi::xml_node node) -> void {
    for (pugi::xml_node e = node.first_child(); e; e = e.next_sibling()) {
      if (e.type() != pugi::node_element) continue;
      const std::string_view tag = e.name();
      const std::string f = e.attribute("file").value();
      if ((tag == "include" || tag == "model") && !f.empty()) {
        found.emplace_back((model_dir / f).lexically_normal(), tag == "model");
      }
      self(self, e);
    }
  };
  walk(walk, doc);
  for (const auto& [path, is_model] : found) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec) || !out->insert(path).second) continue;
    AddReferencedModels(path, is_model ? path.parent_path() : model_dir, depth + 1, out);
  }
}

std::string SpecString(const mjString* s) {
  const char* c = s ? mjs_getString(s) : nullptr;
  return c ? c : "";
}

AssetFailure FailureOf(const Error& e, const fs::path& fallback, const std::string& uid) {
  return AssetFailure(e.path().empty() ? fallback.string() : e.path(), e.field(), e.message(), uid);
}

/// One asset of ComputeAssetMetadata.
struct Work {
  std::string uid;
  fs::path xml, json, computed;
};

enum class Outcome { kComputed, kReused, kFailed };

struct Result {
  Outcome outcome = Outcome::kFailed;
  AssetFailure failure;
  bool removed = false;  // the asset's computed file (ours) was deleted
};

/// Decides, computes and writes one asset's computed file (see ComputeAssetMetadata).
Result ProcessAsset(const Work& w, bool overwrite) {
  Result r;
  std::error_code ec;
  bool ours = false;     // the existing computed file carries our record
  bool foreign = false;  // it exists without a record and is kept (no overwrite)
  if (fs::exists(w.computed, ec)) {
    try {
      Json old = ParseJsonFile(w.computed);
      std::optional<std::vector<Diagnostic>> check = CheckComputedFrom(w.computed, old);
      ours = check.has_value();
      if (!overwrite && !ours) foreign = true;
      if (!overwrite && ours && check->empty()) {
        r.outcome = Outcome::kReused;
        return r;
      }
    } catch (const Error& e) {
      if (!overwrite) {
        r.failure = FailureOf(e, w.computed, w.uid);
        r.failure.message += " (cannot reuse it: fix or delete it, or use --overwrite)";
        return r;
      }
    }
  }
  try {
    ComposeOptions physics;
    physics.physics_only = true;
    if (foreign) {
      // Not ours: kept as the user's, but only for an asset that still compiles.
      ComputeAssetFacts(MjcfComposer(w.xml, physics).Compile().get(), w.xml);
      r.outcome = Outcome::kReused;
      return r;
    }
    Json source = ParseJsonFile(w.json);
    if (!source.is_object()) {
      throw Error("expected object, got " + JsonTypeWord(source), w.json.string(), "/", w.uid);
    }
    MjcfComposer composer(w.xml, physics);
    const AssetFacts facts = ComputeAssetFacts(composer.Compile().get(), w.xml);
    std::vector<fs::path> sources = AssetSourceFiles(composer);
    sources.push_back(w.json);
    Json out = MakeComputedMetadata(source, facts);
    out[std::string(kComputedFromKey)] = ComputedFromRecord(w.computed, sources);
    // No fsync per ~300-byte file (4-8 ms each on this machine's disk, several times the
    // compile): the file system is synced once, before the index is written.
    WriteFileAtomic(w.computed, DumpJsonIndent4(out), /*sync=*/false);
    r.outcome = Outcome::kComputed;
    return r;
  } catch (const Error& e) {
    r.failure = FailureOf(e, w.xml, w.uid);
  } catch (const std::exception& e) {
    r.failure = AssetFailure(w.xml.string(), "", e.what(), w.uid);
  }
  // A computed file of ours no longer describes a compilable asset: it goes, so nothing can
  // take it for the asset's metadata. Anyone else's file stays (the index leaves it out).
  if (ours) r.removed = fs::remove(w.computed, ec);
  return r;
}

}  // namespace

Json MakeComputedMetadata(const Json& source, const AssetFacts& facts) {
  Json out = source;
  if (!out.contains("mass")) out["mass"] = facts.mass;
  if (!out.contains("boundingBox")) {
    out["boundingBox"] = {
        {"x", facts.bounding_box[0]}, {"y", facts.bounding_box[1]}, {"z", facts.bounding_box[2]}};
  }
  out["aabb"] = {{"min", {facts.aabb_min[0], facts.aabb_min[1], facts.aabb_min[2]}},
                 {"max", {facts.aabb_max[0], facts.aabb_max[1], facts.aabb_max[2]}}};
  return out;
}

std::vector<fs::path> AssetSourceFiles(MjcfComposer& composer) {
  const fs::path xml = fs::absolute(composer.path()).lexically_normal();
  const fs::path dir = xml.parent_path();
  std::set<fs::path> files{xml};
  AddReferencedModels(xml, dir, 0, &files);
  mjSpec* spec = composer.spec();
  const std::string meshdir = SpecString(spec->compiler.meshdir);
  const fs::path mesh_base = meshdir.empty() ? dir : (dir / meshdir).lexically_normal();
  auto add = [&](const std::string& f) {
    if (f.empty()) return;
    // The composer made the paths of a model without <model> assets absolute; others are
    // resolved as MuJoCo resolves the model's own (a <model>'s meshes are not recorded).
    const fs::path p = fs::path(f).is_absolute() ? fs::path(f) : mesh_base / f;
    std::error_code ec;
    if (fs::is_regular_file(p, ec)) files.insert(p.lexically_normal());
  };
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_MESH); e; e = mjs_nextElement(spec, e)) {
    add(SpecString(mjs_asMesh(e)->file));
  }
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_HFIELD); e; e = mjs_nextElement(spec, e)) {
    add(SpecString(mjs_asHField(e)->file));
  }
  return {files.begin(), files.end()};
}

ComputeMetadataReport ComputeAssetMetadata(const fs::path& dir, const AssetIndexOptions& options,
                                           const ComputeMetadataOptions& compute) {
  InstallMujocoHandlers();
  const fs::path root = fs::absolute(dir).lexically_normal();
  ComputeMetadataReport report;
  const fs::path output = AssetIndexOutputPath(root, options);
  IndexReport scan;
  AssetIndex index = BuildAssetIndex(root, options, &scan, /*use_computed=*/false);

  std::vector<Work> work;
  for (const auto& [uid, e] : index.entries) {
    Work w{uid, root / e.object_path, root / e.metadata_path, {}};
    w.computed = w.xml.parent_path() / (uid + "_computed.json");
    work.push_back(std::move(w));
  }

  std::vector<Result> results(work.size());
  std::mutex mu;
  size_t done = 0;
  ParallelFor(work.size(), compute.threads, [&](size_t i) {
    results[i] = ProcessAsset(work[i], options.overwrite);
    std::lock_guard<std::mutex> lock(mu);
    ++done;
    if (compute.progress) compute.progress(done, work.size());
  });

  for (size_t i = 0; i < work.size(); ++i) {
    Result& r = results[i];
    AssetEntry& entry = index.entries.at(work[i].uid);
    switch (r.outcome) {
      case Outcome::kComputed:
        ++report.computed;
        break;
      case Outcome::kReused:
        ++report.reused;
        break;
      case Outcome::kFailed:
        report.failures.push_back(std::move(r.failure));
        if (r.removed) report.removed.push_back(work[i].computed);
        index.entries.erase(work[i].uid);  // work is in UID order: failures come sorted
        continue;
    }
    // object_path is ".../<uid>.xml": the computed file sits beside it.
    entry.metadata_path =
        entry.object_path.substr(0, entry.object_path.size() - 4) + "_computed.json";
  }

  if (report.computed > 0 || !report.removed.empty()) SyncFileSystem(root);

  report.index.output = output;
  report.index.warnings = scan.warnings;
  report.index.count = index.entries.size();
  WriteFileAtomic(output, index.Serialize());
  return report;
}

std::vector<Diagnostic> CompileLibraryAssets(const fs::path& dir,
                                             const ComputeMetadataOptions& compute) {
  InstallMujocoHandlers();
  AssetIndex index;
  try {
    index = AssetIndex::Load(dir / "assets_index.json");
  } catch (const Error&) {
    return {};
  }
  std::vector<std::pair<std::string, fs::path>> assets;  // uid, MJCF; in UID order
  for (const auto& [uid, e] : index.entries) {
    std::error_code ec;
    const fs::path rel(e.object_path);
    if (e.object_path.empty() || rel.is_absolute()) continue;
    if (fs::is_regular_file(dir / rel, ec)) assets.emplace_back(uid, dir / rel);
  }
  std::vector<std::optional<Diagnostic>> problems(assets.size());
  std::mutex mu;
  size_t done = 0;
  ParallelFor(assets.size(), compute.threads, [&](size_t i) {
    const auto& [uid, xml] = assets[i];
    try {
      MjcfComposer(xml).Compile();
    } catch (const Error& e) {
      problems[i] = FailureOf(e, xml, uid);
    } catch (const std::exception& e) {
      problems[i] = Diagnostic(xml.string(), "", e.what(), uid);
    }
    if (problems[i]) {
      problems[i]->message = "asset '" + uid + "' does not compile: " + problems[i]->message;
    }
    std::lock_guard<std::mutex> lock(mu);
    ++done;
    if (compute.progress) compute.progress(done, assets.size());
  });
  std::vector<Diagnostic> out;
  for (auto& p : problems) {
    if (p) out.push_back(std::move(*p));
  }
  return out;
}

}  // namespace mlspaces::sim
