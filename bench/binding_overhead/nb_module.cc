#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>

#include "lookup.h"

namespace nb = nanobind;

NB_MODULE(nb_lookup, m) {
  m.def("noop", [] {});
  nb::class_<Table>(m, "Table")
      .def(nb::init<>())
      .def("locate",
           [](const Table& t, const std::string& uid) -> nb::object {
             const std::string* p = t.Find(uid);
             if (p == nullptr) return nb::none();
             return nb::make_tuple("lib", nb::none(), *p);
           })
      .def("annotation", [](const Table& t, const std::string& uid) -> nb::object {
        const std::string* p = t.Find(uid);
        if (p == nullptr) return nb::none();
        nb::dict box;
        box["x"] = 0.05;
        box["y"] = 0.05;
        box["z"] = 0.05;
        nb::dict d;
        d["uid"] = uid;
        d["mass"] = 0.062;
        d["boundingBox"] = box;
        return d;
      });
}
