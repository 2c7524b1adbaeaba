// libFuzzer target: the packed UID index and metadata store reader (src/library/
// packed_store.cc). Input: a 4-byte little-endian length N, then N bytes of uid_index.mlsx,
// then the rest as metadata.mlsm (fuzz/make_corpus.cc writes seeds in this form from stores
// the real writer produced). Every lookup on whatever opens must end in a value or an Error.
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>

#include "fuzz_util.h"
#include "mlspaces/core/error.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/library/packed_store.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlspaces;
  if (size < 4) return 0;
  uint32_t index_size;
  std::memcpy(&index_size, data, 4);
  data += 4;
  size -= 4;
  if (index_size > size) index_size = static_cast<uint32_t>(size);
  const std::filesystem::path dir = fuzz::ScratchDir();
  fuzz::WriteBytes(dir / std::string(kUidIndexFile), data, index_size);
  fuzz::WriteBytes(dir / std::string(kMetadataStoreFile), data + index_size, size - index_size);
  std::shared_ptr<const PackedLibrary> lib;
  try {
    lib = PackedLibrary::Open(dir, "fuzz");
  } catch (const Error&) {
    return 0;
  }
  try {
    (void)lib->robots();
    for (const std::string& archive : lib->archives()) (void)GraspShardMember(archive);
    const size_t n = lib->size() < 64 ? lib->size() : 64;
    for (size_t i = 0; i < n; ++i) {
      try {
        const PackedAsset asset = lib->At(i);
        const std::optional<PackedAsset> found = lib->Find(asset.uid);
        (void)found;
        for (const PackedGraspRef& ref : lib->Grasps(asset)) {
          (void)lib->FindGrasps(asset, ref.robot, ref.joint);
          (void)lib->GraspShardPath(ref.archive);
        }
        if (std::shared_ptr<const Annotation> a = lib->LoadAnnotation(asset)) (void)a->ToJson();
      } catch (const Error&) {}
    }
    (void)lib->Find("no such uid");
    lib->Check();
  } catch (const Error&) {}
  return 0;
}
