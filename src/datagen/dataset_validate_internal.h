// Internal to validate-dataset (dataset_validate.h): the Validator and the HDF5 helpers its
// checks share. The checks are spread over dataset_validate.cc (the walk over the folder),
// dataset_validate_child.cc (crash isolation in a child process), dataset_validate_hdf5.cc
// (HDF5 reading helpers), dataset_validate_traj.cc (trajectory checks) and
// dataset_validate_video.cc (camera and video checks).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hdf5_util.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/strings.h"
#include "mlspaces/datagen/dataset_schema.h"
#include "mlspaces/datagen/dataset_validate.h"

namespace mlspaces::datagen::dataset_check {
namespace fs = std::filesystem;
using h5::Handle;

// A dataset bigger than this is not read (a corrupt shape must not exhaust memory); real ones
// are a few MiB.
constexpr double kMaxDatasetBytes = double{1 << 30};

inline bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}
inline bool EndsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

/// `what`, with the innermost message of this thread's HDF5 error stack (the cause, e.g.
/// "file signature not found") in parentheses.
std::string HdfMessage(const std::string& what);

std::string Shape(const std::vector<hsize_t>& dims);

/// numpy-like name of an HDF5 type: "uint8", "float32", "enum(int8)", "string", ...
std::string TypeName(hid_t type);

bool IsUint8(hid_t type);

bool IsNumeric(hid_t type);

/// Up to 60 bytes of `text`, quoted, non-printable bytes as \xNN.
std::string Snippet(std::string_view text);

/// Python's json.loads accepts NaN, Infinity and -Infinity (DumpJsonCompactSorted writes them
/// for non-finite floats); nlohmann does not. Replaces them by 0 outside strings.
std::string PythonJsonToStrict(std::string_view text);

/// Parses Python-flavoured JSON; nullopt if invalid.
std::optional<FlatJson> ParsePythonJson(std::string_view text);

/// Whether `rel` ('/'-separated, relative) exists below `loc`, checking each prefix in turn (so
/// a missing intermediate group is "no", not an HDF5 error).
bool Exists(hid_t loc, const std::string& rel);

/// Names of the links in group `loc` (sorted by name); `recursive`: every path below it.
std::optional<std::vector<std::string>> ListLinks(hid_t loc, bool recursive);

/// An open dataset with its type and shape.
struct Ds {
  std::string path;  // for messages: "traj_0/obs/agent/qpos"
  Handle id, type;
  std::vector<hsize_t> dims;
  size_t elements() const {
    size_t n = 1;
    for (hsize_t d : dims) n *= static_cast<size_t>(d);
    return n;
  }
};

/// What one trajectory's checks share.
struct Traj {
  hid_t g = H5I_INVALID_HID;
  std::string name;  // "traj_3"
  int64_t k = 0;
  int64_t t = -1;                                    // T, -1 if unknown
  std::string t_source;                              // where T comes from
  std::map<std::string, std::vector<int8_t>> flags;  // success, fail, terminated, truncated
};

/// Checks a folder into a DatasetReport (see ValidateDataset).
class Validator {
 public:
  explicit Validator(DatasetReport& report) : report_(report) {}

  void Run(const fs::path& dir);

 private:
  static std::string Key(const fs::path& p);

  void Add(const std::string& file, const std::string& path, const std::string& message);
  void Add(const std::string& path, const std::string& message) { Add(file_, path, message); }

  void MarkIncomplete(const fs::path& dir);

  // -------------------------------------------------------------------------------------------
  // Crash isolation: HDF5 (1.10) can crash on corrupt metadata (e.g. an out-of-bounds read of
  // a damaged global heap), so each file is checked in a child process that sends its findings
  // back through a pipe; a crash becomes a problem of that file.

  static void Put(std::string& out, const std::string& s);
  static bool Get(std::string_view& in, std::string& s);
  static bool GetInt(std::string_view& in, int64_t& v);

  /// What File() found since `first_problem`, serialized for the parent.
  std::string Serialize(size_t first_problem, int64_t trajectories, int64_t videos) const;

