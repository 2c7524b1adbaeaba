// MessagePack -> ordered_json (include/mlspaces/library/msgpack.h).
//
//
// How the metadata JSON is stored, chosen by measurement. Decoding the 303-byte compact form
// of examples/custom_assets/asset_library/red_block/red_block_computed.json into a Json
// (nlohmann::ordered_json), -O2, one core of the build machine, mean of 200,000 decodes:
//
//   nlohmann::json::parse of the compact text           3,670 ns
//   ParseJson (simdjson DOM + conversion) of the text    1,590 ns
//   nlohmann::json::from_msgpack (258 bytes)             2,710 ns
//   nlohmann::json::from_cbor (258 bytes)                2,750 ns
//   copying the finished Json (allocation floor)           670 ns
//
// bench/packed_store_bench.cc repeats these (BM_JsonDecode*, BM_JsonCopy) beside
// BM_LoadAnnotation, which decodes a whole red_block-like record with the decoder below.
//
// nlohmann's own binary readers are slower than simdjson on the text (they go through a
// generic SAX interface byte by byte), so records hold MessagePack as nlohmann::to_msgpack
// writes it (standard, 15% smaller than the text) and msgpack.cc decodes it with a small
// direct decoder that builds the ordered_json in place (about two allocations per value,
// bounds-checked, depth-limited). That leaves the whole LoadAnnotation of a small record
// (checksum, UID check, decode) at 0.9 us (BM_LoadAnnotation, 150,000-asset store; same run:
#include "mlspaces/library/msgpack.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <string>
#include <utility>

namespace mlspaces {
namespace {

class MsgpackDecoder {
 public:
  MsgpackDecoder(const uint8_t* p, const uint8_t* end) : p_(p), end_(end) {}

  /// Decodes one value that must span the whole input. Returns false on any malformation.
  bool DecodeAll(Json& out) {
    if (!Value(out, 0)) return false;
    return p_ == end_;
  }

 private:
  bool Need(uint64_t n) const { return static_cast<uint64_t>(end_ - p_) >= n; }

  template <class T>
  bool BigEndian(T& v) {
    if (!Need(sizeof v)) return false;
    std::memcpy(&v, p_, sizeof v);
    p_ += sizeof v;
    if constexpr (sizeof v == 2) v = __builtin_bswap16(v);
    if constexpr (sizeof v == 4) v = __builtin_bswap32(v);
    if constexpr (sizeof v == 8) v = __builtin_bswap64(v);
    return true;
  }

  bool Str(uint64_t n, std::string& s) {
    if (!Need(n)) return false;
    s.assign(reinterpret_cast<const char*>(p_), n);
    p_ += n;
    return true;
  }

  /// Reads a string header + bytes (map keys).
  bool Key(std::string& s) {
    if (!Need(1)) return false;
    const uint8_t b = *p_++;
    uint64_t n;
    if (b >= 0xa0 && b <= 0xbf) {
      n = b & 0x1f;
    } else if (b == 0xd9) {
      uint8_t v;
      if (!BigEndian(v)) return false;
      n = v;
    } else if (b == 0xda) {
      uint16_t v;
      if (!BigEndian(v)) return false;
      n = v;
    } else if (b == 0xdb) {
      uint32_t v;
      if (!BigEndian(v)) return false;
      n = v;
    } else {
      return false;
    }
    return Str(n, s);
  }

  bool Array(Json& out, uint64_t n, int depth) {
    out = Json(Json::value_t::array);
    auto& items = out.get_ref<Json::array_t&>();
    // Every element takes at least one byte: a damaged count cannot reserve more than that.
    items.reserve(std::min<uint64_t>(n, static_cast<uint64_t>(end_ - p_)));
    for (uint64_t i = 0; i < n; ++i) {
      items.emplace_back();
      if (!Value(items.back(), depth + 1)) return false;
    }
    return true;
  }

