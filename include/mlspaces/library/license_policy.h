// The licence policy: which assets a run, a search or an install may use. MolmoSpaces added a
// non-commercial gate after spec 11 was written (its NON_COMMERCIAL_LICENSES = by-nc, by-nc-sa
// and object_license_key: an annotation's `license_info.license`, "by" for assets without
// one); `commercial_safe` leaves out assets whose annotation says `license_info.license` is
// `by-nc` or `by-nc-sa` (docs/licenses.md). The full licence text of an asset is
// resources/license.h's ResolveLicense; this header only holds what every layer needs.
//
// Plain functions on values; nothing keeps a reference to its arguments.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace mlspaces {

struct Annotation;

// =============================================================================================
// Policies

enum class LicensePolicy {
  kAll,             ///< every asset (the original's behaviour before its licence gate)
  kCommercialSafe,  ///< no non-commercial (by-nc, by-nc-sa) assets
};

/// The names ParseLicensePolicy reads, in enum order.
inline constexpr std::array<std::string_view, 2> kLicensePolicyNames{"all", "commercial_safe"};
/// The YAML archive's enum hook (core/yaml_archive.h), found by ADL: a config key of type
/// LicensePolicy reads and writes these names.
constexpr const auto& YamlEnumNames(LicensePolicy) { return kLicensePolicyNames; }

/// "all" or "commercial_safe". @throws UsageError naming `origin` for any other text.
MLSPACES_API LicensePolicy ParseLicensePolicy(std::string_view text,
                                              std::string_view origin = "license policy");
/// The policy's name as ParseLicensePolicy reads it.
MLSPACES_API std::string_view LicensePolicyName(LicensePolicy policy);
/// `given` when it has a value (a flag, a config key), else MLSPACES_LICENSE_POLICY when set
/// and non-empty, else kAll. @throws UsageError for a bad MLSPACES_LICENSE_POLICY.
MLSPACES_API LicensePolicy ResolveLicensePolicy(std::optional<LicensePolicy> given = {});

// =============================================================================================
// Decisions

/// True for the non-commercial Creative Commons short names the original knows: "by-nc",
/// "by-nc-sa" (case-insensitive, surrounding blanks ignored).
MLSPACES_API bool IsNonCommercialLicense(std::string_view license);
/// The licence short name an annotation records (`license_info.license`), or empty when it has
/// none (THOR assets, user assets without `license_info`). `annotation` may be null.
MLSPACES_API std::string AnnotationLicense(const Annotation* annotation);
/// Whether `policy` lets an asset with this annotation be used (null: no annotation, allowed).
MLSPACES_API bool AllowedByLicensePolicy(LicensePolicy policy, const Annotation* annotation);

// =============================================================================================
// Short answers (episode provenance)

/// The SPDX-style name the original's resolve_license gives a Creative Commons short name:
/// by -> CC-BY-4.0, by-sa -> CC-BY-SA-4.0, cc0 -> CC0-1.0, by-nc -> CC-BY-NC-4.0, by-nc-sa ->
/// CC-BY-NC-SA-4.0 (case-insensitive, blanks ignored); nullopt for anything else.
MLSPACES_API std::optional<std::string> SpdxLicenseName(std::string_view license);
/// The licence of an asset in one word, as episode provenance records it: the SPDX name of
/// `license_info.license` when the annotation has one (its text as written when it is not a
/// known short name); CC-BY-4.0 for a `thor` asset (Ai2's in-house assets); else a top-level
/// `license` (or `licence`) string of a user asset's metadata; else "unknown".
/// `library` is the asset library that holds the UID; `annotation` may be null.
MLSPACES_API std::string AssetLicenseName(std::string_view library, const Annotation* annotation);

}  // namespace mlspaces
