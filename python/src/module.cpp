// The extension module mocap._mocap (python/mocap/__init__.py imports it and
// documents the API; docs/python.md). Errors: mocap::InputError (bad input:
// a file, a query, a value) becomes mocap.InputError, a ValueError with
// `source`, `line` and `detail`; std::invalid_argument a ValueError;
// std::out_of_range an IndexError; other exceptions a RuntimeError.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "mocap/common/util/error.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_mocap, m) {
  m.doc() = "Bindings of the mocap libraries (use the package mocap).";
  m.attr("__version__") = MOCAP_VERSION;
  static py::exception<mocap::InputError> input_error(m, "InputError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const mocap::InputError& e) {
      py::object err = py::handle(input_error.ptr())(e.what());
      err.attr("source") = e.source();
      err.attr("line") = e.line();
      err.attr("detail") = e.detail();
      PyErr_SetObject(input_error.ptr(), err.ptr());
    }
  });
  mocap::python::bind_index(m);
  mocap::python::bind_search(m);
  mocap::python::bind_synth(m);
  mocap::python::bind_bvh(m);
  mocap::python::bind_style(m);
}
