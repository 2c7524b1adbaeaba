#include "convert.h"

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <utility>

#include <nanobind/ndarray.h>

#include "mlspaces/core/error.h"

namespace mlspaces::python {

namespace {

nb::dlpack::dtype ToDlpack(DType dtype) {
  switch (dtype) {
    case DType::kF2:
      return nb::dlpack::dtype{static_cast<uint8_t>(nb::dlpack::dtype_code::Float), 16, 1};
    case DType::kF4:
      return nb::dtype<float>();
    case DType::kF8:
      return nb::dtype<double>();
    case DType::kI4:
      return nb::dtype<int32_t>();
    case DType::kI8:
      return nb::dtype<int64_t>();
    case DType::kU1:
      return nb::dtype<uint8_t>();
    case DType::kB1:
      return nb::dtype<bool>();
  }
  return nb::dtype<double>();
}

}  // namespace

nb::object JsonToPython(const Json& value) {
  switch (value.type()) {
    case Json::value_t::null:
      return nb::none();
    case Json::value_t::boolean:
      return nb::bool_(value.get<bool>());
    case Json::value_t::number_integer:
      return nb::int_(value.get<int64_t>());
    case Json::value_t::number_unsigned:
      return nb::steal(PyLong_FromUnsignedLongLong(value.get<uint64_t>()));
    case Json::value_t::number_float:
      return nb::float_(value.get<double>());
    case Json::value_t::string: {
      const auto& s = value.get_ref<const std::string&>();
      return nb::str(s.data(), s.size());
    }
    case Json::value_t::array: {
      // The C API directly: a list of known size, items stolen into it.
      nb::object out = nb::steal(PyList_New(static_cast<Py_ssize_t>(value.size())));
      if (!out.is_valid()) throw nb::python_error();
      Py_ssize_t i = 0;
      for (const Json& item : value) {
        PyList_SET_ITEM(out.ptr(), i++, JsonToPython(item).release().ptr());
      }
      return out;
    }
    case Json::value_t::object: {
      // Keys are interned: annotations repeat the same few keys, so dicts share them and
      // lookups compare pointers.
      nb::object out = nb::steal(PyDict_New());
      if (!out.is_valid()) throw nb::python_error();
      for (auto it = value.begin(); it != value.end(); ++it) {
        const std::string& key = it.key();
        PyObject* k = PyUnicode_FromStringAndSize(key.data(), static_cast<Py_ssize_t>(key.size()));
        if (k == nullptr) throw nb::python_error();
        PyUnicode_InternInPlace(&k);
        nb::object item = JsonToPython(it.value());
        const int rc = PyDict_SetItem(out.ptr(), k, item.ptr());
        Py_DECREF(k);
        if (rc != 0) throw nb::python_error();
      }
      return out;
    }
    case Json::value_t::binary:
    case Json::value_t::discarded:
      break;
  }
  return nb::none();
}

nb::object NpyToNumpy(const NpyArray& array) {
  // Any dtype: the byte buffer with the array's dtype (an owned copy of the annotation's).
  auto* owned = new std::vector<uint8_t>(array.data);
  nb::capsule owner(owned, [](void* p) noexcept { delete static_cast<std::vector<uint8_t>*>(p); });
  return nb::cast(nb::ndarray<nb::numpy>(owned->data(), array.shape.size(), array.shape.data(),
                                         owner, nullptr, ToDlpack(array.dtype)));
}

namespace {

/// A read-only numpy view of `array`, keeping `owner` (which holds it) alive.
nb::object SharedNpyToNumpy(const NpyArray& array, const std::shared_ptr<const Annotation>& owner) {
  auto* keep = new std::shared_ptr<const Annotation>(owner);
  nb::capsule capsule(
      keep, [](void* p) noexcept { delete static_cast<std::shared_ptr<const Annotation>*>(p); });
  return nb::cast(nb::ndarray<nb::numpy, nb::ro>(array.data.data(), array.shape.size(),
                                                 array.shape.data(), capsule, nullptr,
                                                 ToDlpack(array.dtype)));
}

/// The annotation's JSON as Python with its arrays inserted at their pointers, made by `make`.
template <class MakeArray>
nb::object AnnotationWithArrays(const Annotation& annotation, const MakeArray& make) {
  nb::object root = JsonToPython(annotation.json);
  for (const auto& [pointer, array] : annotation.arrays) {
    // pointer: "/a/b/c" (tokens escaped as JSON pointer tokens; LoadAnnotation built them).
    nb::object node = root;
    size_t start = 1;
    while (true) {
      const size_t slash = pointer.find('/', start);
      std::string token =
          pointer.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
      // Unescape ~1 and ~0.
      for (size_t pos = 0; (pos = token.find('~', pos)) != std::string::npos; ++pos) {
        token.replace(pos, 2, token.compare(pos, 2, "~1") == 0 ? "/" : "~");
      }
      nb::dict dict = nb::borrow<nb::dict>(node);
      if (slash == std::string::npos) {
        dict[nb::str(token.c_str())] = make(array);
        break;
      }
      nb::str key(token.c_str());
      if (!dict.contains(key)) dict[key] = nb::dict();
      node = dict[key];
      start = slash + 1;
    }
  }
  return root;
}

}  // namespace

nb::object AnnotationToPython(const Annotation& annotation) {
  return AnnotationWithArrays(annotation, [](const NpyArray& a) { return NpyToNumpy(a); });
}

nb::object AnnotationToPython(std::shared_ptr<const Annotation> annotation) {
  return AnnotationWithArrays(*annotation,
                              [&](const NpyArray& a) { return SharedNpyToNumpy(a, annotation); });
}

nb::object PosesToNumpy(std::vector<Mat4> poses) {
  static_assert(sizeof(Mat4) == 16 * sizeof(double));
  const size_t n = poses.size();
  return OwnedNumpy<double>(std::move(poses), {n, 4, 4});
}

namespace {

/// numpy.ascontiguousarray(value, dtype=float64), checked to have `shape` (-1 = any).
nb::ndarray<double, nb::c_contig, nb::device::cpu> AsFloat64(nb::handle value,
                                                             std::initializer_list<long> shape,
                                                             const std::string& what) {
  if (value.is_none()) throw Error(what + ": expected an array, got None");
  // Held for the life of the process (never released: no decref after the interpreter ends).
  static nb::handle ascontiguous =
      nb::object(nb::module_::import_("numpy").attr("ascontiguousarray")).release();
  static nb::handle float64 = nb::object(nb::module_::import_("numpy").attr("float64")).release();
  nb::object converted;
  try {
    converted = ascontiguous(value, float64);
  } catch (nb::python_error& e) {
    throw Error(what + ": not a numeric array (" + std::string(e.what()) + ")");
  }
  auto array = nb::cast<nb::ndarray<double, nb::c_contig, nb::device::cpu>>(converted);
  bool ok = array.ndim() == shape.size();
  size_t i = 0;
  for (long want : shape) {
    if (!ok) break;
    if (want >= 0 && array.shape(i) != static_cast<size_t>(want)) ok = false;
    ++i;
  }
  if (!ok) {
    std::string got = "(";
    for (size_t d = 0; d < array.ndim(); ++d) {
      got += (d ? ", " : "") + std::to_string(array.shape(d));
    }
    got += array.ndim() == 1 ? ",)" : ")";
    std::string want = "(";
    i = 0;
    for (long s : shape) want += (i++ ? ", " : "") + (s < 0 ? std::string("N") : std::to_string(s));
    want += shape.size() == 1 ? ",)" : ")";
    throw Error(what + ": expected shape " + want + ", got " + got);
  }
  const double* data = array.data();
  for (size_t k = 0; k < array.size(); ++k) {
    if (!std::isfinite(data[k]))
      throw Error(what + ": non-finite value at flat index " + std::to_string(k));
  }
  return array;
}

}  // namespace

Mat4 Mat4FromPython(nb::handle value, const std::string& what) {
  auto array = AsFloat64(value, {4, 4}, what);
  Mat4 out;
  std::memcpy(out.m.data(), array.data(), sizeof(out.m));
  return out;
}

std::vector<double> DoublesFromPython(nb::handle value, size_t n, const std::string& what) {
  auto array = AsFloat64(value, {static_cast<long>(n)}, what);
  return std::vector<double>(array.data(), array.data() + n);
}

std::vector<Mat4> PosesFromPython(nb::handle value, const std::string& what) {
  auto array = AsFloat64(value, {-1, 4, 4}, what);
  std::vector<Mat4> out(array.shape(0));
  if (!out.empty()) std::memcpy(out.data(), array.data(), out.size() * sizeof(Mat4));
  return out;
}

nb::object ToPathlib(const std::filesystem::path& path) {
  static nb::handle path_type = nb::object(nb::module_::import_("pathlib").attr("Path")).release();
  return path_type(nb::str(path.c_str()));
}

}  // namespace mlspaces::python
