#include "penumbra/plugin/material.h"

#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {

void Material::setParam(const std::string& name, const ParamValue& value) {
  try {
    MaterialParams& p = params_;
    if (name == "diffuseColor")
      p.diffuseColor = paramAsColor(name, value);
    else if (name == "emissiveColor")
      p.emissiveColor = paramAsColor(name, value);
    else if (name == "specularColor")
      p.specularColor = paramAsColor(name, value);
    else if (name == "useSpecularWorkflow")
      p.useSpecularWorkflow = paramAsBool(name, value);
    else if (name == "metallic")
      p.metallic = paramAsFloat(name, value);
    else if (name == "roughness")
      p.roughness = paramAsFloat(name, value);
    else if (name == "clearcoat")
      p.clearcoat = paramAsFloat(name, value);
    else if (name == "clearcoatRoughness")
      p.clearcoatRoughness = paramAsFloat(name, value);
    else if (name == "opacity")
      p.opacity = paramAsFloat(name, value);
    else if (name == "opacityThreshold")
      p.opacityThreshold = paramAsFloat(name, value);
    else if (name == "ior")
      p.ior = paramAsFloat(name, value);
    else if (name == "penumbra:transmissionRoughness")
      p.transmissionRoughness = paramAsFloat(name, value);
    else if (name == "penumbra:abbeNumber")
      p.abbeNumber = paramAsFloat(name, value);
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
