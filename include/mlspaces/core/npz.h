// NumPy .npz archives (zip files of .npy members), read through a memory map.
//
// Members may be STORED (np.savez) or DEFLATEd (np.savez_compressed); ZIP64 records as
// numpy writes them are understood. Every offset and size is bounds-checked: a truncated or
// corrupt archive raises mlspaces::Error naming the file and member, never crashes.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mlspaces/core/npy.h"

namespace mlspaces {

/// An open .npz. Opening maps the file and reads the zip central directory only.
class MLSPACES_API NpzReader {
 public:
  // ===========================================================================================
  // Construction

  /// @throws Error if the file is missing or not a valid zip.
  explicit NpzReader(const std::filesystem::path& path);
  ~NpzReader();
  NpzReader(NpzReader&&) noexcept;
  NpzReader& operator=(NpzReader&&) noexcept;
  NpzReader(const NpzReader&) = delete;
  NpzReader& operator=(const NpzReader&) = delete;

  // ===========================================================================================
  // Contents

  /// The path the reader was opened with; valid while the reader lives.
  const std::filesystem::path& path() const;
  /// Array names: member names with a trailing ".npy" removed, in archive order.
  std::vector<std::string> keys() const;
  bool Contains(std::string_view key) const;
  // ===========================================================================================
  // Reading (the arrays returned are copies, owned by the caller)

  /// Header of one array; for STORED members no data is read.
  /// @throws Error if the key is absent or the member is corrupt.
  NpyHeader ReadHeader(std::string_view key) const;
  /// One whole array. @throws Error as above.
  NpyArray Read(std::string_view key) const;
  /// Rows `rows` (indices along axis 0, in the given order, repeats allowed) of one array,
  /// reading only those rows where the member is STORED and C-ordered.
  /// @throws Error if an index is out of range or the array is 0-d.
  NpyArray ReadRows(std::string_view key, const std::vector<size_t>& rows) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads every array of an .npz, in archive order.
MLSPACES_API std::vector<std::pair<std::string, NpyArray>> ReadNpz(
    const std::filesystem::path& path);

struct MLSPACES_API NpzWriteOptions {
  bool compress = false;  ///< DEFLATE like np.savez_compressed, else STORED like np.savez
  NpyWriteOptions npy;
};

/// Writes an .npz atomically; names get ".npy" appended. numpy's np.load reads the result.
MLSPACES_API void WriteNpz(const std::filesystem::path& path,
                           const std::vector<std::pair<std::string, NpyArray>>& arrays,
                           const NpzWriteOptions& options = {});

}  // namespace mlspaces
