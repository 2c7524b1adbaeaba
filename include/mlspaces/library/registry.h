// The registry of asset and grasp libraries, and every lookup by UID.
//
// A Registry is a value, not a process global: build one, register libraries, look up.
// Indexes are parsed once at registration into hash maps; lookups never scan the disk.
// Const lookups may run concurrently from several threads (the annotation cache is locked);
// registration must not run concurrently with anything else.
//
// Lifetimes: pointers and views a Registry returns (AssetLocation::entry, FindGraspLibrary,
// duplicates(), GraspFileLocation::packed's names) stay valid until the Registry is
// destroyed or moved from; registering more libraries does not invalidate them. Shared
// pointers (annotations, packed libraries) keep what they point to alive on their own.
// How lookups compare with MolmoSpaces' (priorities, workarounds): docs/formats.md.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/library/annotation.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/library/grasp_set.h"
#include "mlspaces/library/packed_store.h"

namespace mlspaces {

/// Built-in asset library names (reserved: user libraries may not take them).
inline constexpr std::string_view kBuiltinAssetLibraries[] = {"objathor_metadata", "objaverse",
                                                              "thor"};
/// Built-in grasp library names, and the asset library each serves.
inline constexpr std::string_view kBuiltinGraspLibraries[] = {"droid", "droid_objaverse"};

/// Where a UID lives.
struct MLSPACES_API AssetLocation {
  std::string library;              ///< asset library name
  std::filesystem::path mjcf_path;  ///< absolute path of the asset MJCF
  /// The index entry of a user library (owned by the Registry); null for built-in and
  /// packed libraries.
  const AssetEntry* entry = nullptr;
  /// Packed libraries: the archive holding the asset; empty otherwise.
  std::string archive;
  /// False when the asset's package archive is not installed yet (the MJCF does not exist).
  bool installed = true;
  /// Other libraries that also hold this UID and are shadowed by `library` (never silent:
  /// the CLI prints them, and Registry::duplicates() lists every such UID).
  std::vector<std::string> shadowed;
};

/// A UID found in more than one asset library, in priority order (first one wins).
/// A built-in library's scan may also find one file stem twice: then `libraries` names that
/// library twice and `paths` holds both files (the lexicographically-first path wins).
struct MLSPACES_API DuplicateUid {
  std::string uid;
  std::vector<std::string> libraries;
  std::vector<std::filesystem::path> paths;  ///< the MJCF in each library, same order
};

/// A grasp file found by a lookup, and the grasp library that provided it.
struct MLSPACES_API GraspFileLocation {
  std::string library;
  std::filesystem::path path;  ///< the NPZ, or a packed library's grasp shard
  /// Packed libraries: where in the shard the poses are (its names view the library's
  /// mapped index, owned by the Registry); nullopt for an NPZ.
  std::optional<PackedGraspRef> packed;
};

/// A registered grasp library: one per (root, robot) for user libraries.
struct MLSPACES_API GraspLibraryInfo {
  std::string name;           ///< "<root>/<robot>" for user libraries, "droid" for built-ins
  std::string robot;          ///< the robot sub-folder name (empty for built-ins)
  std::filesystem::path dir;  ///< library root (absolute)
  std::string asset_library;  ///< the asset library it serves
  bool builtin = false;
};

/// Which grasp libraries a lookup may use, in priority order. Empty = all libraries
/// registered for the UID's asset library, newest registration first.
using GraspLibraryFilter = std::span<const std::string>;

/// One grasp lookup: pickup grasps of an asset, or the grasps of one of its joints.
/// A plain value (copyable, no views) so it can cross the Python binding as is.
struct MLSPACES_API GraspQuery {
  std::string uid;
  /// The joint name in the asset MJCF; empty for pickup grasps.
  std::string joint{};
  /// Grasp libraries the lookup may use, in priority order; empty = all that serve the UID
  /// (see GraspLibraryFilter). Names are "<root>/<robot>" for user libraries.
  std::vector<std::string> libraries{};
};

class MLSPACES_API Registry {
 public:
  // ===========================================================================================
  // Construction
  struct Options {
    /// The install dir of built-in data (MLSPACES_ASSETS_DIR). Built-in libraries answer
    /// lookups only when it is set: thor/objaverse MJCFs under <assets>/objects/<lib>/ and
    /// grasps under <assets>/grasps/<lib>/. Every <assets>/objects/<name> that is an
    /// installed mlspaces package (it has uid_index.mlsx) is opened as a packed library
    /// named <name> with grasp libraries <name>/<robot>: its lookups read the package's
    /// stores, never the disk tree.
    std::optional<std::filesystem::path> assets_dir;
  };

  Registry();
  explicit Registry(Options options);
  ~Registry();
  Registry(Registry&&) noexcept;
  Registry& operator=(Registry&&) noexcept;

  // ===========================================================================================
  // Registration (not concurrent with anything else)

  /// Registers a user asset library: the name must be non-empty, without '/', not taken and
  /// not built-in; `dir`/assets_index.json must exist and parse. The path is made absolute
  /// now. UIDs already present in another library are recorded in duplicates().
  /// Transactional: on error nothing changes. @throws Error / UsageError.
  void RegisterAssetLibrary(const std::string& name, const std::filesystem::path& dir);

  /// Registers a user grasp library: `dir`/grasps_index.json must exist and parse, the
  /// asset library must be registered (user or built-in), the root name must be non-empty
  /// and without '/'. Makes one library "<root>/<robot>" per robot, robots sorted, and puts
  /// them in front of the asset library's list (the first robot in sorted order ends up
  /// first). Transactional. @returns the names registered, in priority order.
  std::vector<std::string> RegisterGraspLibrary(const std::string& root_name,
                                                const std::filesystem::path& dir,
                                                const std::string& asset_library);

