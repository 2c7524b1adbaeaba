// mlspaces::Error -> mlspaces.errors.MlspacesError (a ValueError) with path, field and uid.
#include "bindings.h"

#include <exception>

#include "mlspaces/core/error.h"

namespace mlspaces::python {

namespace {

void RaiseAs(const char* type_name, const Error& e) {
  nb::object errors = nb::module_::import_("mlspaces.errors");
  nb::object type = errors.attr(type_name);
  nb::object value =
      type(nb::str(e.what()), nb::str(e.message().c_str()), nb::str(e.path().c_str()),
           nb::str(e.field().c_str()), nb::str(e.uid().c_str()));
  PyErr_SetObject(type.ptr(), value.ptr());
}

}  // namespace

void BindErrors(nb::module_& m) {
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const KeyLookupError& e) {
      RaiseAs("MlspacesKeyError", e);
    } catch (const UsageError& e) {
      RaiseAs("UsageError", e);
    } catch (const Error& e) {
      RaiseAs("MlspacesError", e);
    }
  });
  (void)m;
}

}  // namespace mlspaces::python
