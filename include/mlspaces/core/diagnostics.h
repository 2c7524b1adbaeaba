// Diagnostic: the one shape of a warning or a per-item problem found while checking or
// building something (library validation, dataset validation, install verification, ...).
// Printed on one line as "path: field: message", leaving out empty parts, like Error::what().
#pragma once

#include "mlspaces/core/export.h"

#include <string>
#include <utility>
#include <vector>

namespace mlspaces {

enum class Severity { kError, kWarning };

struct MLSPACES_API Diagnostic {
  Diagnostic() = default;
  Diagnostic(std::string path, std::string field, std::string message, std::string uid = {},
             Severity severity = Severity::kError)
      : path(std::move(path)),
        field(std::move(field)),
        message(std::move(message)),
        uid(std::move(uid)),
        severity(severity) {}

  std::string path;   ///< the file or folder concerned; may be empty
  std::string field;  ///< where in it: JSON pointer, HDF5 path, "line N", member; may be empty
  std::string message;
  std::string uid;  ///< the asset concerned; may be empty (not printed)
  Severity severity = Severity::kError;

  /// "path: field: message", leaving out empty parts; control characters and bytes that are
  /// not UTF-8 written as \xNN (Printable), so it is always one line.
  std::string ToString() const;
};

/// Collects diagnostics in the order they are found.
class MLSPACES_API Diagnostics {
 public:
  void Error(std::string path, std::string field, std::string message, std::string uid = {});
  void Warning(std::string path, std::string field, std::string message, std::string uid = {});
  void Add(Diagnostic d) { items_.push_back(std::move(d)); }

  /// The diagnostics so far, in order; valid until the next Error/Warning/Add/Take.
  const std::vector<Diagnostic>& items() const { return items_; }
  /// Moves the diagnostics out.
  std::vector<Diagnostic> Take() { return std::move(items_); }
  size_t size() const { return items_.size(); }
  size_t errors() const;
  bool ok() const { return errors() == 0; }

 private:
  std::vector<Diagnostic> items_;
};

}  // namespace mlspaces
