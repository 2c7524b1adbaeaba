#include "mlspaces/core/json.h"

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces {

namespace {

template <class J>
J ParseAny(std::string_view text, const std::string& path_for_errors) {
  try {
    return J::parse(text.begin(), text.end());
  } catch (const nlohmann::json::parse_error& e) {
    // Translate the byte offset into line and column.
    size_t offset = e.byte == 0 ? 0 : e.byte - 1;
    if (offset > text.size()) offset = text.size();
    size_t line = 1, column = 1;
    for (size_t i = 0; i < offset; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    std::string what = e.what();
    // nlohmann's message: "[json.exception.parse_error.101] parse error at line 1, column 2:
    // syntax error while parsing value - invalid literal; last read: 'x'"
    auto pos = what.find("syntax error");
    if (pos == std::string::npos) pos = what.find(": ");
    std::string detail = pos == std::string::npos ? what : what.substr(pos);
    throw Error("invalid JSON: " + detail, path_for_errors,
                "line " + std::to_string(line) + ", column " + std::to_string(column));
  }
}

template <class J>
std::string TypeName(const J& value) {
  switch (value.type()) {
    case nlohmann::json::value_t::null: return "null";
    case nlohmann::json::value_t::object: return "object";
    case nlohmann::json::value_t::array: return "array";
    case nlohmann::json::value_t::string: return "string";
    case nlohmann::json::value_t::boolean: return "boolean";
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned: return "integer";
    case nlohmann::json::value_t::number_float: return "number";
    default: return "value";
  }
}

}  // namespace

Json ParseJson(std::string_view text, const std::string& path_for_errors) {
  return ParseAny<Json>(text, path_for_errors);
}

Json ParseJsonFile(const std::filesystem::path& path) {
  return ParseJson(ReadFile(path), path.string());
}

FlatJson ParseFlatJson(std::string_view text, const std::string& path_for_errors) {
  return ParseAny<FlatJson>(text, path_for_errors);
}

FlatJson ParseFlatJsonFile(const std::filesystem::path& path) {
  return ParseFlatJson(ReadFile(path), path.string());
}

std::string JsonTypeName(const Json& value) { return TypeName(value); }
std::string JsonTypeName(const FlatJson& value) { return TypeName(value); }

std::string DumpJsonIndent4(const Json& value) {
  return value.dump(4, ' ', /*ensure_ascii=*/true);
}


}  // namespace mlspaces
