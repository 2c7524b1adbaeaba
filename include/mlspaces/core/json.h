// JSON helpers on nlohmann::ordered_json (key order is kept, as Python dicts keep it).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace mlspaces {

using Json = nlohmann::ordered_json;

/// Parses a JSON document. @throws Error with `path` and "line L, column C" on a syntax error.
Json ParseJson(std::string_view text, const std::string& path_for_errors);

/// Reads and parses a JSON file. @throws Error naming the file (missing, unreadable, bad JSON).
Json ParseJsonFile(const std::filesystem::path& path);

/// Serialises like Python's json.dumps(obj, indent=4): ", " / ": " separators, non-ASCII
/// escaped as \uXXXX, floats in shortest round-trip form. No trailing newline.
std::string DumpJsonIndent4(const Json& value);

/// Name of a JSON value's type for messages: "object", "array", "string", "number", ...
std::string JsonTypeName(const Json& value);

}  // namespace mlspaces
