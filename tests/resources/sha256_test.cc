#include "mlspaces/resources/sha256.h"

#include "test_util.h"

namespace mlspaces {
namespace {

using testing::TempDir;

TEST(Sha256, KnownVectors) {
  // FIPS 180-2 test vectors.
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, IncrementalEqualsOneShot) {
  Sha256 hash;
  for (int i = 0; i < 1000; ++i) hash.Update(std::string(1000, 'a'));
  EXPECT_EQ(hash.HexDigest(), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  EXPECT_THROW(hash.Update("x"), std::logic_error);
}

TEST(Sha256, FileDigest) {
  TempDir dir;
  // Larger than the 1 MiB read block, so the loop runs more than once.
  const std::string data(3 * 1024 * 1024 + 17, 'a');
  testing::WriteText(dir / "f.bin", data);
  const FileDigest d = Sha256File(dir / "f.bin");
  EXPECT_EQ(d.size, data.size());
  EXPECT_EQ(d.sha256, Sha256Hex(data));
  testing::WriteText(dir / "empty", "");
  EXPECT_EQ(Sha256File(dir / "empty").sha256, Sha256Hex(""));
  EXPECT_EQ(Sha256File(dir / "empty").size, 0u);
}

TEST(Sha256, MissingFileIsAnError) {
  TempDir dir;
  testing::ExpectError([&] { Sha256File(dir / "missing.bin"); },
                       {(dir / "missing.bin").string(), "cannot open"});
}

}  // namespace
}  // namespace mlspaces
