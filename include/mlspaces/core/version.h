// The mlspaces version (the CMake project version).
#pragma once

#include <string_view>

namespace mlspaces {

/// e.g. "0.1.0".
std::string_view Version();

}  // namespace mlspaces