  /// Registers an installed package folder (uid_index.mlsx, metadata.mlsm) as a packed
  /// asset library `name`, ranked like a built-in (thor first, then alphabetically, all
  /// before user libraries), with one grasp library "<name>/<robot>" per robot.
  /// @throws Error for a bad store or a name already taken.
  void RegisterPackedLibrary(const std::string& name, const std::filesystem::path& dir);

  // ===========================================================================================
  // Libraries

  /// The packed library of that name (shared: it outlives the Registry if held), or nullptr.
  std::shared_ptr<const PackedLibrary> FindPackedLibrary(std::string_view name) const;
  /// Registered asset libraries: built-ins first (when an assets dir is set), then user
  /// libraries in registration order.
  std::vector<std::string> asset_libraries() const;
  /// Grasp libraries serving an asset library, highest priority first.
  std::vector<std::string> grasp_libraries_of(const std::string& asset_library) const;
  /// The grasp library of that name, or nullptr. Owned by the Registry.
  const GraspLibraryInfo* FindGraspLibrary(std::string_view name) const;
  /// Every UID held by more than one asset library, sorted by UID. Recomputed after a
  /// registration (built-in libraries are scanned then); the reference is valid until the
  /// next call after a registration.
  const std::vector<DuplicateUid>& duplicates() const;
  /// Number of UIDs across all user libraries (duplicates counted once).
  size_t num_uids() const;
  /// The UIDs of the user libraries: library by library in registration order, each sorted,
  /// a UID shadowed by an earlier library left out (what num_uids() counts).
  std::vector<std::string> user_uids() const;

  // ===========================================================================================
  // Assets

  /// Finds a UID: thor, then the other built-in and packed libraries alphabetically, then
  /// user libraries in registration order. nullopt if unknown.
  /// Packed libraries answer from their UID index (one hash probe). A built-in thor or
  /// objaverse that is not a package is scanned once (<assets>/objects/<lib>/**/*.xml, file
  /// stem = UID) on first use. objathor_metadata holds no MJCFs.
  std::optional<AssetLocation> Locate(std::string_view uid) const;
  /// As Locate. @throws Error "<uid> not found in asset libraries [...]" naming every library.
  AssetLocation LocateOrThrow(std::string_view uid) const;

  // ===========================================================================================
  // Annotations

  /// The annotation of a UID, cached after the first call (the shared object is immutable).
  /// nullptr for an unknown UID or one without metadata. @throws Error for a bad metadata
  /// file. The original's union order: the objathor store first, then packed libraries, then
  /// user libraries in registration order.
  std::shared_ptr<const Annotation> GetAnnotation(std::string_view uid) const;
  /// Every UID GetAnnotation answers, each once, in that order: the objathor store's, the
  /// packed libraries' with metadata, then user_uids().
  std::vector<std::string> annotated_uids() const;

  /// Opens a converted objathor store (uid_index.mlsx + metadata.mlsm in `dir`, written by
  /// resources/objathor.h) as the annotations asked first, replacing any other; clears the
  /// annotation cache. The assets dir's <assets>/objects/objathor_metadata/.mlspaces/index is
  /// opened at construction when present. Not concurrent with lookups. @throws Error.
  void RegisterObjathorStore(const std::filesystem::path& dir);
  /// The objathor store (shared: it outlives the Registry if held), or nullptr.
  std::shared_ptr<const PackedLibrary> objathor_store() const;

  // ===========================================================================================
  // Grasps

  /// Grasp libraries a lookup for `uid` walks: the filter's names that serve the UID's
  /// library, in the filter's order; or all of them when the filter is empty.
  std::vector<std::string> GraspLibrariesFor(std::string_view uid,
                                             GraspLibraryFilter filter = {}) const;

  /// The first existing grasp file for the query in priority order, and the library that
  /// provided it; nullopt when there is none (no error).
  /// Pickup grasps (empty joint): built-in libraries hold
  /// <assets>/grasps/<lib>/<uid>/<uid>_grasps_filtered.npz.
  /// Joint grasps: when the UID is in no asset library and the query names exactly one
  /// library, that library is asked directly (for iTHOR articulated objects; see
  /// docs/formats.md). Built-in libraries hold
  /// <assets>/grasps/<lib>/<uid>/<joint>_grasps_filtered.npz, under the library's own name.
  std::optional<GraspFileLocation> FindGraspFile(const GraspQuery& query) const;
  /// FindGraspFile's path only.
  std::optional<std::filesystem::path> GraspPath(const GraspQuery& query) const;
  /// A grasp file exists and holds at least `num_grasps` grasps (reads the NPZ header only).
  /// False when there is no file. @throws Error for a corrupt file.
  bool HasValidGrasps(const GraspQuery& query, size_t num_grasps = 1) const;
  /// Loads grasps. A decoded NPZ is kept (up to 256 MB of poses, least recently used out) and
  /// reused while the file is unchanged (one stat per call: device, inode, size, mtime,
  /// ctime). If the file has N <= num_grasps rows, all of them in file order; else
  /// num_grasps distinct rows drawn with Rng(seed) by a partial Fisher-Yates shuffle, in
  /// draw order (SubsampleIndices; docs/formats.md). @throws Error "No grasp file found for
  /// <uid>" (pickup) or "No joint grasp file found for <uid>/<joint>", or for a bad file
  /// (shape not (N,4,4), non-finite values, a packed shard not installed or damaged).
  GraspSet LoadGrasps(const GraspQuery& query, size_t num_grasps = 50, uint64_t seed = 0) const;
  /// As LoadGrasps, reading the rows `choose` picks from the file's row count.
  GraspSet LoadGrasps(const GraspQuery& query, const GraspRowChooser& choose) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces
