// Installing packages into the cache and linking them into the assets dir (spec 7.4, with
// checksums, resumable downloads and crash-safe extraction added).
//
// Cache layout per source version (shared with the original's resource manager):
//   <cache>/<type>/<name>/<version>/
//     mlspaces_package.json uid_index.mlsx metadata.mlsm   set-up files (manifest last)
//     .<archive>_complete_extract                           one flag per installed archive
//     <extracted files>                                     read-only
//     .mlspaces/lock                                        flock of installers
//     .mlspaces/downloads/<archive>[.part]                  downloads in flight
//     .mlspaces/staging/<archive stem>/                     extraction in flight
// A killed installer leaves at most a .part file (resumed next time) and a staging folder
// (deleted next time, under the lock); the flag is written only after every file of the
// archive has been renamed into place and flushed, so a flagged archive is complete.
#include "mlspaces/resources/installer.h"

#include "installer_impl.h"
#include "mlspaces/core/yaml_archive.h"

namespace mlspaces {
namespace fs = std::filesystem;

WhereFilter WhereFilter::Parse(const std::string& flag) {
  const size_t eq = flag.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw UsageError("--where expects KEY=VALUE (KEY a field or a JSON pointer), got '" + flag +
                     "'");
  }
  return WhereFilter{flag.substr(0, eq), flag.substr(eq + 1)};
}

Installer::Installer(ResourceSettings settings, InstallOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->settings = std::move(settings);
  impl_->options = std::move(options);
}
Installer::~Installer() = default;

const ResourceSettings& Installer::settings() const { return impl_->settings; }

const InstalledSource& Installer::Setup(const std::string& type, const std::string& name) {
  return impl_->Setup(type, name);
}

std::shared_ptr<const PackedLibrary> Installer::Library(const std::string& type,
                                                        const std::string& name) {
  return impl_->Library(type, name);
}

namespace {

bool MatchesWhere(const Annotation* annotation, const std::vector<WhereFilter>& where) {
  if (where.empty()) return true;
  if (annotation == nullptr) return false;
  for (const WhereFilter& f : where) {
    const Json* value = nullptr;
    if (!f.key.empty() && f.key[0] == '/') {
      const Json::json_pointer ptr(f.key);
      if (annotation->json.contains(ptr)) value = &annotation->json.at(ptr);
    } else if (auto it = annotation->json.find(f.key); it != annotation->json.end()) {
      value = &*it;
    }
    if (value == nullptr || !JsonValueMatches(*value, f.value)) return false;
  }
  return true;
}

void SortByArchive(InstallPlan& plan) {
  std::sort(plan.archives.begin(), plan.archives.end(), [](const auto& a, const auto& b) {
    return std::tie(a.source->type, a.source->name, a.archive) <
           std::tie(b.source->type, b.source->name, b.archive);
  });
}

}  // namespace

