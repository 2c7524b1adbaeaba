// validate-dataset: HDF5 reading helpers (types, shapes, strings, JSON rows, links).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "dataset_validate_internal.h"

namespace mlspaces::datagen::dataset_check {

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
  const herr_t rc = recursive ? H5Lvisit(loc, H5_INDEX_NAME, H5_ITER_INC, cb, &names)
                              : H5Literate(loc, H5_INDEX_NAME, H5_ITER_INC, nullptr, cb, &names);
  if (rc < 0) return std::nullopt;
  return names;
}

// -------------------------------------------------------------------------------------------
// Dataset helpers
/// Opens dataset `rel` below `loc`; nullopt (with a problem when `required` or when it
/// exists but cannot be opened as a dataset) otherwise.
std::optional<Ds> Validator::Open(hid_t loc, const std::string& base, const std::string& rel,
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
bool Validator::Rows(const Ds& ds, const Traj& t) {
  if (ds.dims.empty()) {
    Add(ds.path, "is a scalar, expected one row per observation");
    return false;
  }
  if (t.t >= 0 && static_cast<int64_t>(ds.dims[0]) != t.t) {
    Add(ds.path, "has " + std::to_string(ds.dims[0]) + " rows, expected " + std::to_string(t.t) +
                     " (T, the rows of " + t.t_source + ")");
    return false;
  }
  return true;
}

/// Reads a whole dataset as `mem_type` into `buf` (sized by the caller).
bool Validator::Read(const Ds& ds, hid_t mem_type, void* buf) {
  if (ds.elements() == 0) return true;
  if (H5Dread(ds.id.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
    Add(ds.path, HdfMessage("cannot read the data"));
    return false;
  }
  return true;
}

/// A numeric dataset is readable to its end (catches corrupt chunks).
void Validator::ReadNumeric(const Ds& ds) {
  if (!IsNumeric(ds.type.get())) {
    Add(ds.path, "expected a numeric dataset, got " + TypeName(ds.type.get()));
    return;
  }
  std::vector<unsigned char> buf(ds.elements() * H5Tget_size(ds.type.get()));
  Read(ds, ds.type.get(), buf.data());
}

/// uint8 (T, L) rows, each a zero-padded JSON text (`objects`: a JSON object).
void Validator::JsonRows(const Ds& ds, const Traj& t, bool objects) {
  if (!IsUint8(ds.type.get()) || ds.dims.size() != 2) {
    Add(ds.path,
        "expected uint8 (T, L) JSON rows, got " + TypeName(ds.type.get()) + " " + Shape(ds.dims));
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
    const size_t len =
        nul != nullptr ? static_cast<size_t>(static_cast<const char*>(nul) - row) : width;
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
std::optional<std::string> Validator::ReadString(hid_t obj, bool attribute,
                                                 const std::string& path) {
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

}  // namespace mlspaces::datagen::dataset_check
