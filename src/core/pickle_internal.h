// Private to the restricted pickle reader (src/core/pickle.cc, pickle_numpy.cc): the object
// arena and the decoder. Not installed; include/mlspaces/core/pickle.h is the interface.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/pickle.h"

namespace mlspaces::pickle_internal {

using Kind = PickleValue::Kind;

enum class Global : uint8_t {
  kNone,
  kReconstruct,
  kNdarray,
  kDtype,
  kScalar,
  kFrombuffer,
  kEncode,
  kBytes,
  kByteArray
};
/// Well-formed UTF-8 (no overlongs, no code points past U+10FFFF, no surrogates).
bool ValidUtf8(std::string_view s);
/// Which allowed global `module.name` is; kNone for any other.
Global GlobalOf(std::string_view module, std::string_view name);

/// An object under construction. Leaves and finished arrays keep their value in `value`.
struct Obj {
  enum class Type : uint8_t { kValue, kList, kTuple, kDict, kGlobal, kDtype, kArrayStub };
  Type type = Type::kValue;
  PickleValue value;                                   // kValue (leaves and arrays)
  std::vector<uint32_t> items;                         // kList, kTuple
  std::vector<std::pair<uint32_t, uint32_t>> entries;  // kDict
  std::unordered_map<std::string, size_t> key_index;   // kDict: canonical key -> entry
  Global global = Global::kNone;                       // kGlobal
  DType dtype = DType::kF8;                            // kDtype
  bool big_endian = false, built = false;              // kDtype (BUILD seen), kArrayStub
  /// Places in containers (and the result) that hold it: a value held once, under parents
  /// held once, is moved out instead of copied.
  uint32_t refs = 0;
};

class Decoder {
 public:
  Decoder(std::span<const uint8_t> bytes, const std::string& source, const std::string& key,
          const PickleLimits& limits)
      : in_(bytes), source_(source), key_(key), limits_(limits) {}

  PickleValue Run();

