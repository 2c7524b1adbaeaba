// JSON helpers on nlohmann::ordered_json (key order is kept, as Python dicts keep it).
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace mlspaces {

/// Key-ordered JSON for documents users write (metadata): order is kept as Python keeps it.
/// Its objects are vectors, so key lookup and insertion are linear: fine for small objects,
/// quadratic for big ones. Large machine-written files (indexes) use FlatJson.
using Json = nlohmann::ordered_json;
/// JSON with std::map objects (sorted keys, O(log n) insertion), for index files with
/// hundreds of thousands of keys.
using FlatJson = nlohmann::json;

/// Parses a JSON document. @throws Error with `path` and "line L, column C" on a syntax error.
MLSPACES_API Json ParseJson(std::string_view text, const std::string& path_for_errors);

/// Reads and parses a JSON file. @throws Error naming the file (missing, unreadable, bad JSON).
MLSPACES_API Json ParseJsonFile(const std::filesystem::path& path);

/// As ParseJson / ParseJsonFile, into FlatJson (for big index files; duplicate keys: last wins).
MLSPACES_API FlatJson ParseFlatJson(std::string_view text, const std::string& path_for_errors);
MLSPACES_API FlatJson ParseFlatJsonFile(const std::filesystem::path& path);

/// Serialises like Python's json.dumps(obj, indent=4): ", " / ": " separators, non-ASCII
/// escaped as \uXXXX, floats in shortest round-trip form. No trailing newline.
MLSPACES_API std::string DumpJsonIndent4(const Json& value);

/// Name of a JSON value's type for messages: "object", "array", "string", "integer",
/// "number", "boolean", "null".
MLSPACES_API std::string JsonTypeName(const Json& value);
MLSPACES_API std::string JsonTypeName(const FlatJson& value);
/// As JsonTypeName but "number" for every numeric type ("expected string, got number").
template <class J>
std::string JsonTypeWord(const J& value) {
  return value.is_number() ? "number" : JsonTypeName(value);
}

}  // namespace mlspaces
