// `mlspaces pack`: user library -> package folder (archives, stores, manifests).
//
// An asset's files are the folder of its MJCF with everything under it (the tutorial layout,
// <uid>/<uid>.xml); folders nested in another asset's folder go with that one, and assets
// sharing a folder go together. An asset whose MJCF sits at the library root brings only its
// own files (MJCF, metadata JSON, computed JSON, NPZ). Grasp NPZs named by grasps_index.json
// are not archived: their poses go to the archive's grasp shard, which the lookups read.
#include "mlspaces/resources/pack.h"

#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>
#include <optional>
#include <set>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/core/version.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/library/grasp_index.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/archive.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/packed_store_writer.h"
#include "mlspaces/resources/sha256.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

struct Unit {
  std::string dir;                ///< relative folder ("" = root-level asset)
  std::vector<std::string> uids;  ///< sorted
};

struct ArchivePlan {
  std::string name, stem;
  std::vector<const Unit*> units;
  std::vector<std::string> uids;  ///< sorted
};

struct GraspFile {
  std::string robot, joint;  ///< joint empty = pickup
  fs::path path;
};

struct ArchiveResult {
  PackageArchive archive;
  std::vector<std::string> members;  ///< archive paths, sorted (for the original's tries)
  std::vector<PackedAssetInput> assets;
  std::vector<std::unique_ptr<Annotation>> annotations;
  size_t grasp_sets = 0, grasps = 0;
  std::vector<Diagnostic> warnings;
};

std::string TodayUtc() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y%m%d", &tm);
  return buf;
}

void CheckName(const std::string& value, const char* what) {
  if (value.empty() || value[0] == '.' || value.find_first_of("/\\ \t\n") != std::string::npos) {
    throw UsageError(std::string(what) + " '" + value +
                     "' must be non-empty, not start with '.', and have no '/' or spaces");
  }
}

bool StartsWithDir(const std::string& path, const std::string& dir) {
  return dir.empty() || (path.size() > dir.size() && path.compare(0, dir.size(), dir) == 0 &&
                         path[dir.size()] == '/');
}

std::string ParentOf(const std::string& rel) {
  const size_t slash = rel.rfind('/');
  return slash == std::string::npos ? std::string() : rel.substr(0, slash);
}

/// gzip with a zero mtime, so the same JSON gives the same bytes.
std::string Gzip(const std::string& data) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw Error("zlib: deflateInit2 failed");
  }
  std::string out(deflateBound(&zs, data.size()) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw Error("zlib: deflate failed");
  return out;
}

/// The files of a unit, sorted, relative to the library root.
std::vector<std::string> UnitFiles(const fs::path& root, const Unit& unit, const AssetIndex& index,
                                   const std::set<std::string>& skip,
                                   std::vector<Diagnostic>& warnings) {
  std::vector<std::string> files;
  if (unit.dir.empty()) {
    for (const std::string& uid : unit.uids) {
      const AssetEntry& e = index.entries.at(uid);
      files.push_back(e.object_path);
      files.push_back(e.metadata_path);
      if (e.metadata_npz_path) files.push_back(*e.metadata_npz_path);
      const std::string plain = ParentOf(e.object_path).empty()
                                    ? uid + ".json"
                                    : ParentOf(e.object_path) + "/" + uid + ".json";
      if (IsFile(root / plain)) files.push_back(plain);
    }
  } else {
    std::error_code ec;
    fs::recursive_directory_iterator it(root / unit.dir, ec);
    if (ec) throw Error("cannot list: " + ec.message(), (root / unit.dir).string());
    for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (ec) throw Error("cannot list: " + ec.message(), (root / unit.dir).string());
      const fs::path& p = it->path();
      const std::string rel = RelativeGenericPath(p, root);
      if (it->is_symlink()) {
        warnings.emplace_back(p.string(), "", "symbolic link not packed", "", Severity::kWarning);
        if (it->is_directory()) it.disable_recursion_pending();
        continue;
      }
      if (it->is_directory()) continue;  // nested asset folders were merged into this unit
      if (!it->is_regular_file()) continue;
      const std::string fname = p.filename().string();
      if (fname.find(".tmp.") != std::string::npos) continue;
      if (fname == "assets_index.json" || fname == "grasps_index.json") continue;
      if (skip.count(rel) != 0) continue;
      files.push_back(rel);
    }
  }
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  for (const std::string& f : files) {
    if (!IsFile(root / f))
      throw Error("file named by the asset index is missing", (root / f).string());
  }
  return files;
}

}  // namespace