InstallPlan Installer::PlanUids(const std::vector<std::string>& uids) {
  Impl& impl = *impl_;
  InstallPlan plan;
  std::set<std::pair<const InstalledSource*, uint32_t>> seen;
  impl.SetupAll(plan, seen);
  if (impl.options.license_policy != LicensePolicy::kAll) impl.PrepareAnnotations(plan, seen);
  // The original's order: thor, then the other object sources alphabetically.
  std::vector<std::string> order;
  std::vector<std::pair<const InstalledSource*, std::shared_ptr<const PackedLibrary>>> libs;
  std::set<std::string> searched;
  auto open_libraries = [&] {
    order.clear();
    const SourceVersions& versions = impl.Versions();
    if (auto t = versions.find("objects"); t != versions.end()) {
      if (t->second.count("thor") != 0) order.push_back("thor");
      for (const auto& [name, version] : t->second) {
        if (name != "thor") order.push_back(name);
      }
    }
    std::string skipped;
    for (const std::string& name : order) {
      if (impl.Versions().at("objects").at(name).empty()) continue;  // unpinned
      if (!searched.insert(name).second) continue;                   // opened before
      const InstalledSource* src = impl.TrySetup("objects", name, /*note=*/false);
      if (src == nullptr) {
        skipped += (skipped.empty() ? "" : ", ") + name;
        continue;
      }
      auto lib = src->molmo != nullptr ? impl.MolmoLibrary(*src) : impl.Library("objects", name);
      if (lib != nullptr) libs.emplace_back(src, lib);  // objathor_metadata holds no MJCFs
    }
    if (!skipped.empty()) {
      impl.Note("not searched (neither an mlspaces package nor a MolmoSpaces-format source on " +
                impl.settings.remote_url + "): " + skipped);
    }
  };
  open_libraries();
  // A UID in none of the known sources: maybe in a source the remote's listing publishes.
  for (const std::string& uid : uids) {
    bool found = false;
    for (const auto& [src, lib] : libs) found = found || lib->Find(uid).has_value();
    if (!found && !impl.Libraries().Locate(uid)) {
      if (impl.FetchListing()) open_libraries();
      break;
    }
  }
  for (const std::string& uid : uids) {
    bool found = false;
    for (const auto& [src, lib] : libs) {
      if (auto asset = lib->Find(uid)) {
        found = true;
        if (src->name != "thor" && !impl.Allowed(uid, plan)) break;
        if (src->molmo != nullptr) {
          impl.PlanMolmoAsset(plan, seen, *src, *lib, *asset);
        } else {
          impl.AddArchive(plan, seen, *src, *lib, asset->archive);
        }
        ++plan.assets;
        break;
      }
    }
    if (found) continue;
    // install_uid: a UID of a user library needs nothing.
    if (auto where = impl.Libraries().Locate(uid)) {
      impl.Note(uid + " is in the user library " + where->library + ": nothing to install");
      ++plan.user_assets;
      continue;
    }
    std::string list;
    for (const std::string& name : order) list += (list.empty() ? "" : ", ") + name;
    std::string why;
    if (impl.listing == Impl::Listing::kUnreachable) {
      why = " (the remote's listing of published sources was unreachable: " + impl.listing_error +
            ")";
    }
    throw Error(uid + " not found in object sources [" + list + "]" + why, "", "", uid);
  }
  SortByArchive(plan);
  impl.NoteListing();
  return plan;
}

InstallPlan Installer::PlanLibrary(const std::string& name, const std::vector<WhereFilter>& where) {
  Impl& impl = *impl_;
  if (const size_t slash = name.find('/'); slash != std::string::npos) {
    if (!where.empty()) throw UsageError("--where applies to object libraries only");
    return PlanSource(name.substr(0, slash), name.substr(slash + 1));
  }
  InstallPlan plan;
  std::set<std::pair<const InstalledSource*, uint32_t>> seen;
  impl.SetupAll(plan, seen);
  if (!where.empty() || impl.options.license_policy != LicensePolicy::kAll) {
    impl.PrepareAnnotations(plan, seen);
  }
  auto lib = impl.Library("objects", name);
  const InstalledSource& src = impl.sources.at({"objects", name});
  for (size_t i = 0; i < lib->size(); ++i) {
    const PackedAsset asset = lib->At(i);
    const std::string uid(asset.uid);
    if (!where.empty() && !impl.annotations_unknown) {
      // A package's own annotation; a MolmoSpaces-format source's through the Registry
      // (objathor first, as GetAnnotation answers).
      if (src.molmo != nullptr) {
        if (!MatchesWhere(impl.Annotations().GetAnnotation(uid).get(), where)) continue;
      } else if (!MatchesWhere(lib->LoadAnnotation(asset).get(), where)) {
        continue;
      }
    }
    if (name != "thor" && !impl.Allowed(uid, plan)) continue;
    if (src.molmo != nullptr) {
      impl.PlanMolmoAsset(plan, seen, src, *lib, asset);
    } else {
      impl.AddArchive(plan, seen, src, *lib, asset.archive);
    }
    ++plan.assets;
  }
  SortByArchive(plan);
  impl.NoteListing();
  return plan;
}

void Installer::Install(const InstallPlan& plan) { impl_->Install(plan); }