  bool Map(Json& out, uint64_t n, int depth) {
    out = Json(Json::value_t::object);
    auto& fields = out.get_ref<Json::object_t&>();
    fields.reserve(std::min<uint64_t>(n, static_cast<uint64_t>(end_ - p_) / 2));
    std::string key;
    for (uint64_t i = 0; i < n; ++i) {
      if (!Key(key)) return false;
      Json value;
      if (!Value(value, depth + 1)) return false;
      // ordered_map::emplace keeps the first of duplicate keys, as nlohmann's reader does.
      fields.emplace(key, std::move(value));
      key.clear();
    }
    return true;
  }

  bool Value(Json& out, int depth) {
    if (depth > kMaxMsgpackDepth || !Need(1)) return false;
    const uint8_t b = *p_++;
    if (b <= 0x7f) {
      out = static_cast<uint64_t>(b);
      return true;
    }
    if (b >= 0xe0) {
      out = static_cast<int64_t>(static_cast<int8_t>(b));
      return true;
    }
    if (b >= 0xa0 && b <= 0xbf) {
      out = Json(Json::value_t::string);
      return Str(b & 0x1f, out.get_ref<std::string&>());
    }
    if (b >= 0x90 && b <= 0x9f) return Array(out, b & 0x0f, depth);
    if (b >= 0x80 && b <= 0x8f) return Map(out, b & 0x0f, depth);
    switch (b) {
      case 0xc0:
        out = nullptr;
        return true;
      case 0xc2:
        out = false;
        return true;
      case 0xc3:
        out = true;
        return true;
      case 0xca: {
        uint32_t bits;
        if (!BigEndian(bits)) return false;
        out = static_cast<double>(std::bit_cast<float>(bits));
        return true;
      }
      case 0xcb: {
        uint64_t bits;
        if (!BigEndian(bits)) return false;
        out = std::bit_cast<double>(bits);
        return true;
      }
      case 0xcc: {
        uint8_t v;
        if (!BigEndian(v)) return false;
        out = uint64_t{v};
        return true;
      }
      case 0xcd: {
        uint16_t v;
        if (!BigEndian(v)) return false;
        out = uint64_t{v};
        return true;
      }
      case 0xce: {
        uint32_t v;
        if (!BigEndian(v)) return false;
        out = uint64_t{v};
        return true;
      }
      case 0xcf: {
        uint64_t v;
        if (!BigEndian(v)) return false;
        out = v;
        return true;
      }
      case 0xd0: {
        uint8_t v;
        if (!BigEndian(v)) return false;
        out = int64_t{static_cast<int8_t>(v)};
        return true;
      }
      case 0xd1: {
        uint16_t v;
        if (!BigEndian(v)) return false;
        out = int64_t{static_cast<int16_t>(v)};
        return true;
      }
      case 0xd2: {
        uint32_t v;
        if (!BigEndian(v)) return false;
        out = int64_t{static_cast<int32_t>(v)};
        return true;
      }
      case 0xd3: {
        uint64_t v;
        if (!BigEndian(v)) return false;
        out = static_cast<int64_t>(v);
        return true;
      }
      case 0xd9:
      case 0xda:
      case 0xdb: {
        --p_;
        out = Json(Json::value_t::string);
        return Key(out.get_ref<std::string&>());
      }
      case 0xdc: {
        uint16_t n;
        if (!BigEndian(n)) return false;
        return Array(out, n, depth);
      }
      case 0xdd: {
        uint32_t n;
        if (!BigEndian(n)) return false;
        return Array(out, n, depth);
      }
      case 0xde: {
        uint16_t n;
        if (!BigEndian(n)) return false;
        return Map(out, n, depth);
      }
      case 0xdf: {
        uint32_t n;
        if (!BigEndian(n)) return false;
        return Map(out, n, depth);
      }
      default:
        return false;  // bin, ext, reserved: never written for JSON values
    }
  }

  const uint8_t* p_;
  const uint8_t* end_;
};

}  // namespace

bool DecodeMsgpackJson(std::span<const uint8_t> bytes, Json& out) {
  MsgpackDecoder decoder(bytes.data(), bytes.data() + bytes.size());
  return decoder.DecodeAll(out);
}

}  // namespace mlspaces
