// UsdPreviewSurface parameters (spec 2.5/2.6) with the schema's fallback values, plus Penumbra's
// extensions. The current integrator shades with the Lambertian lobe (diffuseColor) and
// emission; the other parameters are carried for the glossy/translucent lobes to come.
#pragma once

#include "penumbra/math.h"

namespace penumbra {

struct MaterialParams {
  Vec3f diffuseColor{0.18f};
  /// diffuseColor comes from each mesh's displayColor (a UsdPrimvarReader of displayColor).
  bool diffuseFromDisplayColor = false;
  Vec3f emissiveColor{0.0f};
  Vec3f specularColor{0.0f};
  bool useSpecularWorkflow = false;
  float metallic = 0;
  float roughness = 0.5f;
  float clearcoat = 0;
  float clearcoatRoughness = 0.01f;
  float opacity = 1;
  float opacityThreshold = 0;
  float ior = 1.5f;
  float transmissionRoughness = -1;  // inputs:penumbra:transmissionRoughness; < 0: roughness
  float abbeNumber = 0;              // inputs:penumbra:abbeNumber; 0: no dispersion
};

}  // namespace penumbra
