#include "mlspaces/core/error.h"

namespace mlspaces {
namespace {

std::string FormatWhat(const std::string& message, const std::string& path,
                       const std::string& field) {
  std::string out;
  if (!path.empty()) out += path + ": ";
  if (!field.empty()) out += field + ": ";
  out += message;
  return out;
}

}  // namespace

Error::Error(std::string message, std::string path, std::string field, std::string uid)
    : std::runtime_error(FormatWhat(message, path, field)),
      message_(std::move(message)),
      path_(std::move(path)),
      field_(std::move(field)),
      uid_(std::move(uid)) {}

std::string JsonPointerToken(std::string_view token) {
  std::string out;
  out.reserve(token.size());
  for (char c : token) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace mlspaces
