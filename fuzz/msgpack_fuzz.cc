// libFuzzer target: the metadata store's MessagePack decoder (src/library/msgpack.cc). It
// must never read outside its input or recurse without bound, and whatever it accepts must
// survive nlohmann's encoder and decode again.
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "mlspaces/library/msgpack.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlspaces;
  Json value;
  if (!DecodeMsgpackJson(std::span<const uint8_t>(data, size), value)) return 0;
  const std::vector<uint8_t> again = Json::to_msgpack(value);
  Json back;
  if (!DecodeMsgpackJson(again, back)) std::abort();
  return 0;
}
