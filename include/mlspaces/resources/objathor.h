// The built-in objathor metadata (spec 8.2): MolmoSpaces' annotation store of THOR and
// Objaverse assets, read from the original's LMDB (zstd-compressed pickles) or built from the
// source files it is built from, and converted once into our stores:
//
//   <index_dir>/uid_index.mlsx + metadata.mlsm   every annotation (the dict, then its numpy
//                                                arrays clip_img_features / clip_text_features
//                                                as stored), read by the Registry
//   <index_dir>/clip_features.mlsc               the CLIP features (library/clip_store.h)
//
// with <index_dir> = <cache>/objects/objathor_metadata/<version>/.mlspaces/index, reachable as
// <assets>/objects/objathor_metadata/.mlspaces/index through the GLOBAL link. Pickles are read
// by the restricted reader (core/pickle.h); the LMDB is read in a child process, so a corrupt
// page that crashes liblmdb is a one-line Error naming the file and the last key read.
// Where and when this runs: docs/resources.md ("objathor metadata").
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "mlspaces/core/pickle.h"
#include "mlspaces/library/annotation.h"

namespace mlspaces {

/// The key the original writes last; the LMDB counts as complete only when it decodes to itself.
inline constexpr std::string_view kObjathorSentinel = "__LMDBMap__dump_complete__";
/// The library name objathor annotations report.
inline constexpr std::string_view kObjathorLibrary = "objathor_metadata";

// =============================================================================================
// Where it is

/// The objathor_metadata data of an assets dir.
struct MLSPACES_API ObjathorLocation {
  std::string version;               ///< the installed version
  std::filesystem::path source_dir;  ///< <assets>/objects/objathor_metadata
  std::filesystem::path lmdb_dir;    ///< <assets>/.lmdb/objathor_metadata/<version>
  std::filesystem::path index_dir;   ///< <source_dir>/.mlspaces/index (converted store)
};

/// Finds objathor_metadata under `assets`: the version is the one
/// <assets>/mjthor_data_type_to_source_to_versions.json pins ("objects" -> "objathor_metadata"),
/// else the name of the folder <assets>/objects/objathor_metadata links to. nullopt when
/// <assets>/objects/objathor_metadata does not exist. @throws Error for a bad versions file.
MLSPACES_API std::optional<ObjathorLocation> FindObjathor(const std::filesystem::path& assets);

// =============================================================================================
// Converting

/// What a conversion did.
struct MLSPACES_API ObjathorReport {
  size_t annotations = 0;    ///< UIDs written to metadata.mlsm
  size_t clip_features = 0;  ///< UIDs written to clip_features.mlsc
  std::string from;          ///< "lmdb <dir>" or "source files <dir>"
  bool converted = false;    ///< false: the store was already there (EnsureObjathorStore)
  std::filesystem::path index_dir;
};

/// Converts `where` into its index_dir: from the LMDB when it holds the sentinel, else from
/// the source files (objects_metadata.json.gz + clip_features.pkl, whose counts must agree:
/// "# clip entries N != # annotation entries M"). Written to a temp folder and renamed into
/// place under the lock <index_dir>/../objathor.lock (a store already there is replaced); the
/// output is byte-identical for the same input. @throws Error naming the file and key.
MLSPACES_API ObjathorReport ConvertObjathor(const ObjathorLocation& where);

/// Converts when objathor_metadata is installed under `assets` and its store is missing or
/// stale (what `meta`, the Registry's users and Python ObjectMeta call first): a store counts
/// only with its marker <index_dir>/objathor_source.json (store format, "lmdb" or "source
/// files", and the size and mtime of each input file) matching the input as it is now, so a
/// store an older index-builtin made from the tries, or one from older input, is rebuilt.
/// Concurrent callers wait for one conversion. nullopt when objathor_metadata is not installed.
/// @throws Error.
MLSPACES_API std::optional<ObjathorReport> EnsureObjathorStore(const std::filesystem::path& assets);

// =============================================================================================
// Reading the original's files (the steps of a conversion; also for tests)

/// Calls on_entry(key, value) for every entry of the LMDB in `lmdb_dir` (data.mdb), in key
/// order, the sentinel included. liblmdb runs in a forked child (read-only, no lock file)
/// that streams the entries back, killed past a time limit (60 s + 1 s per 10 MB of data.mdb:
/// a corrupt page can make liblmdb loop). @throws Error naming data.mdb for a file liblmdb
/// rejects, a child that crashed or ran past the limit (with the last key read) or an
/// exception of on_entry.
MLSPACES_API void ReadLmdbEntries(
    const std::filesystem::path& lmdb_dir,
    const std::function<void(std::string_view key, std::string_view value)>& on_entry);

/// One LMDB value: a zstd frame (at most 256 MiB decompressed) holding a pickle.
/// @throws Error naming `file` and `key`.
MLSPACES_API PickleValue DecodeLmdbValue(std::string_view value, const std::string& file,
                                         const std::string& key);

/// An annotation from a decoded dict with str keys: every non-scalar numpy array that is the
/// value of a dict key (at any depth of dicts) becomes Annotation::arrays at its JSON pointer,
/// in order; everything else becomes JSON (tuples and arrays inside lists as lists, numpy
/// scalars as numbers). @throws Error (source, pointer, uid) for bytes or non-str dict keys.
MLSPACES_API Annotation AnnotationFromPickle(PickleValue value, const std::string& uid,
                                             const std::string& library, const std::string& source);

}  // namespace mlspaces
