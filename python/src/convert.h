// Conversions between mlspaces values and Python objects, shared by the binding files.
#pragma once

#include <cstddef>
#include <filesystem>
#include <span>
#include <utility>
#include <vector>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include "mlspaces/core/json.h"
#include "mlspaces/core/npy.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/library/annotation.h"

namespace mlspaces::python {

namespace nb = nanobind;

/// A JSON value as new Python objects: dict (key order kept), list, str, int, float, bool,
/// None.
nb::object JsonToPython(const Json& value);

/// A fresh numpy array of `Elem` with `shape` over the buffer of `values`, which moves into the
/// array's owner (no copy); sizeof(T) must be a whole number of `Elem`s.
template <class Elem, class T>
nb::object OwnedNumpy(std::vector<T> values, const std::vector<size_t>& shape) {
  static_assert(sizeof(T) % sizeof(Elem) == 0);
  auto* owned = new std::vector<T>(std::move(values));
  nb::capsule owner(owned, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::cast(nb::ndarray<nb::numpy, Elem>(reinterpret_cast<Elem*>(owned->data()), shape.size(),
                                               shape.data(), owner));
}

/// A fresh numpy array (owning a copy) with the array's dtype and shape.
nb::object NpyToNumpy(const NpyArray& array);
/// An annotation as a new dict: its JSON with every NPZ array inserted at its '/'-path as a
/// numpy array of the stored dtype and shape.
nb::object AnnotationToPython(const Annotation& annotation);
/// As above, but each array is a read-only numpy view of `annotation`'s own buffer, which the
/// view keeps alive (no copy: the Registry's cached annotations are immutable). Not null.
nb::object AnnotationToPython(std::shared_ptr<const Annotation> annotation);

/// Poses as a fresh float64 numpy array (N,4,4), owning its buffer (no copy of `poses`' buffer:
/// the vector is moved into the array's owner).
nb::object PosesToNumpy(std::vector<Mat4> poses);
/// Any array-like of shape (4,4) (numpy of any real dtype, nested lists) as a Mat4.
/// @throws Error naming `what` for another shape, a non-numeric or non-finite value.
Mat4 Mat4FromPython(nb::handle value, const std::string& what);
/// Any array-like of shape (N,4,4) as poses. @throws Error as Mat4FromPython.
std::vector<Mat4> PosesFromPython(nb::handle value, const std::string& what);
/// Any array-like of `n` numbers, shape (n,). @throws Error as Mat4FromPython.
std::vector<double> DoublesFromPython(nb::handle value, size_t n, const std::string& what);

/// pathlib.Path(path).
nb::object ToPathlib(const std::filesystem::path& path);

}  // namespace mlspaces::python
