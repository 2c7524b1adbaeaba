// libFuzzer target: the .npy parser (src/core/npy.cc). Any input is either an Error or an
// array that serialises and parses back to the same dtype, shape and bytes.
#include <cstdint>
#include <cstdlib>
#include <span>

#include "mlspaces/core/error.h"
#include "mlspaces/core/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlspaces;
  const std::span<const uint8_t> bytes(data, size);
  try {
    ParseNpyHeader(bytes, "fuzz.npy");
  } catch (const Error&) {}
  NpyArray array;
  try {
    array = ParseNpy(bytes, "fuzz.npy");
  } catch (const Error&) {
    return 0;
  }
  if (array.data.size() != array.num_elements() * DTypeSize(array.dtype)) std::abort();
  for (size_t i = 0; i < array.num_elements() && i < 64; ++i) (void)array.AsDouble(i);
  const std::string again = SerializeNpy(array);
  const NpyArray back =
      ParseNpy({reinterpret_cast<const uint8_t*>(again.data()), again.size()}, "fuzz-again.npy");
  if (back.dtype != array.dtype || back.shape != array.shape || back.data != array.data) {
    std::abort();
  }
  return 0;
}
