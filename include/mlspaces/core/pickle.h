// A restricted reader of Python pickles (protocols 2-5): plain data and numpy arrays only.
//
// It decodes what `pickle.dumps` writes for None, bool, int, float, str, bytes, bytearray,
// list, tuple, dict and numpy arrays / scalars into a value tree, and nothing else. It never
// runs code: the only globals it accepts are the few numpy and the codecs module name to
// rebuild arrays, scalars and dtypes (kPickleAllowedGlobals), and each is interpreted here,
// by shape, not called. Any other global, a REDUCE of anything else, BUILD on anything but a
// numpy array or dtype, NEWOBJ/INST/OBJ, persistent ids, extension codes, sets and
// out-of-band buffers are errors. Every length is checked against the remaining input before
// anything is allocated, and nesting, memo size and output size are bounded (PickleLimits),
// so a truncated or hostile pickle is an Error, never a crash or a huge allocation.
// Why this subset, and what numpy 1.x and 2.x emit: docs/formats.md ("Pickles").
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mlspaces/core/npy.h"

namespace mlspaces {

/// "module.name" of every global a pickle may name (numpy 1.x `numpy.core`, 2.x `numpy._core`;
/// protocol 2 names Python 3's builtins `__builtin__`).
inline constexpr std::string_view kPickleAllowedGlobals[] = {
    "numpy.core.multiarray._reconstruct",
    "numpy._core.multiarray._reconstruct",
    "numpy.ndarray",
    "numpy.dtype",
    "numpy.core.multiarray.scalar",
    "numpy._core.multiarray.scalar",
    "numpy.core.numeric._frombuffer",
    "numpy._core.numeric._frombuffer",
    "_codecs.encode",
    "builtins.bytes",  // bytes() for b'' (protocol 2)
    "__builtin__.bytes",
    "builtins.bytearray",  // bytearray(bytes) (protocols 2-4)
    "__builtin__.bytearray",
};

struct PickleEntry;

/// One decoded value. A plain tree (shared references in the pickle are copied), owned by
/// value; only the members of its kind are meaningful.
// NOLINTNEXTLINE(bugprone-exception-escape): flags the implicit special members
struct MLSPACES_API PickleValue {
  enum class Kind : uint8_t {
    kNone,
    kBool,
    kInt,
    kFloat,
    kStr,
    kBytes,
    kByteArray,
    kList,
    kTuple,
    kDict,
    kArray
  };
  Kind kind = Kind::kNone;
  bool boolean = false;              ///< kBool
  int64_t integer = 0;               ///< kInt (a Python int beyond int64 is an Error)
  double real = 0;                   ///< kFloat
  std::string text;                  ///< kStr (UTF-8), kBytes, kByteArray
  std::vector<PickleValue> items;    ///< kList, kTuple
  std::vector<PickleEntry> entries;  ///< kDict, insertion order
  NpyArray array;                    ///< kArray: converted to native byte order and C order
  bool fortran_order = false;        ///< kArray: the pickled array was Fortran-ordered
  bool numpy_scalar = false;         ///< kArray: a numpy scalar (np.float32(1.5)); shape ()

  /// The value of a str key of a dict, or nullptr (also for a non-dict).
  const PickleValue* Find(std::string_view key) const;
  /// "None", "bool", "int", "float", "str", "bytes", "bytearray", "list", "tuple", "dict",
  /// "ndarray".
  static const char* KindName(Kind kind);
};

/// One key: value of a dict.
struct MLSPACES_API PickleEntry {
  PickleValue key, value;
};

/// Bounds on what one pickle may make; exceeding one is an Error.
struct MLSPACES_API PickleLimits {
  size_t max_depth = 200;             ///< nesting of containers (and of marks)
  size_t max_memo = size_t{1} << 20;  ///< memo entries
  /// Bytes of the decoded tree (values, strings, array data), shared references counted each
  /// time they are copied.
  uint64_t max_output_bytes = uint64_t{256} << 20;
};

/// Decodes one pickle (PROTO 2..5 first, STOP last, nothing after it). `source` (the file)
/// and `key` (e.g. the LMDB key) name the input in errors; messages give the opcode and its
/// byte offset. @throws Error for anything outside the subset, truncation or a broken limit.
MLSPACES_API PickleValue ParsePickle(std::span<const uint8_t> bytes, const std::string& source,
                                     const std::string& key = {}, const PickleLimits& limits = {});

}  // namespace mlspaces
