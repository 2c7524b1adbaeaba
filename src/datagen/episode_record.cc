#include "mlspaces/datagen/episode_record.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <map>

#include "mlspaces/core/error.h"

namespace mlspaces::datagen {
namespace {

template <class T>
void PutValue(std::vector<unsigned char>& bytes, T v) {
  const size_t at = bytes.size();
  bytes.resize(at + sizeof(T));
  std::memcpy(bytes.data() + at, &v, sizeof(T));
}

void DumpInto(const Json& v, std::string& out) {
  switch (v.type()) {
    case Json::value_t::object: {
      // Python's sort_keys compares code points; UTF-8 byte order is the same order.
      std::map<std::string, const Json*> sorted;
      for (auto it = v.begin(); it != v.end(); ++it) sorted.emplace(it.key(), &it.value());
      out += '{';
      bool first = true;
      for (const auto& [key, value] : sorted) {
        if (!first) out += ',';
        first = false;
        out += Json(key).dump(-1, ' ', true);
        out += ':';
        DumpInto(*value, out);
      }
      out += '}';
      return;
    }
    case Json::value_t::array: {
      out += '[';
      for (size_t i = 0; i < v.size(); ++i) {
        if (i > 0) out += ',';
        DumpInto(v[i], out);
      }
      out += ']';
      return;
    }
    case Json::value_t::number_float: {
      const double d = v.get<double>();
      if (std::isnan(d)) {
        out += "NaN";
      } else if (std::isinf(d)) {
        out += d > 0 ? "Infinity" : "-Infinity";
      } else {
        out += v.dump();
      }
      return;
    }
    default:
      out += v.dump(-1, ' ', true);
  }
}

// double -> integer type, saturating (NaN -> 0) instead of undefined behaviour.
template <class T>
T ToInt(double v) {
  if (std::isnan(v)) return 0;
  if (v <= static_cast<double>(std::numeric_limits<T>::min())) {
    return std::numeric_limits<T>::min();
  }
  if (v >= static_cast<double>(std::numeric_limits<T>::max())) {
    return std::numeric_limits<T>::max();
  }
  return static_cast<T>(v);
}

}  // namespace

const char* DTypeName(DType dtype) {
  switch (dtype) {
    case DType::kBool:
      return "bool";
    case DType::kUint8:
      return "uint8";
    case DType::kInt32:
      return "int32";
    case DType::kInt64:
      return "int64";
    case DType::kFloat32:
      return "float32";
    case DType::kFloat64:
      return "float64";
  }
  return "?";
}

size_t DTypeSize(DType dtype) {
  switch (dtype) {
    case DType::kBool:
    case DType::kUint8:
      return 1;
    case DType::kInt32:
    case DType::kFloat32:
      return 4;
    case DType::kInt64:
    case DType::kFloat64:
      return 8;
  }
  return 0;
}

Series::Series(DType dtype, std::vector<size_t> row_shape)
    : dtype_(dtype), row_shape_(std::move(row_shape)) {}

size_t Series::row_size() const {
  size_t n = 1;
  for (size_t d : row_shape_) n *= d;
  return n;
}

void Series::CheckRow(size_t n) const {
  if (n != row_size()) {
    throw Error("row " + std::to_string(steps_) + " has " + std::to_string(n) +
                " values, expected " + std::to_string(row_size()));
  }
}

void Series::Append(const std::vector<double>& row) {
  CheckRow(row.size());
  for (double v : row) {
    switch (dtype_) {
      case DType::kBool:
        PutValue<uint8_t>(bytes_, v != 0.0 ? 1 : 0);
        break;
      case DType::kUint8:
        PutValue(bytes_, ToInt<uint8_t>(v));
        break;
      case DType::kInt32:
        PutValue(bytes_, ToInt<int32_t>(v));
        break;
      case DType::kInt64:
        PutValue(bytes_, ToInt<int64_t>(v));
        break;
      case DType::kFloat32:
        PutValue(bytes_, static_cast<float>(v));
        break;
      case DType::kFloat64:
        PutValue(bytes_, v);
        break;
    }
  }
  ++steps_;
}

void Series::AppendInts(const std::vector<int64_t>& row) {
  CheckRow(row.size());
  for (int64_t v : row) {
    switch (dtype_) {
      case DType::kBool:
        PutValue<uint8_t>(bytes_, v != 0 ? 1 : 0);
        break;
      case DType::kUint8:
        PutValue(bytes_, static_cast<uint8_t>(v));
        break;
      case DType::kInt32:
        PutValue(bytes_, static_cast<int32_t>(v));
        break;
      case DType::kInt64:
        PutValue(bytes_, v);
        break;
      case DType::kFloat32:
        PutValue(bytes_, static_cast<float>(v));
        break;
      case DType::kFloat64:
        PutValue(bytes_, static_cast<double>(v));
        break;
    }
  }
  ++steps_;
}

std::string DumpJsonCompactSorted(const Json& value) {
  std::string out;
  DumpInto(value, out);
  return out;
}

Json MoveGroupJson(const MoveGroupValues& values, bool round_to_float32) {
  Json out = Json::object();
  for (const auto& [group, vals] : values) {
    Json arr = Json::array();
    for (double v : vals) {
      arr.push_back(round_to_float32 ? static_cast<double>(static_cast<float>(v)) : v);
    }
    out[group] = std::move(arr);
  }
  return out;
}

}  // namespace mlspaces::datagen
