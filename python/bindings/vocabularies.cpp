// The vocabulary tables: the render options (plugin/render_settings.h), the light types and
// light inputs (plugin/light_types.h) and the material inputs (renderer/material_inputs.h), from
// which the Python front ends derive their flags, keywords, USD attributes, light schemas and the
// light and material inputs they read.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "bindings.h"
#include "penumbra/material_inputs.h"
#include "penumbra/plugin/light_types.h"
#include "penumbra/plugin/render_settings.h"

namespace py = pybind11;
using penumbra::MaterialInputInfo;
using penumbra::MaterialInputKind;
using penumbra::MaterialInputOrigin;
using penumbra::plugin::LightInputInfo;
using penumbra::plugin::LightInputKind;
using penumbra::plugin::LightInputOrigin;
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

const char* lightKindName(LightInputKind kind) {
  switch (kind) {
    case LightInputKind::Float:
      return "float";
    case LightInputKind::Color:
      return "color";
    case LightInputKind::Bool:
      return "bool";
    case LightInputKind::Asset:
      return "asset";
  }
  throw std::logic_error("unknown light input kind");
}

const char* lightOriginName(LightInputOrigin origin) {
  switch (origin) {
    case LightInputOrigin::LightAPI:
      return "LightAPI";
    case LightInputOrigin::LightSchema:
      return "light schema";
    case LightInputOrigin::ShapingAPI:
      return "ShapingAPI";
    case LightInputOrigin::ShadowAPI:
      return "ShadowAPI";
    case LightInputOrigin::FrontEnd:
      return "front end";
  }
  throw std::logic_error("unknown light input origin");
}

/// The sprim types of `input`'s light types.
std::vector<std::string> sprimTypes(const LightInputInfo& input) {
  std::vector<std::string> names;
  for (const LightTypeInfo& info : penumbra::plugin::lightTypes())
    for (const penumbra::LightType type : input.lightTypes)
      if (info.type == type) names.push_back(info.sprimType);
  return names;
}

const char* kindName(MaterialInputKind kind) {
  switch (kind) {
    case MaterialInputKind::Float:
      return "float";
    case MaterialInputKind::Vector:
      return "vector";
    case MaterialInputKind::Bool:
      return "bool";
    case MaterialInputKind::Token:
      return "token";
  }
  throw std::logic_error("unknown material input kind");
}

const char* originName(MaterialInputOrigin origin) {
  switch (origin) {
    case MaterialInputOrigin::PreviewSurface:
      return "UsdPreviewSurface";
    case MaterialInputOrigin::PreviewSurfaceExtension:
      return "UsdPreviewSurface extension";
    case MaterialInputOrigin::Extension:
      return "extension";
  }
  throw std::logic_error("unknown material input origin");
}

}  // namespace

namespace penumbra::bindings {

void bindVocabularies(py::module_& m) {
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
      .def("__repr__",
           [](const LightTypeInfo& info) { return "<LightType " + info.sprimType + ">"; });
  m.def("light_types", &penumbra::plugin::lightTypes, py::return_value_policy::reference,
        "Every light type the render delegate renders.");

  py::class_<LightInputInfo>(m, "LightInput", "An input set_light takes (plugin/light_types.h).")
      .def_readonly("name", &LightInputInfo::name,
                    "As UsdLux spells it without \"inputs:\" (\"shaping:cone:angle\").")
      .def_property_readonly(
          "kind", [](const LightInputInfo& input) { return lightKindName(input.kind); },
          "\"float\", \"color\" (a 3-tuple), \"bool\" or \"asset\" (a file's path).")
      .def_property_readonly(
          "origin", [](const LightInputInfo& input) { return lightOriginName(input.origin); },
          "Where a light has it: \"LightAPI\" (every light, mesh lights too), \"light schema\" "
          "(the schema of the light types light_types lists), \"ShapingAPI\" or \"ShadowAPI\" "
          "(where applied), or \"front end\" (no UsdLux input: the front end's choice).")
      .def_property_readonly("light_types", &sprimTypes,
                             "The sprim types of a \"light schema\" input's light types.")
      .def("__repr__",
           [](const LightInputInfo& input) { return "<LightInput " + input.name + ">"; });
  m.def("light_inputs", &penumbra::plugin::lightInputs, py::return_value_policy::reference,
        "Every input set_light takes: UsdLuxLightAPI's, the light schemas', ShapingAPI's, "
        "ShadowAPI's, then the front end's.");

  py::class_<MaterialInputInfo>(m, "MaterialInput",
                                "An input set_material takes (renderer/material_inputs.h).")
      .def_property_readonly("name",
                             [](const MaterialInputInfo& info) { return std::string(info.name); })
      .def_property_readonly(
          "kind", [](const MaterialInputInfo& info) { return kindName(info.kind); },
          "\"float\", \"vector\" (a 3-tuple: a colour, or the normal), \"bool\" or \"token\".")
      .def_property_readonly(
          "origin", [](const MaterialInputInfo& info) { return originName(info.origin); },
          "\"UsdPreviewSurface\" (the schema's own input), \"UsdPreviewSurface extension\" "
          "(Penumbra's, read from a UsdPreviewSurface shader) or \"extension\" (Penumbra's, "
          "set from MaterialX surfaces).")
      .def_property_readonly(
          "constant",
          [](const MaterialInputInfo& info) {
            return !std::holds_alternative<std::monostate>(info.member);
          },
          "Whether it takes a constant value (all but normal).")
      .def_property_readonly(
          "connectable", [](const MaterialInputInfo& info) { return info.connectable.has_value(); },
          "Whether a shader network may drive it.")
      .def_readonly("must_be_finite", &MaterialInputInfo::mustBeFinite)
      .def("__repr__", [](const MaterialInputInfo& info) {
        return "<MaterialInput " + std::string(info.name) + ">";
      });
  m.def("material_inputs", &materialInputs, py::return_value_policy::reference,
        "Every input set_material takes: UsdPreviewSurface's, then the extensions "
        "read from it, then the other extensions.");
}

}  // namespace penumbra::bindings
