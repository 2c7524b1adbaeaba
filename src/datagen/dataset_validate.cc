#include "mlspaces/datagen/dataset_validate.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <set>
#include <string_view>
#include <utility>

#include "hdf5_util.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/video.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
using h5::Handle;

std::string DatasetProblem::ToString() const {
  std::string out = file;
  if (!path.empty()) out += (out.empty() ? "" : ": ") + path;
  if (!message.empty()) out += (out.empty() ? "" : ": ") + message;
  return out;
}

namespace {

// A dataset bigger than this is not read (a corrupt shape must not exhaust memory); real ones
// are a few MiB.
constexpr double kMaxDatasetBytes = double{1 << 30};

// The datasets every trajectory has (docs/dataset.md).
const char* const kAgentDatasets[] = {"qpos", "qvel"};
const char* const kActionDatasets[] = {"commanded_action", "joint_pos", "joint_pos_rel",
                                       "ee_twist", "ee_pose"};
const char* const kBoolDatasets[] = {"success", "fail", "terminated", "truncated"};

bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}
bool EndsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

/// `what`, with the innermost message of this thread's HDF5 error stack (the cause, e.g.
/// "file signature not found") in parentheses.
std::string HdfMessage(const std::string& what) {
  std::string msg;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
        if (n == 0 && e->desc != nullptr) *static_cast<std::string*>(data) = e->desc;
        return 0;
      },
      &msg);
  return msg.empty() ? what : what + " (" + msg + ")";
}

std::string Shape(const std::vector<hsize_t>& dims) {
  std::string out = "(";
  for (size_t i = 0; i < dims.size(); ++i) {
    out += (i > 0 ? ", " : "") + std::to_string(dims[i]);
  }
  return out + (dims.size() == 1 ? ",)" : ")");
}

/// numpy-like name of an HDF5 type: "uint8", "float32", "enum(int8)", "string", ...
std::string TypeName(hid_t type) {
  const size_t bits = H5Tget_size(type) * 8;
  switch (H5Tget_class(type)) {
    case H5T_INTEGER:
      return (H5Tget_sign(type) == H5T_SGN_NONE ? "uint" : "int") + std::to_string(bits);
    case H5T_FLOAT:
      return "float" + std::to_string(bits);
    case H5T_ENUM: {
      Handle super(H5Tget_super(type), H5Tclose);
      return "enum(" + (super.get() >= 0 ? TypeName(super.get()) : std::string("?")) + ")";
    }
    case H5T_STRING:
      return "string";
    case H5T_COMPOUND:
      return "compound";
    case H5T_ARRAY:
      return "array";
    case H5T_VLEN:
      return "vlen";
    case H5T_BITFIELD:
      return "bitfield";
    case H5T_OPAQUE:
      return "opaque";
    case H5T_REFERENCE:
      return "reference";
    default:
      return "unknown type";
  }
}

bool IsUint8(hid_t type) {
  return H5Tget_class(type) == H5T_INTEGER && H5Tget_size(type) == 1 &&
         H5Tget_sign(type) == H5T_SGN_NONE;
}

bool IsNumeric(hid_t type) {
  const H5T_class_t c = H5Tget_class(type);
  return c == H5T_INTEGER || c == H5T_FLOAT || c == H5T_ENUM || c == H5T_BITFIELD;
}

/// Up to 60 bytes of `text`, quoted, non-printable bytes as \xNN.
std::string Snippet(std::string_view text) {
  std::string out = "\"";
  for (size_t i = 0; i < text.size() && i < 60; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  return out + (text.size() > 60 ? "\"…" : "\"");
}

/// `s` with control characters and bytes that are not UTF-8 written as \xNN (HDF5 names and
/// messages are bytes; a corrupt file can hold anything).
std::string Printable(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    size_t len = c < 0x80 ? 1 : (c >> 5) == 6 ? 2 : (c >> 4) == 14 ? 3 : (c >> 3) == 30 ? 4 : 0;
    bool ok = len > 0 && i + len <= s.size() && (len > 1 || (c >= 0x20 && c != 0x7f));
    for (size_t j = 1; ok && j < len; ++j) {
      ok = (static_cast<unsigned char>(s[i + j]) & 0xC0) == 0x80;
    }
    if (ok) {
      out.append(s.substr(i, len));
      i += len;
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
      ++i;
    }
  }
  return out;
}

/// Python's json.loads accepts NaN, Infinity and -Infinity (DumpJsonCompactSorted writes them
/// for non-finite floats); nlohmann does not. Replaces them by 0 outside strings.
std::string PythonJsonToStrict(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      out += c;
      if (c == '\\' && i + 1 < text.size()) {
        out += text[++i];
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
      out += c;
    } else if (text.compare(i, 3, "NaN") == 0) {
      out += '0';
      i += 2;
    } else if (text.compare(i, 8, "Infinity") == 0) {
      out += '0';
      i += 7;
    } else {
      out += c;
    }
  }
  return out;
}

/// Parses Python-flavoured JSON; nullopt if invalid.
std::optional<FlatJson> ParsePythonJson(std::string_view text) {
  FlatJson j = FlatJson::parse(PythonJsonToStrict(text), nullptr, false);
  if (j.is_discarded()) return std::nullopt;
  return j;
}

