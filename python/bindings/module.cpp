// penumbra._core: Python bindings of the render delegate (plugin/) and the image I/O.
// See docs/core-api.md. Heavy data crosses as numpy buffers; errors map to ValueError
// (bad values), KeyError (unknown prim ids) and RuntimeError (files, Embree). Each area is
// bound by its own file (bindings.h).
#include <pybind11/pybind11.h>

#include <exception>
#include <stdexcept>
#include <string>

#include "bindings.h"

namespace py = pybind11;
using namespace penumbra::bindings;

PYBIND11_MODULE(_core, m) {
  m.doc() = "Penumbra's render delegate and image I/O (see docs/core-api.md)";
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const std::out_of_range& error) {
      PyErr_SetString(PyExc_KeyError, error.what());
    }
  });

  m.def("version", [] { return std::string(PENUMBRA_VERSION); });

  DelegateClass delegate(m, "RenderDelegate");
  delegate.def(py::init<const std::string&>(), py::arg("ocio_config") = "");
  bindScene(m, delegate);
  bindPoints(m, delegate);
  bindCurves(m, delegate);
  bindVolumes(m, delegate);
  bindMaterials(m, delegate);
  bindRender(m, delegate);
  bindImages(m);
  bindVocabularies(m);
}
