// Material sprim: a UsdPreviewSurface's inputs.
#pragma once

#include "penumbra/material.h"
#include "penumbra/plugin/prim.h"

namespace penumbra::plugin {

class Material : public Prim {
 public:
  using Prim::Prim;

  /// Sets a UsdPreviewSurface input by name (diffuseColor, emissiveColor, specularColor,
  /// metallic, roughness, opacity, opacityThreshold, ior, clearcoat, clearcoatRoughness,
  /// useSpecularWorkflow, penumbra:transmissionRoughness, penumbra:abbeNumber).
  /// diffuseColor may instead name the primvar it reads: "primvar:displayColor".
  /// Throws std::invalid_argument for an unknown name or a value of the wrong type.
  void setParam(const std::string& name, const ParamValue& value);
  /// Back to the schema's fallback values.
  void resetParams();

  const MaterialParams& params() const { return params_; }

 private:
  MaterialParams params_;
};

}  // namespace penumbra::plugin
