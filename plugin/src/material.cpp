#include "penumbra/plugin/material.h"

#include <map>

#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {

void Material::setParam(const std::string& name, const ParamValue& value) {
  static const std::map<std::string, float MaterialParams::*> numbers = {
      {"metallic", &MaterialParams::metallic},
      {"roughness", &MaterialParams::roughness},
      {"clearcoat", &MaterialParams::clearcoat},
      {"clearcoatRoughness", &MaterialParams::clearcoatRoughness},
      {"opacity", &MaterialParams::opacity},
      {"opacityThreshold", &MaterialParams::opacityThreshold},
      {"ior", &MaterialParams::ior},
      {"penumbra:transmissionRoughness", &MaterialParams::transmissionRoughness},
      {"penumbra:abbeNumber", &MaterialParams::abbeNumber}};
  static const std::map<std::string, Vec3f MaterialParams::*> colors = {
      {"diffuseColor", &MaterialParams::diffuseColor},
      {"emissiveColor", &MaterialParams::emissiveColor},
      {"specularColor", &MaterialParams::specularColor}};
  try {
    if (name == "diffuseColor" && std::holds_alternative<std::string>(value)) {
      if (std::get<std::string>(value) != "primvar:displayColor")
        throw std::invalid_argument("diffuseColor can name only the primvar displayColor, not '" +
                                    std::get<std::string>(value) + "'");
      params_.diffuseFromDisplayColor = true;
    } else if (const auto number = numbers.find(name); number != numbers.end())
      params_.*(number->second) = paramAsFloat(name, value);
    else if (const auto color = colors.find(name); color != colors.end())
      params_.*(color->second) = paramAsColor(name, value);
    else if (name == "useSpecularWorkflow")
      params_.useSpecularWorkflow = paramAsBool(name, value);
    else
      throw std::invalid_argument("unknown UsdPreviewSurface input '" + name + "'");
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(id() + ": " + error.what());
  }
  markDirty(DirtyParams);
}

void Material::resetParams() {
  params_ = MaterialParams{};
  markDirty(DirtyParams);
}

}  // namespace penumbra::plugin
