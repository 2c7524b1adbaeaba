// Installing packaged libraries: set-up of a source (manifest and stores), install by UID or by
// library, verification. Downloads resume, every file is checked against the manifest's
// SHA-256, archives are extracted safely into a staging folder and renamed into place, and an
// extraction flag marks an archive done. Concurrent installers on one cache take a per-version
// flock, which the kernel releases when a holder dies. The steps and their guarantees:
// docs/resources.md ("Install").
//
// One Installer is used from one thread at a time. Lifetimes: references and pointers it
// returns (settings(), Setup's InstalledSource, InstallPlan::Item::source) stay valid until the
// Installer is destroyed; a plan must not outlive the Installer that made it. Shared pointers
// (Library) keep what they point to alive on their own.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces {

class Registry;
struct MolmoSource;

struct MLSPACES_API InstallOptions {
  /// Messages for the user (waiting for a lock, skipped sources). May be empty.
  std::function<void(const std::string&)> note;
  /// Byte progress over the whole install: (done, total).
  std::function<void(uint64_t, uint64_t)> progress;
  int parallel_downloads = 4;
  int retries = 3;
  /// Assets the licence policy leaves out are skipped with a note (their annotation is read
  /// through the Registry: objathor first, as GetAnnotation answers).
  LicensePolicy license_policy = LicensePolicy::kAll;
  /// The grasp source install_uid takes grasp archives from for a non-THOR object.
  std::string grasp_source = "droid_objaverse";
  /// Opens the Registry used for annotations (--where, the licence policy) and to recognise
  /// user-library UIDs; called at most once, after the built-in sources are set up. Empty:
  /// a Registry on the assets dir without user libraries.
  std::function<Registry()> open_registry;
  /// A plan only: nothing is installed while planning (objathor_metadata, which --where and
  /// the licence policy read, joins the plan instead when it is missing).
  bool dry_run = false;
};

// =============================================================================================
// Options, sources and plans

/// One source installed or looked at.
struct MLSPACES_API InstalledSource {
  std::string type, name, version;
  std::filesystem::path dir;  ///< the version dir in the cache
  PackageManifest manifest;   ///< empty for a MolmoSpaces-format source
  /// Set for a MolmoSpaces-format source (owned by the Installer), null for a package.
  const MolmoSource* molmo = nullptr;
};

/// What an install would fetch, and then did.
struct MLSPACES_API InstallPlan {
  struct Item {
    /// The source the archive belongs to (owned by the Installer that made the plan; never
    /// null in a plan it returned).
    const InstalledSource* source = nullptr;
    std::string archive;
    uint64_t size = 0, unpacked_bytes = 0;
    uint32_t index = 0;  ///< the archive's entry in the source's manifest and UID index
  };
  std::vector<Item> archives;    ///< not yet installed, sorted
  size_t assets = 0;             ///< assets selected
  size_t already_installed = 0;  ///< selected archives already there
  size_t left_out = 0;           ///< assets the licence policy left out (each with a note)
  size_t user_assets = 0;        ///< UIDs of user libraries (nothing to install)
  /// Bytes to download; for MolmoSpaces-format sources an estimate from the size manifest
  /// (MB), and unpacked_bytes is unknown (0) for them.
  uint64_t download_bytes = 0, unpacked_bytes = 0;
  /// type -> source -> the archives a scene plan asked for, installed already or not, sorted
  /// (PlanScene, PlanSceneContents: what the original's install_*_for_scene return). A
  /// grasp source that is asked for appears even when nothing matched.
  std::map<std::string, std::map<std::string, std::vector<std::string>>> requested;
};

/// A scene asked for by `install --scene`: its source and MJCF files (relative to the
/// source), installed first; PlanSceneContents then plans what they reference.
struct MLSPACES_API SceneRequest {
  std::string source;
  std::vector<std::string> files;
};

/// A `--where KEY=VALUE` filter on annotations: KEY is a top-level field or a JSON pointer;
/// matches when the value (or, for a list, any element) printed as text equals VALUE.
struct MLSPACES_API WhereFilter {
  std::string key, value;
  static WhereFilter Parse(const std::string& flag);  ///< @throws UsageError
};

