// NumPy .npy arrays: parse and write, for the dtypes mlspaces meets in libraries.
//
// Reading accepts format versions 1.0, 2.0 and 3.0; dtypes f2/f4/f8/i4/i8/u1/b1 with '<', '>',
// '|' or '=' byte order; C or Fortran order; 0-d to n-d. Loaded data is always converted to
// native (little-endian) byte order and C order, so callers index it one way.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace mlspaces {

enum class DType : uint8_t { kF2, kF4, kF8, kI4, kI8, kU1, kB1 };

/// Bytes per element of a dtype.
MLSPACES_API size_t DTypeSize(DType dtype);
/// The descr numpy writes for a little-endian array of this dtype: "<f8", "|u1", "|b1", ...
MLSPACES_API std::string DTypeDescr(DType dtype, bool big_endian = false);

/// Python's repr of a shape tuple, as numpy prints it: "()", "(3,)", "(2, 4)".
MLSPACES_API std::string ShapeRepr(const std::vector<size_t>& shape);

/// What a .npy header says.
struct MLSPACES_API NpyHeader {
  DType dtype = DType::kF8;
  bool big_endian = false;      ///< byte order in the file
  bool fortran_order = false;   ///< as stored in the file
  std::vector<size_t> shape;    ///< empty for a 0-d array
  size_t data_offset = 0;       ///< bytes from the start of the .npy to the data
  size_t num_elements() const;  ///< product of shape (1 for 0-d)
  size_t data_bytes() const { return num_elements() * DTypeSize(dtype); }
};

/// A loaded array: native byte order, C order.
struct MLSPACES_API NpyArray {
  DType dtype = DType::kF8;
  std::vector<size_t> shape;
  std::vector<uint8_t> data;  ///< num_elements() * DTypeSize(dtype) bytes

  size_t num_elements() const;
  /// Element i (flat, C order) converted to double (f2 exactly, i8 may round).
  double AsDouble(size_t i) const;
  /// All elements converted to double.
  std::vector<double> ToDoubles() const;

  /// Makes an f8 array of the given shape from values (C order).
  static NpyArray FromDoubles(std::vector<size_t> shape, std::span<const double> values);
  /// Makes an array of any dtype; values are converted (f2 rounds to nearest even).
  static NpyArray FromDoubles(DType dtype, std::vector<size_t> shape,
                              std::span<const double> values);
};

/// Options for writing.
struct MLSPACES_API NpyWriteOptions {
  bool big_endian = false;
  bool fortran_order = false;
};

/// Parses only the header from the first bytes of a .npy. `source` names the file (and zip
/// member) in errors. @throws Error on a bad magic, version, header dict, dtype or shape, or
/// when `bytes` is shorter than the header says.
MLSPACES_API NpyHeader ParseNpyHeader(std::span<const uint8_t> bytes, const std::string& source);

/// Parses a whole .npy image. @throws Error (also when the data is truncated or has extra
/// bytes missing).
MLSPACES_API NpyArray ParseNpy(std::span<const uint8_t> bytes, const std::string& source);

/// Serialises an array as .npy v1.0 (v2.0 if the header would not fit), header padded to a
/// multiple of 64 bytes as numpy does.
std::string SerializeNpy(const NpyArray& array, const NpyWriteOptions& options = {});

/// Reads a .npy file. @throws Error naming the file.
MLSPACES_API NpyArray ReadNpyFile(const std::string& path);
/// Writes a .npy file atomically.
void WriteNpyFile(const std::string& path, const NpyArray& array,
                  const NpyWriteOptions& options = {});

/// IEEE half <-> double conversions (round to nearest even).
MLSPACES_API double HalfToDouble(uint16_t h);
MLSPACES_API uint16_t DoubleToHalf(double d);
/// IEEE half -> float, exactly (normals, subnormals, infinities, NaNs), by bit operations.
MLSPACES_API float HalfToFloat(uint16_t h);

}  // namespace mlspaces
