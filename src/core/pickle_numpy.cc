// The numpy half of the restricted pickle reader (include/mlspaces/core/pickle.h): the allowed
// callables (REDUCE) and numpy's BUILD states, turned into finished arrays.
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mlspaces/core/error.h"
#include "pickle_internal.h"

namespace mlspaces::pickle_internal {

std::optional<DType> Decoder::DTypeNamed(const std::string& name) {
  static constexpr std::pair<std::string_view, DType> kNames[] = {
      {"f2", DType::kF2}, {"f4", DType::kF4}, {"f8", DType::kF8}, {"i4", DType::kI4},
      {"i8", DType::kI8}, {"u1", DType::kU1}, {"b1", DType::kB1}};
  for (const auto& [n, d] : kNames) {
    if (name == n) return d;
  }
  return std::nullopt;
}

std::vector<size_t> Decoder::ShapeOf(uint32_t id) {
  const Obj& o = At(id);
  if (o.type != Obj::Type::kTuple) Fail("array shape is not a tuple");
  if (o.items.size() > 64) Fail("array has more than 64 dimensions");
  std::vector<size_t> shape;
  for (uint32_t item : o.items) {
    std::optional<int64_t> n = IntOf(item);
    if (!n || *n < 0) Fail("array shape holds a non-count");
    shape.push_back(static_cast<size_t>(*n));
  }
  return shape;
}

const Obj& Decoder::BuiltDtype(uint32_t id) {
  const Obj& o = At(id);
  if (o.type != Obj::Type::kDtype) Fail("expected a numpy dtype");
  return o;
}

/// A finished array from raw bytes in the pickled byte order and memory order.
uint32_t Decoder::MakeArray(const Obj& dtype, std::vector<size_t> shape, const std::string& data,
                            bool fortran, bool scalar) {
  const size_t item = DTypeSize(dtype.dtype);
  uint64_t count = 1;
  for (size_t d : shape) {
    if (d != 0 && count > std::numeric_limits<uint64_t>::max() / d) Fail("array too large");
    count *= d;
  }
  if (count > std::numeric_limits<uint64_t>::max() / item || count * item != data.size()) {
    Fail("array data holds " + std::to_string(data.size()) + " bytes, shape " + ShapeRepr(shape) +
         " of " + DTypeDescr(dtype.dtype) + " needs " + std::to_string(count * item));
  }
  PickleValue v;
  v.kind = Kind::kArray;
  v.numpy_scalar = scalar;
  v.fortran_order = fortran && shape.size() > 1;
  v.array.dtype = dtype.dtype;
  v.array.shape = shape;
  v.array.data.assign(data.begin(), data.end());
  if (dtype.big_endian && item > 1) {
    for (size_t i = 0; i < count; ++i) {
      uint8_t* p = v.array.data.data() + i * item;
      for (size_t a = 0, b = item - 1; a < b; ++a, --b) std::swap(p[a], p[b]);
    }
  }
  if (v.fortran_order) {  // to C order: element at C index i comes from its F index
    std::vector<uint8_t> c(v.array.data.size());
    const size_t nd = shape.size();
    std::vector<size_t> idx(nd, 0);
    for (size_t i = 0; i < count; ++i) {
      size_t f = 0, stride = 1;
      for (size_t d = 0; d < nd; ++d) {
        f += idx[d] * stride;
        stride *= shape[d];
      }
      std::memcpy(c.data() + i * item, v.array.data.data() + f * item, item);
      for (size_t d = nd; d-- > 0;) {
        if (++idx[d] < shape[d]) break;
        idx[d] = 0;
      }
    }
    v.array.data = std::move(c);
  }
  return NewValue(std::move(v));
}

uint32_t Decoder::Reduce(uint32_t callable, uint32_t args_id) {
  const Obj& f = At(callable);
  const Obj& a = At(args_id);
  if (f.type != Obj::Type::kGlobal) Fail("REDUCE of a non-allowed callable");
  if (a.type != Obj::Type::kTuple) Fail("REDUCE arguments are not a tuple");
  const std::vector<uint32_t> args = a.items;
  switch (f.global) {
    case Global::kEncode: {  // _codecs.encode(str, "latin1"): protocol-2 bytes
      if (args.size() != 2 || StrOf(args[0]) == nullptr || StrOf(args[1]) == nullptr ||
          (*StrOf(args[1]) != "latin1" && *StrOf(args[1]) != "latin-1")) {
        Fail("_codecs.encode takes (str, 'latin1') only");
      }
      const std::string& s = *StrOf(args[0]);
      PickleValue v;
      v.kind = Kind::kBytes;
      for (size_t i = 0; i < s.size(); ++i) {  // UTF-8 code points < 256 -> bytes
        const auto c = static_cast<uint8_t>(s[i]);
        if (c < 0x80) {
          v.text += static_cast<char>(c);
        } else if ((c == 0xc2 || c == 0xc3) && i + 1 < s.size()) {
          v.text += static_cast<char>(((c & 0x03) << 6) | (static_cast<uint8_t>(s[++i]) & 0x3f));
        } else {
          Fail("_codecs.encode: a character beyond latin-1");
        }
      }
      return NewValue(std::move(v));
    }
    case Global::kDtype: {  // numpy.dtype(name, False, True)
      if (args.size() != 3 || StrOf(args[0]) == nullptr)
        Fail("numpy.dtype takes (name, align, copy)");
      std::optional<DType> d = DTypeNamed(*StrOf(args[0]));
      if (!d) Fail("unsupported numpy dtype '" + *StrOf(args[0]) + "'");
      const uint32_t id = New(Obj::Type::kDtype);
      At(id).dtype = *d;
      return id;
    }
    case Global::kReconstruct: {  // _reconstruct(ndarray, (0,), b'b'), then BUILD
      if (args.size() != 3 || At(args[0]).type != Obj::Type::kGlobal ||
          At(args[0]).global != Global::kNdarray || At(args[1]).type != Obj::Type::kTuple ||
          BytesOf(args[2]) == nullptr) {
        Fail("_reconstruct takes (numpy.ndarray, shape, typecode)");
      }
      return New(Obj::Type::kArrayStub);
    }
    case Global::kScalar: {  // scalar(dtype, bytes)
      if (args.size() != 2 || BytesOf(args[1]) == nullptr) Fail("scalar takes (dtype, bytes)");
      const Obj& dtype = BuiltDtype(args[0]);
      return MakeArray(dtype, {}, *BytesOf(args[1]), false, true);
    }
    case Global::kFrombuffer: {  // _frombuffer(buffer, dtype, shape, order)
      if (args.size() != 4 || BytesOf(args[0]) == nullptr || StrOf(args[3]) == nullptr ||
          (*StrOf(args[3]) != "C" && *StrOf(args[3]) != "F")) {
        Fail("_frombuffer takes (buffer, dtype, shape, 'C' or 'F')");
      }
      const Obj& dtype = BuiltDtype(args[1]);
      return MakeArray(dtype, ShapeOf(args[2]), *BytesOf(args[0]), *StrOf(args[3]) == "F", false);
    }
    case Global::kBytes:  // bytes(): protocol 2's b''
      if (!args.empty()) Fail("bytes takes no arguments here");
      return Text(Kind::kBytes, {});
    case Global::kByteArray: {  // bytearray() or bytearray(bytes)
      if (args.size() > 1 || (args.size() == 1 && BytesOf(args[0]) == nullptr)) {
        Fail("bytearray takes () or (bytes,)");
      }
      return Text(Kind::kByteArray, args.empty() ? std::string() : *BytesOf(args[0]));
    }
    default:
      Fail("REDUCE of a non-allowed callable");
  }
}

void Decoder::Build(uint32_t target, uint32_t state_id) {
  Obj& t = At(target);
  const Obj& s = At(state_id);
  if (s.type != Obj::Type::kTuple) Fail("BUILD state is not a tuple");
  const std::vector<uint32_t> st = s.items;
  if (t.type == Obj::Type::kDtype && !t.built) {
    // (3, byteorder, subarray, names, fields, elsize, alignment, flags[, metadata])
    if (st.size() < 8 || st.size() > 9 || StrOf(st[1]) == nullptr) Fail("bad numpy dtype state");
    for (size_t i : {2, 3, 4}) {
      const PickleValue* v = Leaf(st[i]);
      if (v == nullptr || v->kind != Kind::kNone) Fail("structured numpy dtypes are not supported");
    }
    const std::string& order = *StrOf(st[1]);
    if (order != "<" && order != ">" && order != "|" && order != "=") Fail("bad dtype byte order");
    t.big_endian = order == ">";
    t.built = true;
    return;
  }
  if (t.type == Obj::Type::kArrayStub && !t.built) {
    // (version, shape, dtype, is_fortran, data)
    if (st.size() != 5) Fail("bad numpy array state");
    std::optional<int64_t> fortran = IntOf(st[3]);
    const std::string* data = BytesOf(st[4]);
    if (!fortran) Fail("bad numpy array state");
    if (data == nullptr) Fail("numpy arrays of Python objects are not supported");
    const std::vector<size_t> shape = ShapeOf(st[1]);
    const uint32_t id = MakeArray(BuiltDtype(st[2]), shape, *data, *fortran != 0, false);
    // The stub becomes the array in place, so memo references to it see the array.
    Obj& stub = At(target);
    stub.type = Obj::Type::kValue;
    stub.value = std::move(At(id).value);
    stub.built = true;
    return;
  }
  Fail("BUILD on anything but a numpy array or dtype");
}

}  // namespace mlspaces::pickle_internal
