// MessagePack -> JSON, for the subset nlohmann::to_msgpack writes for JSON values: what the
// packed metadata store (metadata.mlsm) holds for each asset's metadata JSON.
//
// A small direct decoder that builds the ordered Json in place (about two allocations per
// value): bounds-checked, depth-limited, never reads outside its input. Public so the store
// writer (resources) can check what it encodes and the fuzz targets (fuzz/) can reach it.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <span>

#include "mlspaces/core/json.h"

namespace mlspaces {

/// Deepest nesting of arrays and maps the decoder accepts.
inline constexpr int kMaxMsgpackDepth = 256;

/// Decodes one value that must span all of `bytes` into `out`. Returns false on any
/// malformation (truncated, trailing bytes, bin/ext types, non-string map keys, nesting
/// deeper than kMaxMsgpackDepth); `out` then holds a partial value. Never throws but
/// std::bad_alloc. Of duplicate map keys the first is kept, as nlohmann's reader does.
MLSPACES_API bool DecodeMsgpackJson(std::span<const uint8_t> bytes, Json& out);

}  // namespace mlspaces
