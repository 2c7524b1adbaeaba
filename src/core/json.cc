#include "mlspaces/core/json.h"

#include <simdjson.h>

#include <cstring>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces {

namespace {

// The one-line error for text nlohmann cannot parse: "invalid JSON: <what>" at "line L,
// column C".
[[noreturn]] void ThrowParseError(const nlohmann::json::parse_error& e, std::string_view text,
                                  const std::string& path_for_errors) {
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

// The value of a simdjson result whose type was already checked.
template <class T>
T ValueOf(simdjson::simdjson_result<T> result) {
  T value{};
  if (std::move(result).get(value) != simdjson::SUCCESS) return T{};
  return value;
}

// simdjson DOM -> nlohmann value, with nlohmann's own conventions: non-negative integers are
// number_unsigned, a repeated key keeps its first position and its last value.
template <class J>
J Convert(simdjson::dom::element e) {
  using simdjson::dom::element_type;
  switch (e.type()) {
    case element_type::OBJECT: {
      J out = J::object();
      simdjson::dom::object object;
      if (e.get_object().get(object) != simdjson::SUCCESS) return out;
      for (simdjson::dom::key_value_pair field : object) {
        out[std::string(field.key)] = Convert<J>(field.value);
      }
      return out;
    }
    case element_type::ARRAY: {
      J out = J::array();
      auto& items = out.template get_ref<typename J::array_t&>();
      simdjson::dom::array array;
      if (e.get_array().get(array) != simdjson::SUCCESS) return out;
      for (simdjson::dom::element item : array) {
        items.push_back(Convert<J>(item));
      }
      return out;
    }
    case element_type::INT64: {
      const int64_t v = ValueOf(e.get_int64());
      return v >= 0 ? J(static_cast<uint64_t>(v)) : J(v);
    }
    case element_type::UINT64:
      return J(ValueOf(e.get_uint64()));
    case element_type::DOUBLE:
      return J(ValueOf(e.get_double()));
    case element_type::STRING:
      return J(std::string(ValueOf(e.get_string())));
    case element_type::BOOL:
      return J(ValueOf(e.get_bool()));
    case element_type::NULL_VALUE:
      return J(nullptr);
  }
  return J();
}

// Parses with simdjson (several times faster than nlohmann's parser, which matters for
// first-time annotation lookups and big index files) and converts. Anything simdjson rejects
// (bad syntax, integers beyond 64 bits, ...) goes to nlohmann, which either accepts it the
// way mlspaces always did or words the error with line and column.
template <class J>
J ParseAny(std::string_view text, const std::string& path_for_errors) {
  thread_local simdjson::dom::parser parser;
  thread_local std::vector<char> padded;
  if (padded.size() < text.size() + simdjson::SIMDJSON_PADDING) {
    padded.resize(text.size() + simdjson::SIMDJSON_PADDING);
  }
  std::memcpy(padded.data(), text.data(), text.size());
  simdjson::dom::element root;
  if (parser.parse(padded.data(), text.size(), /*realloc_if_needed=*/false).get(root) ==
      simdjson::SUCCESS) {
    return Convert<J>(root);
  }
  try {
    return J::parse(text.begin(), text.end());
  } catch (const nlohmann::json::parse_error& e) {
    ThrowParseError(e, text, path_for_errors);
  }
}

template <class J>
std::string TypeName(const J& value) {
  switch (value.type()) {
    case nlohmann::json::value_t::null:
      return "null";
    case nlohmann::json::value_t::object:
      return "object";
    case nlohmann::json::value_t::array:
      return "array";
    case nlohmann::json::value_t::string:
      return "string";
    case nlohmann::json::value_t::boolean:
      return "boolean";
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
      return "integer";
    case nlohmann::json::value_t::number_float:
      return "number";
    default:
      return "value";
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

std::string DumpJsonIndent4(const Json& value) { return value.dump(4, ' ', /*ensure_ascii=*/true); }

}  // namespace mlspaces
