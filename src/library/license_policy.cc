// The licence policy (include/mlspaces/library/license_policy.h).
#include "mlspaces/library/license_policy.h"

#include <cctype>
#include <cstdlib>

#include "mlspaces/core/error.h"
#include "mlspaces/library/annotation.h"

namespace mlspaces {

LicensePolicy ParseLicensePolicy(std::string_view text, std::string_view origin) {
  if (text == "all") return LicensePolicy::kAll;
  if (text == "commercial_safe") return LicensePolicy::kCommercialSafe;
  throw UsageError(std::string(origin) + ": unknown licence policy '" + std::string(text) +
                   "' (expected all or commercial_safe)");
}

std::string_view LicensePolicyName(LicensePolicy policy) {
  return policy == LicensePolicy::kCommercialSafe ? "commercial_safe" : "all";
}

LicensePolicy ResolveLicensePolicy(std::optional<LicensePolicy> given) {
  if (given) return *given;
  const char* env = std::getenv("MLSPACES_LICENSE_POLICY");
  if (env != nullptr && *env != '\0') return ParseLicensePolicy(env, "MLSPACES_LICENSE_POLICY");
  return LicensePolicy::kAll;
}

namespace {

// The short name lower-cased, surrounding blanks removed.
std::string NormalizedLicense(std::string_view license) {
  while (!license.empty() && std::isspace(static_cast<unsigned char>(license.front())))
    license.remove_prefix(1);
  while (!license.empty() && std::isspace(static_cast<unsigned char>(license.back())))
    license.remove_suffix(1);
  std::string lower;
  for (char c : license) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower;
}

}  // namespace

bool IsNonCommercialLicense(std::string_view license) {
  const std::string lower = NormalizedLicense(license);
  return lower == "by-nc" || lower == "by-nc-sa";
}

std::optional<std::string> SpdxLicenseName(std::string_view license) {
  const std::string lower = NormalizedLicense(license);
  if (lower == "by") return "CC-BY-4.0";
  if (lower == "by-sa") return "CC-BY-SA-4.0";
  if (lower == "cc0") return "CC0-1.0";
  if (lower == "by-nc") return "CC-BY-NC-4.0";
  if (lower == "by-nc-sa") return "CC-BY-NC-SA-4.0";
  return std::nullopt;
}

std::string AssetLicenseName(std::string_view library, const Annotation* annotation) {
  const std::string key = AnnotationLicense(annotation);
  if (!key.empty()) return SpdxLicenseName(key).value_or(key);
  if (library == "thor") return "CC-BY-4.0";
  if (annotation != nullptr && annotation->json.is_object()) {
    for (const char* name : {"license", "licence"}) {
      const auto it = annotation->json.find(name);
      if (it != annotation->json.end() && it->is_string() && !it->get<std::string>().empty()) {
        return it->get<std::string>();
      }
    }
  }
  return "unknown";
}

std::string AnnotationLicense(const Annotation* annotation) {
  if (annotation == nullptr || !annotation->json.is_object()) return {};
  auto info = annotation->json.find("license_info");
  if (info == annotation->json.end() || !info->is_object()) return {};
  auto license = info->find("license");
  if (license == info->end() || !license->is_string()) return {};
  return license->get<std::string>();
}

bool AllowedByLicensePolicy(LicensePolicy policy, const Annotation* annotation) {
  if (policy == LicensePolicy::kAll) return true;
  return !IsNonCommercialLicense(AnnotationLicense(annotation));
}

}  // namespace mlspaces
