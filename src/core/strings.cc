#include "mlspaces/core/strings.h"

#include <cctype>

namespace mlspaces {

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace mlspaces
