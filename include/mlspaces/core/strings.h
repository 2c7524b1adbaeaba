// Small string helpers shared by every layer.
#pragma once

#include "mlspaces/core/export.h"

#include <string>
#include <string_view>

namespace mlspaces {

/// ASCII lower case of `s` (bytes >= 0x80 unchanged): for case-insensitive names.
MLSPACES_API std::string Lower(std::string_view s);

/// `s` for a one-line message: control characters (newline, ESC, ...) and bytes that are not
/// UTF-8 written as \xNN, everything else unchanged (so applying it twice changes nothing).
MLSPACES_API std::string Printable(std::string_view s);

}  // namespace mlspaces
