// libFuzzer target: the restricted pickle reader (src/core/pickle.cc). It may reject input
// only with mlspaces::Error, must never read outside its input, recurse without bound or
// allocate past its limits, and whatever it accepts must be a tree within those limits.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "mlspaces/core/error.h"
#include "mlspaces/core/pickle.h"

namespace {

size_t Depth(const mlspaces::PickleValue& v) {
  size_t d = 0;
  for (const auto& item : v.items) d = std::max(d, Depth(item));
  for (const auto& [k, x] : v.entries) d = std::max({d, Depth(k), Depth(x)});
  return d + 1;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mlspaces::PickleLimits limits;
  limits.max_output_bytes = 64 << 20;  // within the fuzzer's RSS limit
  try {
    const mlspaces::PickleValue v =
        mlspaces::ParsePickle(std::span<const uint8_t>(data, size), "fuzz.pkl", "", limits);
    if (Depth(v) > limits.max_depth + 2) std::abort();
    if (v.kind == mlspaces::PickleValue::Kind::kArray &&
        v.array.data.size() != v.array.num_elements() * mlspaces::DTypeSize(v.array.dtype)) {
      std::abort();
    }
  } catch (const mlspaces::Error&) {}
  return 0;
}