std::vector<Installer::Problem> Installer::Verify(const std::vector<std::string>& names,
                                                  bool repair, size_t* files_checked) {
  Impl& impl = *impl_;
  std::vector<Problem> problems;
  size_t checked = 0;
  std::error_code ec;
  // The data types installed here (never the remote: verify works offline).
  std::set<std::string> types;
  for (const auto& [type, srcs] : BuiltinSourceVersions()) types.insert(type);
  for (const auto& [type, srcs] : impl.settings.versions) types.insert(type);
  const Json installed = ReadVersionsManifest(impl.settings.assets_dir / kVersionsManifestFile);
  for (auto it = installed.begin(); it != installed.end(); ++it) types.insert(it.key());
  if (!names.empty()) {
    // A name that is no installed source is a typo, not a source with nothing to check.
    std::set<std::string> known;
    for (const std::string& type : types) {
      for (const auto& entry : fs::directory_iterator(impl.settings.assets_dir / type, ec)) {
        if (entry.is_symlink()) known.insert(entry.path().filename().string());
      }
      ec.clear();
    }
    for (auto t = installed.begin(); t != installed.end(); ++t) {
      if (!t->is_object()) continue;
      for (auto src = t->begin(); src != t->end(); ++src) known.insert(src.key());
    }
    for (const std::string& name : names) {
      if (known.count(name) != 0) continue;
      const std::vector<std::string> list(known.begin(), known.end());
      const std::string hint = DidYouMean(name, list);
      throw Error("no installed source named '" + name + "' (" + (hint.empty() ? "" : hint + " ") +
                      "installed: " + (list.empty() ? "none" : JoinNames(list)) + ")",
                  impl.settings.assets_dir.string());
    }
  }
  for (const std::string& type : types) {
    const fs::path type_dir = impl.settings.assets_dir / type;
    if (!fs::is_directory(type_dir, ec)) continue;
    std::vector<fs::path> links;
    for (const auto& entry : fs::directory_iterator(type_dir, ec)) {
      if (!entry.is_symlink()) continue;
      const std::string name = entry.path().filename().string();
      if (!names.empty() && std::find(names.begin(), names.end(), name) == names.end()) continue;
      links.push_back(entry.path());
    }
    std::sort(links.begin(), links.end());
    for (const fs::path& link : links) {
      const fs::path dir = fs::read_symlink(link, ec);
      const fs::path manifest_path = dir / std::string(kPackageManifestFile);
      if (!IsFile(manifest_path)) continue;  // not an mlspaces package
      PackageManifest m;
      try {
        m = PackageManifest::Load(manifest_path);
      } catch (const Error& e) {
        problems.push_back({manifest_path.string(), "", e.message()});
        continue;
      }
      auto check = [&](const fs::path& file, uint64_t size, const std::string& sha) {
        ++checked;
        if (!IsFile(file)) {
          problems.push_back({file.string(), "", "missing"});
          return false;
        }
        const FileDigest d = Sha256File(file);
        if (d.size != size) {
          problems.push_back(
              {file.string(), "",
               "size " + std::to_string(d.size) + ", expected " + std::to_string(size)});
          return false;
        }
        if (d.sha256 != sha) {
          problems.push_back({file.string(), "", "SHA-256 " + d.sha256 + ", expected " + sha});
          return false;
        }
        return true;
      };
      for (const auto& [file, info] : m.files) check(dir / file, info.size, info.sha256);
      for (const PackageArchive& a : m.archives) {
        const fs::path flag = dir / ExtractFlagName(a.name);
        if (!IsFile(flag)) continue;
        bool good = true;
        const fs::path listing_path = dir / a.members_file;
        ++checked;
        std::string listing_text;
        if (!IsFile(listing_path)) {
          problems.push_back({listing_path.string(), "", "missing"});
          good = false;
        } else if (listing_text = ReadFile(listing_path);
                   Sha256Hex(listing_text) != a.members_sha256) {
          problems.push_back(
              {listing_path.string(), "", "SHA-256 differs from the manifest's members_sha256"});
          good = false;
        } else {
          const FlatJson listing = ParseFlatJson(listing_text, listing_path.string());
          for (const auto& [rel, info] : listing.items()) {
            if (!info.is_object() || !info.contains("size") || !info.contains("sha256")) {
              problems.push_back({listing_path.string(), "", "bad entry for " + rel});
              good = false;
              continue;
            }
            good &=
                check(dir / rel, info["size"].get<uint64_t>(), info["sha256"].get<std::string>());
          }
        }
        if (!good && repair) {
          fs::remove(flag, ec);
          problems.back().message += " (archive " + a.name + " will be installed again)";
        }
      }
    }
  }
  // MolmoSpaces-format sources: against the member listings recorded when installed.
  for (Diagnostic& p : impl.Molmo().Verify(names, repair, &checked)) problems.push_back(p);
  if (files_checked != nullptr) *files_checked = checked;
  return problems;
}

}  // namespace mlspaces
