// The restricted pickle reader (include/mlspaces/core/pickle.h). Objects live in an arena and
// refer to each other by index, so cycles and deep chains built through the memo can neither
// leak nor overflow the stack; the value tree is copied out at STOP under the depth and size
// limits.
#include "mlspaces/core/pickle.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <unordered_map>

#include "mlspaces/core/error.h"
#include "pickle_internal.h"

namespace mlspaces {

const PickleValue* PickleValue::Find(std::string_view key) const {
  if (kind != Kind::kDict) return nullptr;
  for (const auto& [k, v] : entries) {
    if (k.kind == Kind::kStr && k.text == key) return &v;
  }
  return nullptr;
}

const char* PickleValue::KindName(Kind kind) {
  switch (kind) {
    case Kind::kNone:
      return "None";
    case Kind::kBool:
      return "bool";
    case Kind::kInt:
      return "int";
    case Kind::kFloat:
      return "float";
    case Kind::kStr:
      return "str";
    case Kind::kBytes:
      return "bytes";
    case Kind::kByteArray:
      return "bytearray";
    case Kind::kList:
      return "list";
    case Kind::kTuple:
      return "tuple";
    case Kind::kDict:
      return "dict";
    case Kind::kArray:
      return "ndarray";
  }
  return "?";
}

namespace pickle_internal {

/// Well-formed UTF-8 (no overlongs, no code points past U+10FFFF; surrogates, which Python's
/// pickle lets through, are refused: JSON cannot hold them).
bool ValidUtf8(std::string_view s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<uint8_t>(s[i]);
    size_t n = 0;
    uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xe0) == 0xc0) {
      n = 1, cp = c & 0x1f;
    } else if ((c & 0xf0) == 0xe0) {
      n = 2, cp = c & 0x0f;
    } else if ((c & 0xf8) == 0xf0) {
      n = 3, cp = c & 0x07;
    } else {
      return false;
    }
    if (n >= s.size() - i) return false;
    for (size_t k = 1; k <= n; ++k) {
      const auto d = static_cast<uint8_t>(s[i + k]);
      if ((d & 0xc0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3f);
    }
    static constexpr uint32_t kMin[] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[n] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return false;
    i += n + 1;
  }
  return true;
}

Global GlobalOf(std::string_view module, std::string_view name) {
  const std::string full = std::string(module) + "." + std::string(name);
  for (std::string_view allowed : kPickleAllowedGlobals) {
    if (full != allowed) continue;
    if (name == "_reconstruct") return Global::kReconstruct;
    if (name == "ndarray") return Global::kNdarray;
    if (name == "dtype") return Global::kDtype;
    if (name == "scalar") return Global::kScalar;
    if (name == "_frombuffer") return Global::kFrombuffer;
    if (name == "encode") return Global::kEncode;
    if (name == "bytes") return Global::kBytes;
    if (name == "bytearray") return Global::kByteArray;
  }
  return Global::kNone;
}

PickleValue Decoder::Run() {
  if (in_.size() < 2 || in_[0] != 0x80) {
    throw Error("pickle: not a protocol 2-5 pickle (no PROTO opcode at byte 0)", source_, key_);
  }
  while (!stopped_) {
    if (pos_ >= in_.size()) {
      op_pos_ = pos_;
      op_ = 0;
      Fail("truncated: no STOP opcode");
    }
    Step();
  }
  if (pos_ != in_.size()) {
    op_ = 0;
    op_pos_ = pos_;
    Fail(std::to_string(in_.size() - pos_) + " bytes after STOP");
  }
  ++At(stack_.back()).refs;
  return Materialize(stack_.back(), 0, true);
}

