#include "mlspaces/core/version.h"

namespace mlspaces {

std::string_view Version() { return MLSPACES_VERSION; }

}  // namespace mlspaces
