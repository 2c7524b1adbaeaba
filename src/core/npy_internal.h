// Private helpers shared by npy.cc and npz.cc.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "mlspaces/core/npy.h"

namespace mlspaces::internal {

/// ParseNpyHeader with errors split into file `path` and zip member `member` (may be empty).
NpyHeader ParseNpyHeader(std::span<const uint8_t> bytes, const std::string& path,
                         const std::string& member);

/// Converts header.data_bytes() bytes of file data at `src` (byte order and memory order as
/// the header says) to native little-endian C order at `dst`. Bools become 0/1.
void ConvertToNative(const NpyHeader& header, const uint8_t* src, uint8_t* dst);

/// The array of a whole .npy image `bytes` whose parsed header is `header` and whose data size
/// has been checked against it: its data converted with ConvertToNative.
NpyArray ToNativeArray(NpyHeader header, std::span<const uint8_t> bytes);

/// Swaps the bytes of `count` elements of `item_size` bytes in place (no-op for size 1).
void SwapBytes(uint8_t* data, size_t count, size_t item_size);

/// Makes bool bytes 0 or 1.
void NormalizeBools(uint8_t* data, size_t count);

}  // namespace mlspaces::internal
