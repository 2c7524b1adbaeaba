// Diagnostic formatting and the collector.
#include "mlspaces/core/diagnostics.h"

#include <algorithm>
#include <utility>

#include "mlspaces/core/strings.h"

namespace mlspaces {

std::string Diagnostic::ToString() const {
  std::string out = path;
  if (!field.empty()) out += (out.empty() ? "" : ": ") + field;
  if (!message.empty()) out += (out.empty() ? "" : ": ") + message;
  return Printable(out);  // file names, UIDs and messages from input may hold control bytes
}

void Diagnostics::Error(std::string path, std::string field, std::string message, std::string uid) {
  items_.push_back(Diagnostic{std::move(path), std::move(field), std::move(message), std::move(uid),
                              Severity::kError});
}

void Diagnostics::Warning(std::string path, std::string field, std::string message,
                          std::string uid) {
  items_.push_back(Diagnostic{std::move(path), std::move(field), std::move(message), std::move(uid),
                              Severity::kWarning});
}

size_t Diagnostics::errors() const {
  return static_cast<size_t>(std::count_if(items_.begin(), items_.end(), [](const Diagnostic& d) {
    return d.severity == Severity::kError;
  }));
}

}  // namespace mlspaces