void Decoder::Step() {
  op_pos_ = pos_;
  op_ = *Take(1);
  switch (op_) {
    case 0x80: {  // PROTO
      const uint8_t proto = Read<uint8_t>();
      if (proto < 2 || proto > 5) Fail("unsupported pickle protocol " + std::to_string(proto));
      return;
    }
    case 0x95:  // FRAME: a length hint only
      CheckedLength(Read<uint64_t>());
      return;
    case '.':  // STOP
      if (!marks_.empty() || stack_.size() != 1) Fail("STOP with a stack of other than one value");
      stopped_ = true;
      return;
    case '(':
      MarkDepth();
      marks_.push_back(stack_.size());
      return;
    case '0':
      Pop();
      return;
    case '1':
      PopMark();
      return;
    case '2':
      Push(Top());
      return;
    case 'N':
      Push(NewValue({}));
      return;
    case 0x88:
    case 0x89: {  // NEWTRUE, NEWFALSE
      PickleValue v;
      v.kind = Kind::kBool;
      v.boolean = op_ == 0x88;
      Push(NewValue(std::move(v)));
      return;
    }
    case 'J':
    case 'K':
    case 'M': {  // BININT, BININT1, BININT2
      PickleValue v;
      v.kind = Kind::kInt;
      v.integer = op_ == 'J' ? Read<int32_t>() : op_ == 'K' ? Read<uint8_t>() : Read<uint16_t>();
      Push(NewValue(std::move(v)));
      return;
    }
    case 0x8a: {  // LONG1
      const uint8_t n = Read<uint8_t>();
      Push(LongFrom(Take(n), n));
      return;
    }
    case 0x8b: {  // LONG4
      const int32_t n = Read<int32_t>();
      if (n < 0) Fail("negative LONG4 length");
      Push(LongFrom(Take(CheckedLength(static_cast<uint64_t>(n))), static_cast<uint64_t>(n)));
      return;
    }
    case 'G': {  // BINFLOAT, big-endian
      const uint8_t* p = Take(8);
      uint64_t u = 0;
      for (int i = 0; i < 8; ++i) u = (u << 8) | p[i];
      PickleValue v;
      v.kind = Kind::kFloat;
      std::memcpy(&v.real, &u, sizeof u);
      Push(NewValue(std::move(v)));
      return;
    }
    case 0x8c:
      Push(Text(Kind::kStr, ReadString(Read<uint8_t>())));
      return;  // SHORT_BINUNICODE
    case 'X':
      Push(Text(Kind::kStr, ReadString(CheckedLength(Read<uint32_t>()))));
      return;
    case 0x8d:
      Push(Text(Kind::kStr, ReadString(CheckedLength(Read<uint64_t>()))));
      return;
    case 'C':
      Push(Text(Kind::kBytes, ReadString(Read<uint8_t>())));
      return;  // SHORT_BINBYTES
    case 'B':
      Push(Text(Kind::kBytes, ReadString(CheckedLength(Read<uint32_t>()))));
      return;
    case 0x8e:
      Push(Text(Kind::kBytes, ReadString(CheckedLength(Read<uint64_t>()))));
      return;
    case 0x96:  // BYTEARRAY8
      Push(Text(Kind::kByteArray, ReadString(CheckedLength(Read<uint64_t>()))));
      return;
    case ']':
      Push(New(Obj::Type::kList));
      return;
    case '}':
      Push(New(Obj::Type::kDict));
      return;
    case ')':
      Push(MakeTuple({}));
      return;
    case 0x85:
    case 0x86:
    case 0x87: {  // TUPLE1..3
      const size_t n = op_ - 0x84u;
      std::vector<uint32_t> items(n);
      for (size_t i = n; i-- > 0;) items[i] = Pop();
      Push(MakeTuple(std::move(items)));
      return;
    }
    case 't':
      Push(MakeTuple(PopMark()));
      return;
    case 'l': {  // LIST
      const uint32_t id = New(Obj::Type::kList);
      std::vector<uint32_t> items = PopMark();
      Append(id, items);
      Push(id);
      return;
    }
    case 'd': {  // DICT
      std::vector<uint32_t> items = PopMark();
      if (items.size() % 2 != 0) Fail("DICT with an odd number of items");
      const uint32_t id = New(Obj::Type::kDict);
      for (size_t i = 0; i < items.size(); i += 2) SetItem(id, items[i], items[i + 1]);
      Push(id);
      return;
    }
    case 'a': {  // APPEND
      const uint32_t item = Pop();
      Append(Top(), {item});
      return;
    }
    case 'e': {  // APPENDS
      std::vector<uint32_t> items = PopMark();
      Append(Top(), items);
      return;
    }
    case 's': {  // SETITEM
      const uint32_t value = Pop();
      const uint32_t k = Pop();
      SetItem(Top(), k, value);
      return;
    }
    case 'u': {  // SETITEMS
      std::vector<uint32_t> items = PopMark();
      if (items.size() % 2 != 0) Fail("SETITEMS with an odd number of items");
      const uint32_t dict = Top();
      for (size_t i = 0; i < items.size(); i += 2) SetItem(dict, items[i], items[i + 1]);
      return;
    }
    case 0x94:
      Memo(memo_.size(), Top());
      return;  // MEMOIZE
    case 'q':
      Memo(Read<uint8_t>(), Top());
      return;
    case 'r':
      Memo(Read<uint32_t>(), Top());
      return;
    case 'h':
      Push(Recall(Read<uint8_t>()));
      return;
    case 'j':
      Push(Recall(Read<uint32_t>()));
      return;
    case 'c': {  // GLOBAL "module\nname\n"
      const std::string module = ReadLine();
      const std::string name = ReadLine();
      const Global g = GlobalOf(module, name);
      if (g == Global::kNone) Fail("global " + module + "." + name + " is not allowed");
      const uint32_t id = New(Obj::Type::kGlobal);
      At(id).global = g;
      Push(id);
      return;
    }
    case 0x93: {  // STACK_GLOBAL
      const uint32_t name = Pop();
      const uint32_t module = Pop();
      if (StrOf(module) == nullptr || StrOf(name) == nullptr) Fail("STACK_GLOBAL of non-strings");
      const Global g = GlobalOf(*StrOf(module), *StrOf(name));
      if (g == Global::kNone)
        Fail("global " + *StrOf(module) + "." + *StrOf(name) + " is not allowed");
      const uint32_t id = New(Obj::Type::kGlobal);
      At(id).global = g;
      Push(id);
      return;
    }
    case 'R': {  // REDUCE
      const uint32_t args = Pop();
      const uint32_t callable = Pop();
      Push(Reduce(callable, args));
      return;
    }
    case 'b': {  // BUILD
      const uint32_t state = Pop();
      Build(Top(), state);
      return;
    }
    case 'P':
    case 'Q':
      Fail("persistent ids are not allowed");
    case 0x82:
    case 0x83:
    case 0x84:
      Fail("extension codes are not allowed");
    case 'i':
    case 'o':
    case 0x81:
    case 0x92:
      Fail("object construction (INST/OBJ/NEWOBJ) is not allowed");
    case 0x8f:
    case 0x90:
    case 0x91:
      Fail("sets are not supported");
    case 0x97:
    case 0x98:
      Fail("out-of-band buffers are not supported");
    default:
      Fail("unsupported opcode");
  }
}

}  // namespace pickle_internal

using pickle_internal::Decoder;

PickleValue ParsePickle(std::span<const uint8_t> bytes, const std::string& source,
                        const std::string& key, const PickleLimits& limits) {
  return Decoder(bytes, source, key, limits).Run();
}

}  // namespace mlspaces
