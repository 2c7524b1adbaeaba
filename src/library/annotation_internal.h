// Internal: annotation loading relative to an open library folder.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "mlspaces/library/annotation.h"

namespace mlspaces::internal {

/// LoadAnnotation with the metadata JSON opened by openat(dir_fd, metadata_rel) when
/// dir_fd >= 0 (an O_PATH descriptor of `dir`), saving the kernel the walk of the full path on
/// every first-time lookup; errors still name the full path.
Annotation LoadAnnotationAt(int dir_fd, const std::filesystem::path& dir, std::string_view uid,
                            const std::string& library, const std::string& metadata_rel,
                            const std::string* npz_rel);

}  // namespace mlspaces::internal
