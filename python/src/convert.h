// Conversions between mlspaces values and Python objects, shared by the binding files.
#pragma once

#include <cstddef>
#include <filesystem>
#include <span>
#include <vector>

#include <nanobind/nanobind.h>
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
/// A Python dict/list/str/int/float/bool/None tree as JSON. @throws Error naming `what` for
/// anything else (or a non-str key, or a non-finite float).
Json PythonToJson(nb::handle value, const std::string& what);

/// A fresh numpy array (owning a copy) with the array's dtype and shape.
nb::object NpyToNumpy(const NpyArray& array);
/// An annotation as a new dict: its JSON with every NPZ array inserted at its '/'-path as a
/// numpy array of the stored dtype and shape.
nb::object AnnotationToPython(const Annotation& annotation);

/// Poses as a fresh float64 numpy array (N,4,4), owning its buffer (no copy of `poses`' buffer:
/// the vector is moved into the array's owner).
nb::object PosesToNumpy(std::vector<Mat4> poses);
/// One pose as a fresh float64 (4,4) array.
nb::object Mat4ToNumpy(const Mat4& pose);
/// Any array-like of shape (4,4) (numpy of any real dtype, nested lists) as a Mat4.
/// @throws Error naming `what` for another shape, a non-numeric or non-finite value.
Mat4 Mat4FromPython(nb::handle value, const std::string& what);
/// Any array-like of shape (N,4,4) as poses. @throws Error as Mat4FromPython.
std::vector<Mat4> PosesFromPython(nb::handle value, const std::string& what);

/// pathlib.Path(path).
nb::object ToPathlib(const std::filesystem::path& path);

}  // namespace mlspaces::python