/// Whether `rel` ('/'-separated, relative) exists below `loc`, checking each prefix in turn (so
/// a missing intermediate group is "no", not an HDF5 error).
bool Exists(hid_t loc, const std::string& rel) {
  size_t end = 0;
  while (end != std::string::npos) {
    end = rel.find('/', end + 1);
    const std::string prefix = rel.substr(0, end);
    if (H5Lexists(loc, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return true;
}

/// Names of the links in group `loc` (sorted by name); `recursive`: every path below it.
std::optional<std::vector<std::string>> ListLinks(hid_t loc, bool recursive) {
  std::vector<std::string> names;
  auto cb = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->push_back(name);
    return 0;
  };
  const herr_t rc = recursive
                        ? H5Lvisit(loc, H5_INDEX_NAME, H5_ITER_INC, cb, &names)
                        : H5Literate(loc, H5_INDEX_NAME, H5_ITER_INC, nullptr, cb, &names);
  if (rc < 0) return std::nullopt;
  return names;
}

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
  int64_t t = -1;        // T, -1 if unknown
  std::string t_source;  // where T comes from
  std::map<std::string, std::vector<int8_t>> flags;  // success, fail, terminated, truncated
};

class Validator {
 public:
  explicit Validator(DatasetReport& report) : report_(report) {}

  void Run(const fs::path& dir) {
    // Walk first (the .parts folders must be skipped while walking), then check in path order.
    enum class Kind { kH5, kVideo, kPartsDir, kTemp, kEpisodeVideo };
    std::vector<std::pair<fs::path, Kind>> entries;
    std::error_code ec;
    fs::recursive_directory_iterator it(dir, ec), end;
    for (; !ec && it != end; it.increment(ec)) {
      const fs::path& p = it->path();
      const std::string name = p.filename().string();
      std::error_code ec2;
      if (it->is_directory(ec2)) {
        if (EndsWith(name, ".parts")) {
          entries.emplace_back(p, Kind::kPartsDir);
          it.disable_recursion_pending();
        }
        continue;
      }
      if (name.find(".tmp.") != std::string::npos) {
        entries.emplace_back(p, Kind::kTemp);
      } else if (StartsWith(name, ".episode_") && EndsWith(name, ".mp4")) {
        entries.emplace_back(p, Kind::kEpisodeVideo);
      } else if (EndsWith(name, ".h5")) {
        entries.emplace_back(p, Kind::kH5);
      } else if (EndsWith(name, ".mp4")) {
        entries.emplace_back(p, Kind::kVideo);
      }
    }
    if (ec) Add(dir.string(), "", "cannot list the folder: " + ec.message());
    std::sort(entries.begin(), entries.end());

    std::vector<fs::path> videos;
    bool any_h5 = false;
    for (const auto& [p, kind] : entries) {
      switch (kind) {
        case Kind::kPartsDir:
          Add(p.string(), "",
              "unfinished write: episode part files never merged into the batch file "
              "(finish the run with mlspaces datagen --resume)");
          MarkIncomplete(p.parent_path());
          break;
        case Kind::kTemp:
          Add(p.string(), "", "unfinished write: leftover temp file");
          break;
        case Kind::kEpisodeVideo:
          Add(p.string(), "", "unfinished write: video of an episode that was never kept");
          break;
        case Kind::kH5:
          any_h5 = true;
          FileIsolated(p);
          break;
        case Kind::kVideo:
          videos.push_back(p);
          break;
      }
    }
    if (!any_h5) Add(dir.string(), "", "no trajectory file (*.h5) in the folder");
    // Videos nobody names, in folders whose trajectories could all be read.
    for (const fs::path& v : videos) {
      if (video_refs_.count(Key(v)) == 0 && incomplete_dirs_.count(Key(v.parent_path())) == 0) {
        Add(v.string(), "", "video not named by any trajectory (obs/sensor_data) in its folder");
      }
    }
  }

 private:
  static std::string Key(const fs::path& p) {
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    return (ec ? p : abs).lexically_normal().string();
  }

  void Add(const std::string& file, const std::string& path, const std::string& message) {
    report_.problems.push_back(DatasetProblem{file, Printable(path), Printable(message)});
  }
  void Add(const std::string& path, const std::string& message) { Add(file_, path, message); }

  void MarkIncomplete(const fs::path& dir) {
    if (incomplete_dirs_.insert(Key(dir)).second) added_incomplete_.push_back(Key(dir));
  }

  // -------------------------------------------------------------------------------------------
  // Crash isolation: HDF5 (1.10) can crash on corrupt metadata (e.g. an out-of-bounds read of
  // a damaged global heap), so each file is checked in a child process that sends its findings
  // back through a pipe; a crash becomes a problem of that file.

  static void Put(std::string& out, const std::string& s) {
    out += std::to_string(s.size());
    out += ':';
    out += s;
  }
  static bool Get(std::string_view& in, std::string& s) {
    const size_t colon = in.find(':');
    if (colon == std::string_view::npos || colon == 0 || colon > 18) return false;
    size_t n = 0;
    for (char c : in.substr(0, colon)) {
      if (c < '0' || c > '9') return false;
      n = n * 10 + static_cast<size_t>(c - '0');
    }
    if (in.size() - colon - 1 < n) return false;
    s.assign(in.substr(colon + 1, n));
    in.remove_prefix(colon + 1 + n);
    return true;
  }
  static bool GetInt(std::string_view& in, int64_t& v) {
    std::string s;
    if (!Get(in, s) || s.empty() || s.size() > 18 ||
        s.find_first_not_of("0123456789") != std::string::npos) {
      return false;
    }
    v = std::stoll(s);
    return true;
  }

  /// What File() found since `first_problem`, serialized for the parent.
  std::string Serialize(size_t first_problem, int64_t trajectories, int64_t videos) const {
    std::string out;
    Put(out, std::to_string(report_.trajectories - trajectories));
    Put(out, std::to_string(report_.videos - videos));
    Put(out, std::to_string(report_.problems.size() - first_problem));
    for (size_t i = first_problem; i < report_.problems.size(); ++i) {
      const DatasetProblem& p = report_.problems[i];
      Put(out, p.file);
      Put(out, p.path);
      Put(out, p.message);
    }
    Put(out, std::to_string(added_refs_.size()));
    for (const auto& [key, referer] : added_refs_) {
      Put(out, key);
      Put(out, referer);
    }
    Put(out, std::to_string(added_incomplete_.size()));
    for (const std::string& dir : added_incomplete_) Put(out, dir);
    return out;
  }

  bool Deserialize(std::string_view in) {
    DatasetReport delta;
    int64_t n = 0;
    if (!GetInt(in, delta.trajectories) || !GetInt(in, delta.videos) || !GetInt(in, n)) {
      return false;
    }
    for (int64_t i = 0; i < n; ++i) {
      DatasetProblem p;
      if (!Get(in, p.file) || !Get(in, p.path) || !Get(in, p.message)) return false;
      delta.problems.push_back(std::move(p));
    }
    std::vector<std::pair<std::string, std::string>> refs;
    if (!GetInt(in, n)) return false;
    for (int64_t i = 0; i < n; ++i) {
      std::string key, referer;
      if (!Get(in, key) || !Get(in, referer)) return false;
      refs.emplace_back(std::move(key), std::move(referer));
    }
    std::vector<std::string> dirs;
    if (!GetInt(in, n)) return false;
    for (int64_t i = 0; i < n; ++i) {
      std::string dir;
      if (!Get(in, dir)) return false;
      dirs.push_back(std::move(dir));
    }
    if (!in.empty()) return false;
    report_.trajectories += delta.trajectories;
    report_.videos += delta.videos;
    for (DatasetProblem& p : delta.problems) report_.problems.push_back(std::move(p));
    for (auto& [key, referer] : refs) video_refs_.emplace(std::move(key), std::move(referer));
    for (std::string& dir : dirs) incomplete_dirs_.insert(std::move(dir));
    return true;
  }

  /// File(p) in a child process (in this one if fork or pipe fail).
  void FileIsolated(const fs::path& p) {
    int fds[2];
    if (::pipe(fds) != 0) {
      File(p);
      return;
    }
    const pid_t pid = ::fork();
    if (pid < 0) {
      ::close(fds[0]);
      ::close(fds[1]);
      File(p);
      return;
    }
    if (pid == 0) {  // child: check, send, _exit (no atexit handlers, no stdio flush)
      ::close(fds[0]);
      int rc = 0;
      try {
        const size_t first = report_.problems.size();
        const int64_t trajectories = report_.trajectories, videos = report_.videos;
        added_refs_.clear();
        added_incomplete_.clear();
        File(p);
        const std::string out = Serialize(first, trajectories, videos);
        for (size_t done = 0; done < out.size();) {
          const ssize_t w = ::write(fds[1], out.data() + done, out.size() - done);
          if (w < 0 && errno == EINTR) continue;
          if (w <= 0) {
            rc = 3;
            break;
          }
          done += static_cast<size_t>(w);
        }
      } catch (...) {
        rc = 4;
      }
      ::close(fds[1]);
      ::_exit(rc);
    }
    ::close(fds[1]);
    std::string data;
    char buf[65536];
    for (;;) {
      const ssize_t r = ::read(fds[0], buf, sizeof buf);
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) break;
      data.append(buf, static_cast<size_t>(r));
    }
    ::close(fds[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && Deserialize(data)) {
      ++report_.files;
      return;
    }
    ++report_.files;
    file_ = p.string();
    std::string how;
    if (WIFSIGNALED(status)) {
      const char* name = ::strsignal(WTERMSIG(status));
      how = "signal " + std::to_string(WTERMSIG(status)) + (name ? std::string(", ") + name : "");
    } else {
      how = "exit status " + std::to_string(WEXITSTATUS(status));
    }
    Add("", "checking this file (and the videos it names) crashed the reader (" + how +
                "): a file is corrupt beyond what HDF5 or FFmpeg report as an error");
    MarkIncomplete(p.parent_path());
  }

  // -------------------------------------------------------------------------------------------
  // One file

  void File(const fs::path& p) {
    ++report_.files;
    file_ = p.string();
    dir_ = p.parent_path();
    h5::QuietErrors quiet;
    Handle f(H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (f.get() < 0) {
      Add("", HdfMessage("not a readable HDF5 file"));
      MarkIncomplete(dir_);
      return;
    }
    const auto names = ListLinks(f.get(), false);
    if (!names) {
      Add("/", HdfMessage("cannot list the root group"));
      MarkIncomplete(dir_);
      return;
    }
    std::map<int64_t, std::string> trajs;
    for (const std::string& name : *names) {
      if (!StartsWith(name, "traj_")) continue;  // e.g. post-processing outputs
      const std::string digits = name.substr(5);
      const bool canonical = !digits.empty() && digits.size() <= 9 &&
                             digits.find_first_not_of("0123456789") == std::string::npos &&
                             (digits == "0" || digits[0] != '0');
      if (!canonical) {
        Add(name, "unexpected name: trajectories are traj_<k>, k = 0, 1, …");
        continue;
      }
      trajs.emplace(std::stoll(digits), name);
    }
    if (trajs.empty()) {
      Add("", "no traj_<k> group");
      return;
    }
    const int64_t last = trajs.rbegin()->first;
    const int64_t missing = last + 1 - static_cast<int64_t>(trajs.size());
    if (missing > 0) {
      int64_t first_missing = 0;
      while (trajs.count(first_missing) != 0) ++first_missing;
      Add("", "trajectory numbering has gaps: " + std::to_string(missing) + " of traj_0 … traj_" +
                  std::to_string(last) + " missing (first: traj_" +
                  std::to_string(first_missing) + ")");
    }
    for (const auto& [k, name] : trajs) {
      ++report_.trajectories;
      CheckTraj(f.get(), name, k);
    }
  }

  // -------------------------------------------------------------------------------------------
  // Dataset helpers

  /// Opens dataset `rel` below `loc`; nullopt (with a problem when `required` or when it
  /// exists but cannot be opened as a dataset) otherwise.
  std::optional<Ds> Open(hid_t loc, const std::string& base, const std::string& rel,
                         bool required) {
    const std::string path = base + "/" + rel;
    if (!Exists(loc, rel)) {
      if (required) Add(path, "missing");
      return std::nullopt;
    }
    Handle obj(H5Oopen(loc, rel.c_str(), H5P_DEFAULT), H5Oclose);
    if (obj.get() < 0) {
      Add(path, HdfMessage("cannot open"));
      return std::nullopt;
    }
    if (H5Iget_type(obj.get()) != H5I_DATASET) {
      Add(path, "expected a dataset, found a group");
      return std::nullopt;
    }
    Ds ds;
    ds.path = path;
    ds.type = Handle(H5Dget_type(obj.get()), H5Tclose);
    Handle space(H5Dget_space(obj.get()), H5Sclose);
    const int rank = space.get() >= 0 ? H5Sget_simple_extent_ndims(space.get()) : -1;
    if (ds.type.get() < 0 || rank < 0) {
      Add(path, HdfMessage("cannot read the type or shape"));
      return std::nullopt;
    }
    ds.dims.resize(static_cast<size_t>(rank));
    if (rank > 0) H5Sget_simple_extent_dims(space.get(), ds.dims.data(), nullptr);
    double bytes = static_cast<double>(H5Tget_size(ds.type.get()));
    for (hsize_t d : ds.dims) bytes *= static_cast<double>(d);
    if (bytes > kMaxDatasetBytes) {
      Add(path, "shape " + Shape(ds.dims) + " is too large to check (" +
                    std::to_string(static_cast<int64_t>(bytes / (1 << 20))) + " MiB)");
      return std::nullopt;
    }
    ds.id = std::move(obj);
    return ds;
  }

  /// Checks the first dimension is T.
  bool Rows(const Ds& ds, const Traj& t) {
    if (ds.dims.empty()) {
      Add(ds.path, "is a scalar, expected one row per observation");
      return false;
    }
    if (t.t >= 0 && static_cast<int64_t>(ds.dims[0]) != t.t) {
      Add(ds.path, "has " + std::to_string(ds.dims[0]) + " rows, expected " +
                       std::to_string(t.t) + " (T, the rows of " + t.t_source + ")");
      return false;
    }
    return true;
  }

  /// Reads a whole dataset as `mem_type` into `buf` (sized by the caller).
  bool Read(const Ds& ds, hid_t mem_type, void* buf) {
    if (ds.elements() == 0) return true;
    if (H5Dread(ds.id.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
      Add(ds.path, HdfMessage("cannot read the data"));
      return false;
    }
    return true;
  }

  /// A numeric dataset is readable to its end (catches corrupt chunks).
  void ReadNumeric(const Ds& ds) {
    if (!IsNumeric(ds.type.get())) {
      Add(ds.path, "expected a numeric dataset, got " + TypeName(ds.type.get()));
      return;
    }
    std::vector<unsigned char> buf(ds.elements() * H5Tget_size(ds.type.get()));
    Read(ds, ds.type.get(), buf.data());
  }

  /// uint8 (T, L) rows, each a zero-padded JSON text (`objects`: a JSON object).
  void JsonRows(const Ds& ds, const Traj& t, bool objects) {
    if (!IsUint8(ds.type.get()) || ds.dims.size() != 2) {
      Add(ds.path, "expected uint8 (T, L) JSON rows, got " + TypeName(ds.type.get()) + " " +
                       Shape(ds.dims));
      return;
    }
    Rows(ds, t);
    const size_t rows = ds.dims[0], width = ds.dims[1];
    std::vector<unsigned char> buf(rows * width);
    if (!Read(ds, H5T_NATIVE_UINT8, buf.data())) return;
    int64_t bad = 0;
    std::string first;
    for (size_t i = 0; i < rows; ++i) {
      const char* row = reinterpret_cast<const char*>(buf.data() + i * width);
      const void* nul = std::memchr(row, 0, width);
      const size_t len = nul != nullptr ? static_cast<size_t>(static_cast<const char*>(nul) - row)
                                        : width;
      const std::string_view text(row, len);
      std::string why;
      if (std::any_of(row + len, row + width, [](char c) { return c != 0; })) {
        why = "has non-zero bytes after its zero padding starts (byte " + std::to_string(len) + ")";
      } else if (len == 0) {
        why = "is empty (all zeros)";
      } else if (const auto j = ParsePythonJson(text); !j) {
        why = "is not valid JSON: " + Snippet(text);
      } else if (objects && !j->is_object()) {
        why = "is a JSON " + JsonTypeName(*j) + ", expected an object";
      }
      if (!why.empty() && bad++ == 0) {
        first = "row " + std::to_string(i) + " of " + std::to_string(rows) + " " + why;
      }
    }
    if (bad > 0) {
      Add(ds.path, first + (bad > 1 ? " (" + std::to_string(bad) + " bad rows)" : ""));
    }
  }

  /// A string dataset or attribute's text (fixed or variable length); nullopt after a problem.
  std::optional<std::string> ReadString(hid_t obj, bool attribute, const std::string& path) {
    Handle type(attribute ? H5Aget_type(obj) : H5Dget_type(obj), H5Tclose);
    Handle space(attribute ? H5Aget_space(obj) : H5Dget_space(obj), H5Sclose);
    if (type.get() < 0 || space.get() < 0) {
      Add(path, HdfMessage("cannot read the type or shape"));
      return std::nullopt;
    }
    if (H5Tget_class(type.get()) != H5T_STRING ||
        H5Sget_simple_extent_type(space.get()) != H5S_SCALAR) {
      std::vector<hsize_t> dims(std::max(0, H5Sget_simple_extent_ndims(space.get())));
      if (!dims.empty()) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
      Add(path, "expected a scalar string, got " + TypeName(type.get()) + " " + Shape(dims));
      return std::nullopt;
    }
    std::string text;
    herr_t rc;
    if (H5Tis_variable_str(type.get()) > 0) {
      char* p = nullptr;
      rc = attribute ? H5Aread(obj, type.get(), &p)
                     : H5Dread(obj, type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &p);
      if (rc >= 0 && p != nullptr) text = p;
      if (rc >= 0) H5Dvlen_reclaim(type.get(), space.get(), H5P_DEFAULT, &p);
    } else {
      std::vector<char> buf(H5Tget_size(type.get()) + 1, 0);
      rc = attribute ? H5Aread(obj, type.get(), buf.data())
                     : H5Dread(obj, type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
      text = buf.data();
    }
    if (rc < 0) {
      Add(path, HdfMessage("cannot read the data"));
      return std::nullopt;
    }
    return text;
  }

  // -------------------------------------------------------------------------------------------
  // One trajectory

  void CheckTraj(hid_t file, const std::string& name, int64_t k) {
    Handle g(H5Oopen(file, name.c_str(), H5P_DEFAULT), H5Oclose);
    if (g.get() < 0) {
      Add(name, HdfMessage("cannot open"));
      return;
    }
    if (H5Iget_type(g.get()) != H5I_GROUP) {
      Add(name, "expected a group, found a dataset");
      return;
    }
    Traj t;
    t.g = g.get();
    t.name = name;
    t.k = k;
    // T: the rows of obs/agent/qpos (or, when that is unusable, of rewards, to go on checking).
    {
      h5::QuietErrors quiet;
      for (const char* source : {"obs/agent/qpos", "rewards"}) {
        if (!Exists(t.g, source)) continue;
        Handle ds(H5Dopen2(t.g, source, H5P_DEFAULT), H5Dclose);
        Handle space(ds.get() >= 0 ? H5Dget_space(ds.get()) : H5I_INVALID_HID, H5Sclose);
        if (space.get() < 0 || H5Sget_simple_extent_ndims(space.get()) < 1) continue;
        std::vector<hsize_t> dims(H5Sget_simple_extent_ndims(space.get()));
        H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
        t.t = static_cast<int64_t>(dims[0]);
        t.t_source = source;
        break;
      }
    }
    if (t.t >= 0 && t.t < 2) {
      Add(name + "/" + t.t_source,
          "T = " + std::to_string(t.t) +
              " rows: an episode needs at least one observation and one step (T >= 2)");
    }

    JsonGroup(t, "obs/agent", kAgentDatasets);
    JsonGroup(t, "actions", kActionDatasets);
    if (auto ds = Open(t.g, name, "rewards", true)) {
      const hid_t type = ds->type.get();
      if (H5Tget_class(type) != H5T_FLOAT || H5Tget_size(type) != 4 || ds->dims.size() != 1) {
        Add(ds->path, "expected float32 (T,), got " + TypeName(type) + " " + Shape(ds->dims));
      } else if (Rows(*ds, t)) {
        ReadNumeric(*ds);
      }
    }
    for (const char* flag : kBoolDatasets) Bools(t, flag);
    FlagConsistency(t);
    ObsScene(t);
    Provenance(t);
    // Per-step numeric (and JSON) datasets of any name.
    for (const char* group : {"obs/extra", "env_states"}) {
      const bool extra = std::strcmp(group, "obs/extra") == 0;
      VisitDatasets(t, group, [&](const Ds& ds) {
        if (extra && IsUint8(ds.type.get()) && ds.dims.size() == 2) {
          JsonRows(ds, t, false);
        } else if (Rows(ds, t)) {
          ReadNumeric(ds);
        }
      });
    }
    Cameras(t);
  }

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

  template <size_t N>
  void JsonGroup(const Traj& t, const std::string& rel, const char* const (&required)[N]) {
    for (const char* name : required) {
      if (!Exists(t.g, rel + "/" + name)) Add(t.name + "/" + rel + "/" + name, "missing");
    }
    VisitDatasets(t, rel, [&](const Ds& ds) { JsonRows(ds, t, true); });
  }

  void Bools(Traj& t, const std::string& flag) {
    auto ds = Open(t.g, t.name, flag, true);
    if (!ds) return;
    const hid_t type = ds->type.get();
    const H5T_class_t c = H5Tget_class(type);
    if ((c != H5T_ENUM && c != H5T_INTEGER) || H5Tget_size(type) != 1 || ds->dims.size() != 1) {
      Add(ds->path, "expected bool (T,) (int8 enum FALSE/TRUE), got " + TypeName(type) + " " +
                        Shape(ds->dims));
      return;
    }
    if (!Rows(*ds, t)) return;
    std::vector<int8_t> v(ds->dims[0]);
    if (!Read(*ds, type, v.data())) return;
    for (size_t i = 0; i < v.size(); ++i) {
      if (v[i] != 0 && v[i] != 1) {
        Add(ds->path, "row " + std::to_string(i) + " holds " + std::to_string(v[i]) +
                          ", expected 0 (FALSE) or 1 (TRUE)");
        return;
      }
    }
    t.flags[flag] = std::move(v);
  }

  void FlagConsistency(const Traj& t) {
    auto get = [&](const char* name) -> const std::vector<int8_t>* {
      auto it = t.flags.find(name);
      return it == t.flags.end() ? nullptr : &it->second;
    };
    const auto *success = get("success"), *fail = get("fail");
    const auto *terminated = get("terminated"), *truncated = get("truncated");
    if (success != nullptr && fail != nullptr && success->size() == fail->size()) {
      int64_t differ = 0;
      size_t first = 0;
      for (size_t i = 0; i < success->size(); ++i) {
        if ((*fail)[i] == (*success)[i] && differ++ == 0) first = i;
      }
      if (differ > 0) {
        Add(t.name + "/fail",
            "row " + std::to_string(first) + " equals success (" +
                ((*success)[first] ? "TRUE" : "FALSE") + "): fail must be !success (" +
                std::to_string(differ) + " of " + std::to_string(success->size()) + " rows)");
      }
    }
    for (const auto* flags : {terminated, truncated}) {
      if (flags == nullptr || flags->empty()) continue;
      int64_t early = 0;
      size_t first = 0;
      for (size_t i = 0; i + 1 < flags->size(); ++i) {
        if ((*flags)[i] != 0 && early++ == 0) first = i;
      }
      if (early > 0) {
        Add(t.name + (flags == terminated ? "/terminated" : "/truncated"),
            "set on row " + std::to_string(first) + " of " + std::to_string(flags->size()) +
                ": only the last row may end the episode" +
                (early > 1 ? " (" + std::to_string(early) + " rows set early)" : ""));
      }
    }
    if (terminated != nullptr && truncated != nullptr && !terminated->empty() &&
        terminated->size() == truncated->size() && terminated->back() == 0 &&
        truncated->back() == 0) {
      Add(t.name + "/terminated", "the last row (" + std::to_string(terminated->size() - 1) +
                                      ") is neither terminated nor truncated");
    }
  }

  void ObsScene(const Traj& t) {
    auto ds = Open(t.g, t.name, "obs_scene", true);
    if (!ds) return;
    const auto text = ReadString(ds->id.get(), false, ds->path);
    if (!text) return;
    const auto j = ParsePythonJson(*text);
    if (!j) {
      Add(ds->path, "is not valid JSON: " + Snippet(*text));
    } else if (!j->is_object()) {
      Add(ds->path, "is a JSON " + JsonTypeName(*j) + ", expected an object");
    }
  }

  void Provenance(const Traj& t) {
    const std::string path = t.name + "@provenance";
    const htri_t exists = H5Aexists(t.g, "provenance");
    if (exists <= 0) {
      Add(path, exists == 0 ? "missing" : HdfMessage("cannot read"));
      return;
    }
    Handle attr(H5Aopen(t.g, "provenance", H5P_DEFAULT), H5Aclose);
    if (attr.get() < 0) {
      Add(path, HdfMessage("cannot open"));
      return;
    }
    const auto text = ReadString(attr.get(), true, path);
    if (!text) return;
    const auto p = ParsePythonJson(*text);
    if (!p || !p->is_object()) {
      Add(path, p ? "is a JSON " + JsonTypeName(*p) + ", expected an object"
                  : "is not valid JSON: " + Snippet(*text));
      return;
    }
    auto non_empty_string = [&](const FlatJson& obj, const char* key, const std::string& where,
                                const std::string& uid = "") {
      auto it = obj.find(key);
      const std::string suffix = uid.empty() ? "" : " (uid \"" + uid + "\")";
      if (it == obj.end()) {
        Add(where + "/" + key, "missing" + suffix);
      } else if (!it->is_string() || it->get<std::string>().empty()) {
        Add(where + "/" + key, (it->is_string() ? std::string("empty")
                                                : "expected a string, got " + JsonTypeName(*it)) +
                                   suffix);
      }
    };
    non_empty_string(*p, "config_hash", path);
    non_empty_string(*p, "mujoco_version", path);
    non_empty_string(*p, "mlspaces_version", path);
    if (auto it = p->find("seed"); it == p->end()) {
      Add(path + "/seed", "missing");
    } else if (!it->is_number_unsigned()) {
      Add(path + "/seed", "expected an unsigned integer, got " + it->dump());
    }
    if (auto it = p->find("assets"); it == p->end()) {
      Add(path + "/assets", "missing");
    } else if (!it->is_array()) {
      Add(path + "/assets", "expected an array, got " + JsonTypeName(*it));
    } else {
      for (size_t i = 0; i < it->size(); ++i) {
        const FlatJson& a = (*it)[i];
        const std::string where = path + "/assets/" + std::to_string(i);
        if (!a.is_object()) {
          Add(where, "expected an object, got " + JsonTypeName(a));
          continue;
        }
        const std::string uid =
            a.contains("uid") && a["uid"].is_string() ? a["uid"].get<std::string>() : "";
        non_empty_string(a, "uid", where);
        non_empty_string(a, "library", where, uid);
        non_empty_string(a, "license", where, uid);
      }
    }
    // Optional fields, when present, must agree with the datasets.
    if (auto it = p->find("episode_index"); it != p->end() && *it != FlatJson(t.k)) {
      Add(path + "/episode_index", it->dump() + ", expected " + std::to_string(t.k) +
                                       " (the k of traj_<k>)");
    }
    if (auto it = p->find("num_steps"); it != p->end() && t.t >= 0 && *it != FlatJson(t.t)) {
      Add(path + "/num_steps", it->dump() + ", expected T = " + std::to_string(t.t));
    }
    for (const char* flag : {"success", "terminated", "truncated"}) {
      auto it = p->find(flag);
      auto rows = t.flags.find(flag);
      if (it == p->end() || rows == t.flags.end() || rows->second.empty()) continue;
      const bool last = rows->second.back() != 0;
      if (!it->is_boolean() || it->get<bool>() != last) {
        Add(path + "/" + flag, it->dump() + ", but the last row of " + t.name + "/" + flag +
                                   " is " + (last ? "TRUE" : "FALSE"));
      }
    }
  }

  // -------------------------------------------------------------------------------------------
  // Cameras and videos

  void Cameras(const Traj& t) {
    // Camera parameters and image sizes.
    std::map<std::string, std::optional<std::pair<int, int>>> cams;  // name -> image W x H
    const std::string param_base = t.name + "/obs/sensor_param";
    if (Exists(t.g, "obs/sensor_param")) {
      Handle g(H5Gopen2(t.g, "obs/sensor_param", H5P_DEFAULT), H5Gclose);
      const auto names = g.get() >= 0 ? ListLinks(g.get(), false) : std::nullopt;
      if (!names) Add(param_base, HdfMessage("expected a readable group"));
      for (const std::string& cam : names.value_or(std::vector<std::string>{})) {
        const std::string rel = "obs/sensor_param/" + cam;
        Handle obj(H5Oopen(t.g, rel.c_str(), H5P_DEFAULT), H5Oclose);
        if (obj.get() < 0 || H5Iget_type(obj.get()) != H5I_GROUP) {
          Add(param_base + "/" + cam, obj.get() < 0 ? HdfMessage("cannot open")
                                                    : "expected a group per camera");
          continue;
        }
        cams[cam] = std::nullopt;
        VisitDatasets(t, rel, [&](const Ds& ds) {
          if (!Rows(ds, t)) return;
          const std::string key = ds.path.substr(ds.path.rfind('/') + 1);
          static const std::map<std::string, std::vector<hsize_t>> kShapes = {
              {"cam2world_gl", {4, 4}}, {"extrinsic_cv", {3, 4}}, {"intrinsic_cv", {3, 3}}};
          auto shape = kShapes.find(key);
          if (shape != kShapes.end() &&
              !std::equal(ds.dims.begin() + 1, ds.dims.end(), shape->second.begin(),
                          shape->second.end())) {
            Add(ds.path, "has shape " + Shape(ds.dims) + ", expected (T, " +
                             std::to_string(shape->second[0]) + ", " +
                             std::to_string(shape->second[1]) + ")");
            return;
          }
          if (key != "intrinsic_cv") {
            ReadNumeric(ds);
            return;
          }
          if (H5Tget_class(ds.type.get()) != H5T_FLOAT) {
            Add(ds.path, "expected float64, got " + TypeName(ds.type.get()));
            return;
          }
          std::vector<double> k(ds.elements());
          if (!Read(ds, H5T_NATIVE_DOUBLE, k.data()) || k.empty()) return;
          const double w = 2 * k[2], h = 2 * k[5];  // cx = K[0][2], cy = K[1][2]
          if (!(w >= 1 && h >= 1 && w <= 65536 && h <= 65536)) {
            Add(ds.path, "row 0 gives no image size (2 cx = " + std::to_string(w) +
                             ", 2 cy = " + std::to_string(h) + ")");
            return;
          }
          cams[cam] = std::pair{static_cast<int>(std::lround(w)), static_cast<int>(std::lround(h))};
        });
        if (!Exists(t.g, rel + "/intrinsic_cv")) Add(param_base + "/" + cam + "/intrinsic_cv", "missing");
      }
    }

    const std::string data_base = t.name + "/obs/sensor_data";
    if (!Exists(t.g, "obs/sensor_data")) {
      Add(data_base, "missing");
      return;
    }
    Handle g(H5Gopen2(t.g, "obs/sensor_data", H5P_DEFAULT), H5Gclose);
    const auto names = g.get() >= 0 ? ListLinks(g.get(), false) : std::nullopt;
    if (!names) {
      Add(data_base, HdfMessage("expected a readable group"));
      return;
    }
    for (const std::string& entry : *names) {
      auto ds = Open(g.get(), data_base, entry, true);
      if (!ds) continue;
      ++report_.videos;
      if (!IsUint8(ds->type.get()) || ds->dims.size() != 1) {
        Add(ds->path, "expected a uint8 (100,) zero-padded file name, got " +
                          TypeName(ds->type.get()) + " " + Shape(ds->dims));
        continue;
      }
      std::vector<unsigned char> buf(ds->dims[0]);
      if (!Read(*ds, H5T_NATIVE_UINT8, buf.data())) continue;
      const auto nul = std::find(buf.begin(), buf.end(), 0);
      const std::string file(buf.begin(), nul);
      if (std::any_of(nul, buf.end(), [](unsigned char c) { return c != 0; })) {
        Add(ds->path, "has non-zero bytes after its zero padding starts");
        continue;
      }
      if (file.empty() || file.find('/') != std::string::npos || file == "." || file == "..") {
        Add(ds->path, "expected a file name beside the HDF5 file, got " + Snippet(file));
        continue;
      }
      // The camera whose intrinsics give the size: <cam>, or <cam> for "<cam>_depth".
      std::string cam = entry;
      if (cams.count(cam) == 0 && EndsWith(cam, "_depth")) cam.resize(cam.size() - 6);
      auto cam_it = cams.find(cam);
      if (cam_it == cams.end()) {
        Add(ds->path, "no camera obs/sensor_param/" + entry + " for this video");
      }
      Video(t, *ds, file, cam_it != cams.end() ? cam_it->second : std::nullopt);
    }
    for (const auto& [cam, size] : cams) {
      if (std::find(names->begin(), names->end(), cam) == names->end()) {
        Add(data_base + "/" + cam, "missing: camera obs/sensor_param/" + cam + " has no video");
      }
    }
  }

  void Video(const Traj& t, const Ds& ds, const std::string& name,
             const std::optional<std::pair<int, int>>& image) {
    const fs::path file = dir_ / name;
    const std::string key = Key(file);
    const std::string referer = file_ + ": " + ds.path;
    auto [ref, inserted] = video_refs_.emplace(key, referer);
    if (inserted) added_refs_.emplace_back(key, referer);
    if (!inserted) {
      Add(ds.path, "video " + name + " is also named by " + ref->second);
      return;
    }
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) {
      Add(ds.path, "video file does not exist: " + file.string());
      return;
    }
    VideoInfo info;
    try {
      info = ProbeVideo(file);
    } catch (const Error& e) {
      Add(ds.path, "video " + name + " cannot be decoded: " + e.message());
      return;
    }
    if (t.t >= 0 && info.frames != t.t) {
      Add(ds.path, "video " + name + " has " + std::to_string(info.frames) + " frames, expected " +
                       std::to_string(t.t) + " (T, one per observation)");
    }
    if (image) {
      const int w = (image->first + 15) / 16 * 16, h = (image->second + 15) / 16 * 16;
      if (info.width != w || info.height != h) {
        Add(ds.path, "video " + name + " is " + std::to_string(info.width) + "x" +
                         std::to_string(info.height) + ", expected " + std::to_string(w) + "x" +
                         std::to_string(h) + " (the camera's " + std::to_string(image->first) +
                         "x" + std::to_string(image->second) +
                         " image rounded up to multiples of 16)");
      }
    }
  }

  DatasetReport& report_;
  std::string file_;  // the HDF5 file being checked
  fs::path dir_;      // its folder (videos live there)
  std::map<std::string, std::string> video_refs_;  // video file -> "file: path" naming it
  std::set<std::string> incomplete_dirs_;          // folders whose videos may be unreferenced
  // What File() added to the two above (sent back from the child process).
  std::vector<std::pair<std::string, std::string>> added_refs_;
  std::vector<std::string> added_incomplete_;
};

}  // namespace

DatasetReport ValidateDataset(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw Error(fs::exists(dir, ec) ? "not a folder" : "no such folder", dir.string());
  }
  DatasetReport report;
  Validator(report).Run(dir);
  return report;
}

}  // namespace mlspaces::datagen
