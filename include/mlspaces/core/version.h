// The mlspaces version (the CMake project version).
#pragma once

#include "mlspaces/core/export.h"

#include <string_view>

namespace mlspaces {

/// e.g. "0.1.0".
MLSPACES_API std::string_view Version();

}  // namespace mlspaces
