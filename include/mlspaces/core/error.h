// mlspaces::Error, the one exception type the libraries throw for bad input.
#pragma once

#include "mlspaces/core/export.h"

#include <stdexcept>
#include <string>

namespace mlspaces {

/// An error caused by input: a file, a field in it, or a UID.
///
/// what() is one line: "<path>: <field>: <message>", leaving out empty parts.
/// `field` is a JSON pointer ("/red_block/object_path"), an XML/YAML line ("line 12"),
/// or a zip member name, whichever locates the problem best.
class MLSPACES_API Error : public std::runtime_error {
 public:
  explicit Error(std::string message, std::string path = {}, std::string field = {},
                 std::string uid = {});

  // The accessors' references are valid while the Error lives.

  /// The message alone, without path and field.
  const std::string& message() const { return message_; }
  /// The file the error is about; may be empty.
  const std::string& path() const { return path_; }
  /// Where in the file: JSON pointer, "line N", or member name; may be empty.
  const std::string& field() const { return field_; }
  /// The asset UID involved; may be empty.
  const std::string& uid() const { return uid_; }

 private:
  std::string message_, path_, field_, uid_;
};

/// Bad usage of a command or API (bad flag value, malformed NAME=DIR); CLI exit code 2.
class MLSPACES_API UsageError : public Error {
 public:
  using Error::Error;
  /// `e` (message, path, field, UID) as bad usage: the value it is about came from a flag or
  /// an argument ("--gripper: unknown robot ...").
  explicit UsageError(const Error& e) : Error(e) {}
};

/// Escapes one reference token for a JSON pointer ("~" -> "~0", "/" -> "~1").
MLSPACES_API std::string JsonPointerToken(std::string_view token);

}  // namespace mlspaces
