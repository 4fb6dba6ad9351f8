// The render options table (plugin/render_settings.h) and the light types table
// (plugin/light_types.h), from which the Python front ends derive their flags, keywords,
// USD attributes and light schemas.
#include "penumbra/plugin/render_settings.h"

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>

#include "bindings.h"
#include "penumbra/plugin/light_types.h"

namespace py = pybind11;
using penumbra::plugin::LightTypeInfo;
using penumbra::plugin::RenderOption;
using penumbra::plugin::RenderOptionType;

namespace {

const char* typeName(RenderOptionType type) {
  switch (type) {
    case RenderOptionType::Int:
      return "int";
    case RenderOptionType::Float:
      return "float";
    case RenderOptionType::Level:
      return "level";
  }
  throw std::logic_error("unknown render option type");
}

/// A value of `option` as Python gives it: an int, a float or a level's name.
py::object pythonValue(const RenderOption& option, double value) {
  switch (option.type) {
    case RenderOptionType::Int:
      return py::int_(int(value));
    case RenderOptionType::Float:
      return py::float_(value);
    case RenderOptionType::Level:
      return py::str(option.levels.at(size_t(value)));
  }
  throw std::logic_error("unknown render option type");
}

}  // namespace

namespace penumbra::bindings {

void bindRenderSettings(py::module_& m) {
  py::class_<RenderOption>(m, "RenderOption",
                           "A render option of the render delegate (set_render_setting's key).")
      .def_readonly("key", &RenderOption::key)
      .def_property_readonly("type",
                             [](const RenderOption& option) { return typeName(option.type); })
      .def_property_readonly(
          "default",
          [](const RenderOption& option) { return pythonValue(option, option.frontEndDefault); },
          "What penumbra-record and Renderer.render use unless told otherwise.")
      .def_property_readonly(
          "delegate_default",
          [](const RenderOption& option) { return pythonValue(option, option.defaultValue); },
          "What a RenderDelegate starts with.")
      .def_readonly("minimum", &RenderOption::minimum)
      .def_readonly("maximum", &RenderOption::maximum)
      .def_readonly("levels", &RenderOption::levels)
      .def_readonly("help", &RenderOption::help)
      .def_readonly("default_meaning", &RenderOption::defaultMeaning)
      .def_readonly("metavar", &RenderOption::metavar)
      .def_readonly("short_flag", &RenderOption::shortFlag)
      .def_readonly("usdrecord_flag", &RenderOption::usdrecordFlag)
      .def_readonly("changes_pixels", &RenderOption::changesPixels)
      .def_readonly("user_set", &RenderOption::userSet)
      .def("problem", &RenderOption::problem, py::arg("value"),
           "Why the delegate's value `value` cannot be this option's, or an empty string.")
      .def("__repr__",
           [](const RenderOption& option) { return "<RenderOption " + option.key + ">"; });
  m.def("render_options", &penumbra::plugin::renderOptions, py::return_value_policy::reference,
        "Every render option, in the order front ends list them.");

  py::class_<LightTypeInfo>(m, "LightType", "A supported UsdLux light type.")
      .def_readonly("schema", &LightTypeInfo::schema)
      .def_readonly("sprim_type", &LightTypeInfo::sprimType)
      .def_readonly("shape_inputs", &LightTypeInfo::shapeInputs)
      .def("__repr__",
           [](const LightTypeInfo& info) { return "<LightType " + info.sprimType + ">"; });
  m.def("light_types", &penumbra::plugin::lightTypes, py::return_value_policy::reference,
        "Every light type the render delegate renders.");
}

}  // namespace penumbra::bindings