PackReport PackLibrary(const fs::path& library_dir, const fs::path& out_dir, PackOptions options) {
  const fs::path root = fs::absolute(library_dir).lexically_normal().parent_path() /
                        fs::absolute(library_dir).lexically_normal().filename();
  const fs::path index_file = root / "assets_index.json";
  if (!IsFile(index_file)) {
    throw Error(
        "no assets_index.json here: run `mlspaces index-assets " + library_dir.string() + "` first",
        root.string());
  }
  if (options.name.empty()) options.name = root.filename().string();
  if (options.version.empty()) options.version = TodayUtc();
  CheckName(options.name, "library name");
  CheckName(options.version, "version");
  CheckName(options.data_type, "data type");
  if (options.assets_per_archive < 1) throw UsageError("--assets-per-archive must be >= 1");
  if (options.zstd_level < 1 || options.zstd_level > 19) {
    throw UsageError("--zstd-level must be between 1 and 19");
  }
  const AssetIndex index = AssetIndex::Load(index_file);
  if (index.entries.empty()) throw Error("the asset index lists no assets", index_file.string());

  // Grasps: uid -> files, from the grasp library's index.
  fs::path grasp_root = options.grasp_dir;
  if (grasp_root.empty() && IsFile(root / "grasps_index.json")) grasp_root = root;
  PackReport report;
  std::map<std::string, std::vector<GraspFile>> grasps_of;
  std::set<std::string> grasp_members;  // library-relative paths not to archive
  if (!grasp_root.empty()) {
    grasp_root = fs::absolute(grasp_root).lexically_normal();
    const GraspIndex gindex = GraspIndex::Load(grasp_root / "grasps_index.json");
    auto add = [&](const std::string& uid, GraspFile file) {
      if (index.entries.count(uid) == 0) {
        report.warnings.emplace_back(
            file.path.string(), "",
            "grasps for UID " + uid + ", which is not in the asset index, not packed", uid,
            Severity::kWarning);
        return;
      }
      const std::string rel = RelativeGenericPath(file.path, root);
      if (rel.rfind("../", 0) != 0) grasp_members.insert(rel);
      grasps_of[uid].push_back(std::move(file));
    };
    for (const auto& [robot, uids] : gindex.grasp_paths) {
      for (const auto& [uid, rel] : uids) add(uid, {robot, "", grasp_root / rel});
    }
    for (const auto& [robot, uids] : gindex.articulated_grasp_paths) {
      for (const auto& [uid, joints] : uids) {
        for (const auto& [joint, rel] : joints) add(uid, {robot, joint, grasp_root / rel});
      }
    }
    for (auto& [uid, files] : grasps_of) {
      std::sort(files.begin(), files.end(), [](const GraspFile& a, const GraspFile& b) {
        return std::tie(a.robot, a.joint) < std::tie(b.robot, b.joint);
      });
    }
  }

  // Units: MJCF folders, nested ones merged into their outermost ancestor.
  std::map<std::string, std::vector<std::string>> by_dir;
  for (const auto& [uid, entry] : index.entries) by_dir[ParentOf(entry.object_path)].push_back(uid);
  std::vector<Unit> units;
  {
    std::vector<std::string> outer;  // sorted: an ancestor sorts before its descendants
    for (auto& [dir, uids] : by_dir) {
      if (dir.empty()) {
        for (const std::string& uid : uids) units.push_back({"", {uid}});
        continue;
      }
      if (!outer.empty() && StartsWithDir(dir, outer.back())) {
        auto& target = units.back();
        target.uids.insert(target.uids.end(), uids.begin(), uids.end());
        continue;
      }
      outer.push_back(dir);
      units.push_back({dir, uids});
    }
    for (Unit& u : units) std::sort(u.uids.begin(), u.uids.end());
    std::sort(units.begin(), units.end(),
              [](const Unit& a, const Unit& b) { return a.uids.front() < b.uids.front(); });
  }

  // Archives: units in order of their first UID, cut once they hold >= K assets.
  std::vector<ArchivePlan> plans;
  for (const Unit& u : units) {
    if (plans.empty() || plans.back().uids.size() >= options.assets_per_archive) {
      plans.emplace_back();
      char num[32];
      std::snprintf(num, sizeof num, "%05zu", plans.size() - 1);
      plans.back().stem = options.name + "_" + num;
      plans.back().name = plans.back().stem + ".tar.zst";
    }
    plans.back().units.push_back(&u);
    plans.back().uids.insert(plans.back().uids.end(), u.uids.begin(), u.uids.end());
  }
  for (ArchivePlan& p : plans) std::sort(p.uids.begin(), p.uids.end());

  // Output folder: built under a temp name, renamed into place at the end.
  const fs::path parent = fs::absolute(out_dir) / options.data_type / options.name;
  const fs::path final_dir = parent / options.version;
  std::error_code ec;
  if (fs::exists(final_dir, ec) && !options.overwrite) {
    throw Error(final_dir.string() + " already exists. Use --overwrite to overwrite.",
                final_dir.string());
  }
  CreateDirectories(parent);
  RemoveDeadTempFiles(parent);  // <version>.tmp.<pid>.<n> folders of packs that died
  const fs::path tmp_dir = parent / (options.version + TempSuffix());
  fs::create_directories(tmp_dir / ".staging", ec);
  if (ec) throw Error("cannot create folder: " + ec.message(), tmp_dir.string());
  struct CleanUp {
    fs::path dir;
    ~CleanUp() {
      std::error_code e;
      if (!dir.empty()) fs::remove_all(dir, e);
    }
  } cleanup{tmp_dir};

  std::vector<std::string> archive_names;
  archive_names.reserve(plans.size());
  for (const ArchivePlan& p : plans) archive_names.push_back(p.name);
  PackedStoreWriter store(tmp_dir, options.name, archive_names);

  // Workers build archives; the main thread adds them to the store in archive order (so the
  // output does not depend on scheduling), and workers stay at most a window ahead.
  const size_t n = plans.size();
  const size_t window = static_cast<size_t>(ParallelThreads(options.threads, n)) * 4;

  auto build = [&](size_t i) {
    const ArchivePlan& plan = plans[i];
    ArchiveResult r;
    const fs::path staging = tmp_dir / ".staging" / plan.stem;
    CreateDirectories(staging);
    // Grasp shard.
    const std::string shard_rel = GraspShardMember(plan.name);
    const fs::path shard_path = staging / "shard.mlsg";
    GraspShardWriter shard(shard_path);
    for (const std::string& uid : plan.uids) {
      const AssetEntry& e = index.entries.at(uid);
      PackedAssetInput in;
      in.uid = uid;
      in.mjcf = e.object_path;
      in.archive = static_cast<uint32_t>(i);
      std::optional<fs::path> npz;
      if (e.metadata_npz_path) npz = root / *e.metadata_npz_path;
      auto annotation = std::make_unique<Annotation>(
          LoadAnnotation(uid, options.name, root / e.metadata_path, npz ? &*npz : nullptr));
      in.annotation = annotation.get();
      r.annotations.push_back(std::move(annotation));
      if (auto g = grasps_of.find(uid); g != grasps_of.end()) {
        for (const GraspFile& f : g->second) {
          const GraspSet set = ReadGraspFile(f.path);
          PackedAssetInput::Grasps ref;
          ref.robot = f.robot;
          ref.joint = f.joint;
          ref.archive = static_cast<uint32_t>(i);
          ref.offset = shard.Append(set.poses);
          ref.count = static_cast<uint32_t>(set.poses.size());
          ref.stored_dtype = set.stored_dtype;
          in.grasps.push_back(std::move(ref));
          ++r.grasp_sets;
          r.grasps += set.poses.size();
        }
      }
      r.assets.push_back(std::move(in));
    }
    shard.Finish(/*sync=*/false);  // staging; the package gets one syncfs at the end

    // Members: the units' files, the shard, then the listing of all of them.
    std::vector<ArchiveMember> members;
    for (const Unit* u : plan.units) {
      for (std::string& rel : UnitFiles(root, *u, index, grasp_members, r.warnings)) {
        members.push_back({rel, root / rel});
      }
    }
    members.push_back({shard_rel, shard_path});
    std::sort(members.begin(), members.end(),
              [](const ArchiveMember& a, const ArchiveMember& b) { return a.path < b.path; });
    FlatJson listing = FlatJson::object();
    uint64_t unpacked = 0;
    for (const ArchiveMember& m : members) {
      const FileDigest d = Sha256File(m.source);
      listing[m.path] = {{"size", d.size}, {"sha256", d.sha256}};
      unpacked += d.size;
    }
    const std::string listing_text = listing.dump(1) + "\n";
    const std::string listing_rel = std::string(kMemberListDir) + "/" + plan.stem + ".json";
    const fs::path listing_path = staging / "members.json";
    WriteFileAtomic(listing_path, listing_text, false);
    members.push_back({listing_rel, listing_path});
    unpacked += listing_text.size();
    for (const ArchiveMember& m : members) r.members.push_back(m.path);

    const fs::path archive_path = tmp_dir / plan.name;
    WriteTarZst(archive_path, members, ArchiveWriteOptions{options.zstd_level, /*sync=*/false});
    const FileDigest digest = Sha256File(archive_path);
    r.archive.name = plan.name;
    r.archive.size = digest.size;
    r.archive.sha256 = digest.sha256;
    r.archive.unpacked_bytes = unpacked;
    r.archive.assets = static_cast<uint32_t>(plan.uids.size());
    r.archive.members_file = listing_rel;
    r.archive.members_sha256 = Sha256Hex(listing_text);
    RemoveAll(staging);
    return r;
  };

  PackageManifest manifest;
  manifest.data_type = options.data_type;
  manifest.name = options.name;
  manifest.version = options.version;
  manifest.created_by = std::string("mlspaces ") + std::string(Version());
  FlatJson sizes = FlatJson::object();
  // The original's tries: {archive: nested {component: ...}, leaves {}}.
  FlatJson tries = FlatJson::object();
  auto add_trie = [&](const std::string& archive, const std::vector<std::string>& paths) {
    FlatJson trie = FlatJson::object();
    for (const std::string& path : paths) {
      FlatJson* node = &trie;
      size_t start = 0;
      for (;;) {
        const size_t slash = path.find('/', start);
        node = &(*node)[path.substr(start, slash == std::string::npos ? slash : slash - start)];
        if (!node->is_object()) *node = FlatJson::object();
        if (slash == std::string::npos) break;
        start = slash + 1;
      }
    }
    tries[archive] = std::move(trie);
  };
  std::set<std::string> robots;
  ParallelForOrdered<ArchiveResult>(
      n, options.threads, window, build, [&](size_t i, ArchiveResult&& r) {
        for (const PackedAssetInput& a : r.assets) {
          store.Add(a);
          for (const auto& g : a.grasps) robots.insert(g.robot);
        }
        report.grasp_sets += r.grasp_sets;
        report.grasps += r.grasps;
        report.warnings.insert(report.warnings.end(), r.warnings.begin(), r.warnings.end());
        report.archive_bytes += r.archive.size;
        report.unpacked_bytes += r.archive.unpacked_bytes;
        sizes[r.archive.name] = static_cast<double>(r.archive.size) / (1024.0 * 1024.0);
        add_trie(r.archive.name, r.members);
        if (options.progress) options.progress(i + 1, n);
        manifest.archives.push_back(std::move(r.archive));
      });

  store.Finish();
  for (std::string_view file : {kUidIndexFile, kMetadataStoreFile}) {
    const FileDigest d = Sha256File(tmp_dir / std::string(file));
    manifest.files[std::string(file)] = PackageFile{d.size, d.sha256};
  }
  manifest.num_assets = index.entries.size();
  manifest.num_grasp_sets = report.grasp_sets;
  manifest.num_grasps = report.grasps;
  manifest.robots.assign(robots.begin(), robots.end());
  WriteFileAtomic(tmp_dir / std::string(kSizeManifestFile), sizes.dump(1) + "\n", false);
  WriteFileAtomic(tmp_dir / std::string(kTriesFile), Gzip(tries.dump()), false);
  WriteFileAtomic(tmp_dir / std::string(kPackageManifestFile), manifest.Serialize(), false);
  RemoveAll(tmp_dir / ".staging");
  SyncFileSystem(tmp_dir);  // one flush for every file above, before the rename publishes them

  if (fs::exists(final_dir, ec)) {
    const fs::path old = parent / (options.version + ".old" + TempSuffix());
    RenamePath(final_dir, old);
    RenamePath(tmp_dir, final_dir);
    fs::remove_all(old, ec);
  } else {
    RenamePath(tmp_dir, final_dir);
  }
  cleanup.dir.clear();
  FsyncPath(parent, true, parent.string());
  CrashPoint("package renamed into place");

  // <out>/mlspaces_sources.json: what this remote serves, merged with earlier packs.
  const fs::path listing = fs::absolute(out_dir) / "mlspaces_sources.json";
  Json sources = IsFile(listing) ? ParseJsonFile(listing) : Json::object();
  if (!sources.is_object()) sources = Json::object();
  sources[options.data_type][options.name] = options.version;
  WriteFileAtomic(listing, DumpJsonIndent4(sources) + "\n");

  report.package_dir = final_dir;
  report.name = options.name;
  report.version = options.version;
  report.assets = index.entries.size();
  report.archives = n;
  return report;
}

}  // namespace mlspaces