  bool Deserialize(std::string_view in);

  /// File(p) in a child process (in this one if fork or pipe fail).
  void FileIsolated(const fs::path& p);

  // -------------------------------------------------------------------------------------------
  // One file

  void File(const fs::path& p);

  // -------------------------------------------------------------------------------------------
  // Dataset helpers

  /// Opens dataset `rel` below `loc`; nullopt (with a problem when `required` or when it
  /// exists but cannot be opened as a dataset) otherwise.
  std::optional<Ds> Open(hid_t loc, const std::string& base, const std::string& rel, bool required);

  /// Checks the first dimension is T.
  bool Rows(const Ds& ds, const Traj& t);

  /// Reads a whole dataset as `mem_type` into `buf` (sized by the caller).
  bool Read(const Ds& ds, hid_t mem_type, void* buf);

  /// A numeric dataset is readable to its end (catches corrupt chunks).
  void ReadNumeric(const Ds& ds);

  /// uint8 (T, L) rows, each a zero-padded JSON text (`objects`: a JSON object).
  void JsonRows(const Ds& ds, const Traj& t, bool objects);

  /// A string dataset or attribute's text (fixed or variable length); nullopt after a problem.
  std::optional<std::string> ReadString(hid_t obj, bool attribute, const std::string& path);

  // -------------------------------------------------------------------------------------------
  // One trajectory

  void CheckTraj(hid_t file, const std::string& name, int64_t k);

  /// Calls `fn` for every dataset below group `rel` of the trajectory (none if it is absent).
  template <class Fn>
  void VisitDatasets(const Traj& t, const std::string& rel, Fn&& fn) {
    if (!Exists(t.g, rel)) return;
    const std::string base = t.name + "/" + rel;
    Handle g(H5Gopen2(t.g, rel.c_str(), H5P_DEFAULT), H5Gclose);
    if (g.get() < 0) {
      Add(base, HdfMessage("expected a group"));
      return;
    }
    const auto names = ListLinks(g.get(), true);
    if (!names) {
      Add(base, HdfMessage("cannot list the group"));
      return;
    }
    for (const std::string& n : *names) {
      Handle obj(H5Oopen(g.get(), n.c_str(), H5P_DEFAULT), H5Oclose);
      if (obj.get() < 0) {
        Add(base + "/" + n, HdfMessage("cannot open"));
        continue;
      }
      if (H5Iget_type(obj.get()) != H5I_DATASET) continue;
      obj.Close();
      if (auto ds = Open(g.get(), base, n, true)) fn(*ds);
    }
  }

  /// The datasets `required` exist below `rel` and every dataset there is JSON-object rows.
  template <class Names>
  void JsonGroup(const Traj& t, const std::string& rel, const Names& required) {
    for (const char* name : required) {
      if (!Exists(t.g, rel + "/" + name)) Add(t.name + "/" + rel + "/" + name, "missing");
    }
    VisitDatasets(t, rel, [&](const Ds& ds) { JsonRows(ds, t, true); });
  }

  void Bools(Traj& t, const std::string& flag);

  void FlagConsistency(const Traj& t);

  void ObsScene(const Traj& t);

  void Provenance(const Traj& t);

  // -------------------------------------------------------------------------------------------
  // Cameras and videos

  void Cameras(const Traj& t);

  void Video(const Traj& t, const Ds& ds, const std::string& name,
             const std::optional<std::pair<int, int>>& image);

  DatasetReport& report_;
  std::string file_;                               // the HDF5 file being checked
  fs::path dir_;                                   // its folder (videos live there)
  std::map<std::string, std::string> video_refs_;  // video file -> "file: path" naming it
  std::set<std::string> incomplete_dirs_;          // folders whose videos may be unreferenced
  // What File() added to the two above (sent back from the child process).
  std::vector<std::pair<std::string, std::string>> added_refs_;
  std::vector<std::string> added_incomplete_;
};

}  // namespace mlspaces::datagen::dataset_check
