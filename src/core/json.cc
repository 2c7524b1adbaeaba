#include "mlspaces/core/json.h"

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces {

Json ParseJson(std::string_view text, const std::string& path_for_errors) {
  try {
    return Json::parse(text.begin(), text.end());
  } catch (const Json::parse_error& e) {
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
    throw Error("invalid JSON: " + detail,
                path_for_errors, "line " + std::to_string(line) + ", column " +
                                     std::to_string(column));
  }
}

Json ParseJsonFile(const std::filesystem::path& path) {
  return ParseJson(ReadFile(path), path.string());
}

std::string DumpJsonIndent4(const Json& value) {
  return value.dump(4, ' ', /*ensure_ascii=*/true);
}

std::string JsonTypeName(const Json& value) {
  switch (value.type()) {
    case Json::value_t::null: return "null";
    case Json::value_t::object: return "object";
    case Json::value_t::array: return "array";
    case Json::value_t::string: return "string";
    case Json::value_t::boolean: return "boolean";
    case Json::value_t::number_integer:
    case Json::value_t::number_unsigned: return "integer";
    case Json::value_t::number_float: return "number";
    default: return "value";
  }
}

}  // namespace mlspaces
