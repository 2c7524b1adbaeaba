#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "lookup.h"

namespace py = pybind11;

PYBIND11_MODULE(pb_lookup, m) {
  m.def("noop", [] {});
  py::class_<Table>(m, "Table")
      .def(py::init<>())
      .def("locate",
           [](const Table& t, const std::string& uid) -> py::object {
             const std::string* p = t.Find(uid);
             if (p == nullptr) return py::none();
             return py::make_tuple("lib", py::none(), *p);
           })
      .def("annotation", [](const Table& t, const std::string& uid) -> py::object {
        const std::string* p = t.Find(uid);
        if (p == nullptr) return py::none();
        py::dict box;
        box["x"] = 0.05;
        box["y"] = 0.05;
        box["z"] = 0.05;
        py::dict d;
        d["uid"] = uid;
        d["mass"] = 0.062;
        d["boundingBox"] = box;
        return d;
      });
}
