// libFuzzer target: the tries reader of MolmoSpaces-format sources (src/resources/
// molmo_tries.cc): gzip bytes of JSON {archive: nested path trie}, as a remote serves them.
// The input is the raw file (fuzz/make_corpus.cc writes gzip seeds of real tries shapes).
// Whatever the bytes, ParseTries must return tries or throw an Error; the archive indexes and
// lookups built on what it returns must then answer without failing.
#include <cstdint>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/resources/molmo_remote.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mlspaces;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  SourceTries tries;
  try {
    tries = ParseTries(bytes, "fuzz.json.gz");
  } catch (const Error&) {
    return 0;
  }
  const ArchiveIndex substring(ArchiveIndexKind::kSubstring, tries.archives);
  const ArchiveIndex numeric(ArchiveIndexKind::kNumeric, tries.archives);
  (void)substring.Unindexed(tries.archives);
  (void)numeric.Unindexed(tries.archives);
  for (size_t a = 0; a < tries.archives.size() && a < 64; ++a) {
    if (tries.Find(tries.archives[a]) != a) __builtin_trap();  // names are sorted and unique
    (void)substring.Candidates(tries.archives[a]);
    (void)numeric.Candidates(tries.archives[a]);
    for (const std::string& file : tries.files[a]) {
      const auto owner = tries.ArchiveOf(file);
      if (!owner || *owner > a) __builtin_trap();  // the first archive holding it owns it
      for (const std::string& token : SplitQueryTokens(file)) (void)substring.QueryToken(token);
    }
  }
  return 0;
}