 private:
  [[noreturn]] void Fail(const std::string& message) const {
    std::string where = " at byte " + std::to_string(op_pos_);
    if (op_ != 0) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "0x%02x", op_);
      where += " (opcode " + std::string(buf) + ")";
    }
    throw Error("pickle: " + message + where, source_, key_);
  }

  // --- input -------------------------------------------------------------------------------
  const uint8_t* Take(uint64_t n) {
    if (n > in_.size() - pos_) {
      Fail("truncated: " + std::to_string(n) + " bytes needed, " +
           std::to_string(in_.size() - pos_) + " left");
    }
    const uint8_t* p = in_.data() + pos_;
    pos_ += n;
    return p;
  }
  template <class T>
  T Read() {
    T v;
    std::memcpy(&v, Take(sizeof v), sizeof v);
    return v;
  }
  std::string ReadString(uint64_t n) {
    const uint8_t* p = Take(n);
    return std::string(reinterpret_cast<const char*>(p), n);
  }
  std::string ReadLine() {
    const uint8_t* begin = in_.data() + pos_;
    const void* nl = std::memchr(begin, '\n', in_.size() - pos_);
    if (nl == nullptr) Fail("truncated: no end of line");
    const size_t n = static_cast<const uint8_t*>(nl) - begin;
    std::string line(reinterpret_cast<const char*>(begin), n);
    pos_ += n + 1;
    return line;
  }

  // --- objects -----------------------------------------------------------------------------
  uint32_t New(Obj::Type type) {
    if (arena_.size() >= std::numeric_limits<uint32_t>::max()) Fail("too many objects");
    arena_.push_back(std::make_unique<Obj>());
    arena_.back()->type = type;
    return static_cast<uint32_t>(arena_.size() - 1);
  }
  uint32_t NewValue(PickleValue value) {
    const uint32_t id = New(Obj::Type::kValue);
    arena_[id]->value = std::move(value);
    return id;
  }
  Obj& At(uint32_t id) { return *arena_[id]; }
  void Push(uint32_t id) { stack_.push_back(id); }
  uint32_t Pop() {
    if (stack_.size() <= Floor()) Fail("stack underflow");
    const uint32_t id = stack_.back();
    stack_.pop_back();
    return id;
  }
  uint32_t Top() {
    if (stack_.size() <= Floor()) Fail("stack underflow");
    return stack_.back();
  }
  size_t Floor() const { return marks_.empty() ? 0 : marks_.back(); }
  /// The items above the last mark, removed with the mark.
  std::vector<uint32_t> PopMark() {
    if (marks_.empty()) Fail("no mark on the stack");
    const size_t mark = marks_.back();
    marks_.pop_back();
    std::vector<uint32_t> items(stack_.begin() + static_cast<ptrdiff_t>(mark), stack_.end());
    stack_.resize(mark);
    return items;
  }
  void Memo(uint64_t index, uint32_t id) {
    if (memo_.size() >= limits_.max_memo && memo_.find(index) == memo_.end()) {
      Fail("memo holds more than " + std::to_string(limits_.max_memo) + " entries");
    }
    memo_[index] = id;
  }
  uint32_t Recall(uint64_t index) {
    auto it = memo_.find(index);
    if (it == memo_.end()) Fail("memo entry " + std::to_string(index) + " was never stored");
    return it->second;
  }

  const PickleValue* Leaf(uint32_t id) {
    const Obj& o = At(id);
    return o.type == Obj::Type::kValue ? &o.value : nullptr;
  }
  std::optional<int64_t> IntOf(uint32_t id) {
    const PickleValue* v = Leaf(id);
    if (v == nullptr) return std::nullopt;
    if (v->kind == Kind::kInt) return v->integer;
    if (v->kind == Kind::kBool) return v->boolean ? 1 : 0;
    return std::nullopt;
  }
  const std::string* StrOf(uint32_t id) {
    const PickleValue* v = Leaf(id);
    return v != nullptr && v->kind == Kind::kStr ? &v->text : nullptr;
  }
  const std::string* BytesOf(uint32_t id) {
    const PickleValue* v = Leaf(id);
    return v != nullptr && (v->kind == Kind::kBytes || v->kind == Kind::kByteArray) ? &v->text
                                                                                    : nullptr;
  }

  /// A hashable key's canonical form (Python's equal keys give equal strings); false for an
  /// unhashable value.
  bool KeyOf(uint32_t id, std::string& out, size_t depth) {
    if (depth > limits_.max_depth)
      Fail("dict key nested deeper than " + std::to_string(limits_.max_depth));
    const Obj& o = At(id);
    if (o.type == Obj::Type::kTuple) {
      out += "t(";
      for (uint32_t item : o.items) {
        if (!KeyOf(item, out, depth + 1)) return false;
        out += ',';
      }
      out += ')';
      return true;
    }
    if (o.type != Obj::Type::kValue) return false;
    const PickleValue& v = o.value;
    switch (v.kind) {
      case Kind::kNone:
        out += 'N';
        return true;
      case Kind::kBool:
        out += v.boolean ? "i1" : "i0";
        return true;
      case Kind::kInt:
        out += "i" + std::to_string(v.integer);
        return true;
      case Kind::kFloat:
        // An integral float equals the int (1.0 == 1); others compare by their bits.
        if (v.real > -9.2e18 && v.real < 9.2e18 && v.real == std::trunc(v.real)) {
          out += "i" + std::to_string(static_cast<int64_t>(v.real));
        } else {
          uint64_t bits;
          std::memcpy(&bits, &v.real, sizeof bits);
          out += "f" + std::to_string(bits);
        }
        return true;
      case Kind::kStr:
        out += "s" + std::to_string(v.text.size()) + ":" + v.text;
        return true;
      case Kind::kBytes:
        out += "b" + std::to_string(v.text.size()) + ":" + v.text;
        return true;
      default:
        return false;
    }
  }
  void SetItem(uint32_t dict, uint32_t key, uint32_t value) {
    Obj& d = At(dict);
    if (d.type != Obj::Type::kDict) Fail("SETITEM on a non-dict");
    std::string canonical;
    if (!KeyOf(key, canonical, 0)) Fail("unhashable dict key");
    auto [it, inserted] = d.key_index.try_emplace(std::move(canonical), d.entries.size());
    ++At(value).refs;
    if (inserted) {
      ++At(key).refs;
      d.entries.emplace_back(key, value);
    } else {
      --At(d.entries[it->second].second).refs;
      d.entries[it->second].second = value;  // Python keeps the first key and its place
    }
  }
  void Append(uint32_t list, const std::vector<uint32_t>& items) {
    Obj& l = At(list);
    if (l.type != Obj::Type::kList) Fail("APPEND on a non-list");
    for (uint32_t item : items) ++At(item).refs;
    l.items.insert(l.items.end(), items.begin(), items.end());
  }
  uint32_t MakeTuple(std::vector<uint32_t> items) {
    const uint32_t id = New(Obj::Type::kTuple);
    for (uint32_t item : items) ++At(item).refs;
    At(id).items = std::move(items);
    return id;
  }

  // --- numpy (pickle_numpy.cc) ------------------------------------------------------------
  std::optional<DType> DTypeNamed(const std::string& name);
  std::vector<size_t> ShapeOf(uint32_t id);
  /// `id` as a dtype that went through BUILD. @throws Error otherwise.
  const Obj& BuiltDtype(uint32_t id);
  /// A finished array from raw bytes in the pickled byte order and memory order.
  uint32_t MakeArray(const Obj& dtype, std::vector<size_t> shape, const std::string& data,
                     bool fortran, bool scalar);
  /// An allowed callable applied to its argument tuple. @throws Error for any other.
  uint32_t Reduce(uint32_t callable, uint32_t args_id);
  /// numpy's dtype and array states. @throws Error for anything else.
  void Build(uint32_t target, uint32_t state_id);

  uint32_t LongFrom(const uint8_t* p, uint64_t n) {
    int64_t v = 0;
    if (n > 0) {
      const bool negative = (p[n - 1] & 0x80) != 0;
      const uint8_t fill = negative ? 0xff : 0x00;
      for (uint64_t i = 8; i < n; ++i) {
        if (p[i] != fill) Fail("integer larger than 64 bits");
      }
      uint64_t u = negative ? ~uint64_t{0} : 0;
      for (uint64_t i = 0; i < n && i < 8; ++i) {
        u &= ~(uint64_t{0xff} << (8 * i));
        u |= uint64_t{p[i]} << (8 * i);
      }
      if (n > 8 && (((u >> 63) != 0) != negative)) Fail("integer larger than 64 bits");
      std::memcpy(&v, &u, sizeof v);
    }
    PickleValue out;
    out.kind = Kind::kInt;
    out.integer = v;
    return NewValue(std::move(out));
  }

  uint32_t Text(Kind kind, std::string s) {
    if (kind == Kind::kStr && !ValidUtf8(s)) Fail("str is not valid UTF-8");
    PickleValue v;
    v.kind = kind;
    v.text = std::move(s);
    return NewValue(std::move(v));
  }
  uint64_t CheckedLength(uint64_t n) {
    if (n > in_.size() - pos_) {
      Fail("declared length " + std::to_string(n) + " exceeds the " +
           std::to_string(in_.size() - pos_) + " bytes left");
    }
    return n;
  }

  void MarkDepth() {
    if (marks_.size() >= limits_.max_depth) {
      Fail("marks nested deeper than " + std::to_string(limits_.max_depth));
    }
  }

  // --- output ------------------------------------------------------------------------------
  void Charge(uint64_t bytes) {
    out_bytes_ += bytes;
    if (out_bytes_ > limits_.max_output_bytes) {
      op_ = 0;
      Fail("decoded value larger than " + std::to_string(limits_.max_output_bytes) + " bytes");
    }
  }
  PickleValue Materialize(uint32_t id, size_t depth, bool unique) {
    if (depth > limits_.max_depth) {
      op_ = 0;
      Fail("values nested deeper than " + std::to_string(limits_.max_depth));
    }
    Obj& o = At(id);
    unique = unique && o.refs == 1;
    Charge(sizeof(PickleValue));
    PickleValue out;
    switch (o.type) {
      case Obj::Type::kValue:
        Charge(o.value.text.size() + o.value.array.data.size());
        if (unique) return std::move(o.value);
        return o.value;
      case Obj::Type::kList:
      case Obj::Type::kTuple:
        out.kind = o.type == Obj::Type::kList ? Kind::kList : Kind::kTuple;
        out.items.reserve(o.items.size());
        for (uint32_t item : o.items) out.items.push_back(Materialize(item, depth + 1, unique));
        return out;
      case Obj::Type::kDict:
        out.kind = Kind::kDict;
        out.entries.reserve(o.entries.size());
        for (const auto& [k, v] : o.entries) {
          PickleValue key = Materialize(k, depth + 1, unique);
          out.entries.push_back(PickleEntry{std::move(key), Materialize(v, depth + 1, unique)});
        }
        return out;
      default:
        op_ = 0;
        Fail("the pickle holds a numpy type or callable, not a value");
    }
  }

  void Step();

  std::span<const uint8_t> in_;
  const std::string& source_;
  const std::string& key_;
  const PickleLimits& limits_;
  size_t pos_ = 0, op_pos_ = 0;
  uint8_t op_ = 0;
  bool stopped_ = false;
  std::vector<std::unique_ptr<Obj>> arena_;
  std::vector<uint32_t> stack_;
  std::vector<size_t> marks_;
  std::unordered_map<uint64_t, uint32_t> memo_;
  uint64_t out_bytes_ = 0;
};

}  // namespace mlspaces::pickle_internal
