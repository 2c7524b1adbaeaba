// libFuzzer target: the .npz reader (src/core/npz.cc): zip directory, ZIP64 records, STORED
// and DEFLATEd members, row reads. NpzReader maps a file, so each input is written to a
// scratch file first.
#include <cstdint>
#include <vector>

#include "fuzz_util.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/npz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlspaces;
  const std::filesystem::path path = fuzz::ScratchDir() / "input.npz";
  fuzz::WriteBytes(path, data, size);
  try {
    NpzReader reader(path);
    for (const std::string& key : reader.keys()) {
      try {
        const NpyHeader header = reader.ReadHeader(key);
        const NpyArray array = reader.Read(key);
        if (array.shape != header.shape || array.dtype != header.dtype) std::abort();
        if (!header.shape.empty() && header.shape[0] > 0) {
          const std::vector<size_t> rows = {header.shape[0] - 1, 0, header.shape[0] - 1};
          const NpyArray some = reader.ReadRows(key, rows);
          if (some.shape.empty() || some.shape[0] != rows.size()) std::abort();
        }
      } catch (const Error&) {}
    }
  } catch (const Error&) {}
  return 0;
}