class MLSPACES_API Installer {
 public:
  // ===========================================================================================
  // Construction

  explicit Installer(ResourceSettings settings, InstallOptions options = {});
  ~Installer();

  /// The settings given (valid for the Installer's life).
  const ResourceSettings& settings() const;

  // ===========================================================================================
  // Sources

  /// Makes sure a source's manifest and stores are in the cache (downloading them if needed)
  /// and that <assets>/<type>/<name> links to its version dir. Set up once per Installer: a
  /// second call returns the same object. @returns a reference valid for the Installer's
  /// life. @throws Error (unknown source, download or checksum failure, not an mlspaces
  /// package).
  const InstalledSource& Setup(const std::string& type, const std::string& name);
  /// The opened stores of a source, set up first if needed (opened once per Installer).
  /// @returns never null. @throws Error as Setup, or for a bad store.
  std::shared_ptr<const PackedLibrary> Library(const std::string& type, const std::string& name);

  // ===========================================================================================
  // Planning and installing

  /// Plans installing UIDs: each is looked up in the object sources in priority order (thor,
  /// then the others alphabetically; docs/resources.md), by our UID index of the source
  /// (packages, and MolmoSpaces-format sources indexed at set-up). For a MolmoSpaces-format
  /// source the UID's grasp archives come too (droid_objaverse archives matching the tokens
  /// of the MJCF stem; droid for thor), as install_uid does. Every pinned MolmoSpaces-format
  /// source is set up first, as the original's set-up does, and its EAGER archives (and the
  /// scene sources' base archives) join the plan. A UID of a user library needs nothing.
  /// @throws Error "<uid> not found in object sources [...]".
  InstallPlan PlanUids(const std::vector<std::string>& uids);
  /// Plans installing a whole library, or the assets whose annotation matches every filter.
  /// `name` may be "TYPE/NAME" for a source of another data type (robots/franka_droid):
  /// PlanSource, no filters.
  InstallPlan PlanLibrary(const std::string& name, const std::vector<WhereFilter>& where);
  /// Plans every archive of one source, `type` any data type (robots, benchmarks, scenes...).
  InstallPlan PlanSource(const std::string& type, const std::string& name);
  /// Plans a scene: `scene` is a path inside a scene source (relative to it, to
  /// <assets>/scenes, or absolute under <assets>/scenes/<source>), or a scene number found by
  /// the source's NumericIndex ("N" when one scene source is pinned, else "SOURCE:N"). Fills
  /// `request` with the scene's MJCFs. @throws Error "no scene ..." naming the key.
  InstallPlan PlanScene(const std::string& scene, SceneRequest* request);
  /// After the scene archive is installed: the object archives its MJCFs reference through
  /// ../objects/<source>/... file attributes (found by path in the tries), then the grasp
  /// archives of `grasp_sources` matching the tokens of each referenced file's name, as
  /// install_scene_with_objects_and_grasps_from_path does.
  /// `objects` false leaves the object archives out (install_grasps_for_scene); nothing
  /// of objects/ is planned unless objects/objaverse is pinned (install_objects_for_scene).
  /// THOR's references and its grasp sources (droid, rum) are skipped with `exclude_thor`.
  InstallPlan PlanSceneContents(const SceneRequest& request,
                                const std::vector<std::string>& grasp_sources = {"droid_objaverse"},
                                bool objects = true, bool exclude_thor = true);
  /// The request for one scene MJCF given by path under <assets>/scenes/<source>/ (absolute
  /// or relative to the cwd). @throws Error naming the path when it is not under it.
  SceneRequest RequestForSceneFile(const std::filesystem::path& xml) const;
  /// Downloads, verifies and extracts a plan's archives (with their grasp shards).
  void Install(const InstallPlan& plan);

  // ===========================================================================================
  // Verification

  /// A problem of an installed file: path = the file, message; field empty.
  using Problem = Diagnostic;
  /// Re-checks installed files of every set-up source in the assets dir (or only `names`)
  /// against the manifests. With `repair`, archives with bad files lose their extraction
  /// flag so the next install fetches them again. @returns the problems (empty = all good).
  std::vector<Problem> Verify(const std::vector<std::string>& names, bool repair,
                              size_t* files_checked = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces
