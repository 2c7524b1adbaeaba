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
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces {

struct MLSPACES_API InstallOptions {
  /// Messages for the user (waiting for a lock, skipped sources). May be empty.
  std::function<void(const std::string&)> note;
  /// Byte progress over the whole install: (done, total).
  std::function<void(uint64_t, uint64_t)> progress;
  int parallel_downloads = 4;
  int retries = 3;
};

// =============================================================================================
// Options, sources and plans

/// One source installed or looked at.
struct MLSPACES_API InstalledSource {
  std::string type, name, version;
  std::filesystem::path dir;  ///< the version dir in the cache
  PackageManifest manifest;
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
  uint64_t download_bytes = 0, unpacked_bytes = 0;
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
  /// then the others alphabetically; docs/resources.md); sources that are not mlspaces
  /// packages on the remote are skipped with a note.
  /// @throws Error "<uid> not found in object sources [...]".
  InstallPlan PlanUids(const std::vector<std::string>& uids);
  /// Plans installing a whole library, or the assets whose annotation matches every filter.
  InstallPlan PlanLibrary(const std::string& name, const std::vector<WhereFilter>& where);
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
