// Licences of MolmoSpaces data: the original's `resolve_license` / `print_license_info`
// (molmo_spaces/utils/license_utils.py) for objects, scenes, grasps and robots, plus the user
// libraries the original cannot answer for (docs/licenses.md lists the rules and every
// difference). Built-in identifiers are validated against a source's archive names, read from
// its size manifest (kSizeManifestFile) in the install or cache tree; annotations come from
// the Registry.
//
// Plain functions on values; nothing keeps a reference to its arguments after returning.
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/json.h"

namespace mlspaces {

class Registry;

// =============================================================================================
// Where lookups read

/// The data types a licence can be asked for, in the original's order.
inline constexpr std::string_view kLicenseDataTypes[] = {"objects", "scenes", "grasps", "robots"};

/// What licence lookups read. `registry` must outlive the calls that use it (not null).
struct MLSPACES_API LicenseContext {
  const Registry* registry = nullptr;  ///< annotations, asset locations, user libraries
  std::filesystem::path assets_dir;    ///< install dir; empty: no built-in data
  std::filesystem::path cache_dir;     ///< resource cache; empty: not searched
};

// =============================================================================================
// Archive names and identifiers

/// The size manifest of a built-in source: <assets>/<type>/<source>/kSizeManifestFile (a
/// GLOBAL link into the cache), else <cache>/<type>/<source>/<version>/kSizeManifestFile with
/// the version the install manifest (<assets>/mjthor_data_type_to_source_to_versions.json)
/// records, else the only version folder in the cache that has one. nullopt when none exists.
MLSPACES_API std::optional<std::filesystem::path> FindSizeManifest(const LicenseContext& context,
                                                                   std::string_view data_type,
                                                                   std::string_view source);

/// The archive names of a source (the manifest's keys, in file order).
/// @throws Error "no size manifest for <type>/<source> ..." naming where it looked, or naming
/// the manifest when it is not a JSON object.
MLSPACES_API std::vector<std::string> SourceArchiveNames(const LicenseContext& context,
                                                         std::string_view data_type,
                                                         std::string_view source);

/// An archive's identifier, as `--list-all` prints it: "<source>_" and ".tar.zst" removed.
MLSPACES_API std::string ArchiveIdentifier(std::string_view archive, std::string_view source);

/// The original's validate_identifier: the first archive (in `archives` order) whose name
/// contains `identifier` as a substring; returns its name up to the first '.', with every
/// "<source>_" removed. @throws Error "identifier='<id>' is not in source='<s>'
/// (data_type='<t>')" followed by how many identifiers exist and the first ten, sorted.
MLSPACES_API std::string ValidateIdentifier(const std::vector<std::string>& archives,
                                            std::string_view data_type, std::string_view source,
                                            std::string_view identifier);

// =============================================================================================
// Resolution

/// The licence record of one item, with the original's keys and texts, in its key order:
///  - objects/objaverse: the annotation's `license_info` (license must be by, by-sa, cc0,
///    by-nc or by-nc-sa, else Error "Got unsupported license ..."; creator_profile_url must
///    contain "sketchfab"); the UID is checked against the annotation's isObjaverse, or, when
///    there is no annotation, by substring over the source's archive names.
///  - objects/thor, objects/objathor_metadata, scenes, grasps: CC-BY-4.0 (Ai2) with the
///    original's scope texts; grasps list their `external_target_assets` when the source's
///    tries file is there; scenes by index list the `assets` of the installed scene's metadata.
///  - robots: the table of robot licences (franka, rby, robotiq, rum, yam, g1, rocketbox).
///  - objects/<user library>: the asset's `license_info` when its metadata has one, else
///    "license": "unknown" with the reason (the original raises instead).
/// @throws Error for an unknown type or source ("Can't determine license for `objects` with
/// data_source='...' and identifier='...'"), an identifier no archive or library holds, or an
/// annotation that lacks a field the rules read (the field named as a JSON pointer).
MLSPACES_API Json ResolveLicense(const LicenseContext& context, std::string_view data_type,
                                 std::string_view source, std::string_view identifier);

/// The source an object UID belongs to when none is given: "objaverse" / "thor" by its
/// annotation's isObjaverse (what built-in annotations carry), else the user library whose
/// metadata holds it, else the library Locate names. nullopt when the UID is unknown.
MLSPACES_API std::optional<std::string> DefaultObjectSource(const Registry& registry,
                                                            std::string_view uid);

}  // namespace mlspaces
