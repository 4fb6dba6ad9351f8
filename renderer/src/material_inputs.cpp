#include "penumbra/material_inputs.h"

#include <algorithm>
#include <array>
#include <stdexcept>

namespace penumbra {
namespace {

using Kind = MaterialInputKind;
using Origin = MaterialInputOrigin;
using Params = MaterialParams;

// MaterialInput's enumerators, Normal being the last.
constexpr size_t kConnectableCount = size_t(MaterialInput::Normal) + 1;

}  // namespace

const std::vector<MaterialInputInfo>& materialInputs() {
  static const std::vector<MaterialInputInfo> inputs = {
      {"diffuseColor", Kind::Vector, Origin::PreviewSurface, &Params::diffuseColor,
       MaterialInput::DiffuseColor, false},
      {"emissiveColor", Kind::Vector, Origin::PreviewSurface, &Params::emissiveColor,
       MaterialInput::EmissiveColor, true},
      {"specularColor", Kind::Vector, Origin::PreviewSurface, &Params::specularColor,
       MaterialInput::SpecularColor, false},
      {"metallic", Kind::Float, Origin::PreviewSurface, &Params::metallic, MaterialInput::Metallic,
       false},
      {"roughness", Kind::Float, Origin::PreviewSurface, &Params::roughness,
       MaterialInput::Roughness, false},
      {"opacity", Kind::Float, Origin::PreviewSurface, &Params::opacity, MaterialInput::Opacity,
       false},
      {"opacityThreshold", Kind::Float, Origin::PreviewSurface, &Params::opacityThreshold,
       std::nullopt, false},
      {"ior", Kind::Float, Origin::PreviewSurface, &Params::ior, MaterialInput::Ior, false},
      {"clearcoat", Kind::Float, Origin::PreviewSurface, &Params::clearcoat,
       MaterialInput::Clearcoat, false},
      {"clearcoatRoughness", Kind::Float, Origin::PreviewSurface, &Params::clearcoatRoughness,
       MaterialInput::ClearcoatRoughness, false},
      {"useSpecularWorkflow", Kind::Bool, Origin::PreviewSurface, &Params::useSpecularWorkflow,
       std::nullopt, false},
      {"normal", Kind::Vector, Origin::PreviewSurface, std::monostate{}, MaterialInput::Normal,
       false},
      {"penumbra:clearcoatIor", Kind::Float, Origin::PreviewSurfaceExtension, &Params::clearcoatIor,
       std::nullopt, false},
      {"penumbra:metalWhiteEdge", Kind::Bool, Origin::PreviewSurfaceExtension,
       &Params::metalWhiteEdge, std::nullopt, false},
      {"penumbra:transmissionRoughness", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::transmissionRoughness, std::nullopt, false},
      {"penumbra:abbeNumber", Kind::Float, Origin::PreviewSurfaceExtension, &Params::abbeNumber,
       std::nullopt, false},
      {"penumbra:thinWalled", Kind::Bool, Origin::PreviewSurfaceExtension, &Params::thinWalled,
       std::nullopt, false},
      {"penumbra:hair", Kind::Bool, Origin::PreviewSurfaceExtension, &Params::hair, std::nullopt,
       false},
      {"penumbra:hairAbsorption", Kind::Vector, Origin::PreviewSurfaceExtension,
       &Params::hairAbsorption, MaterialInput::HairAbsorption, true},
      {"penumbra:hairAbsorptionFromColor", Kind::Bool, Origin::PreviewSurfaceExtension,
       &Params::hairAbsorptionFromColor, std::nullopt, false},
      {"penumbra:hairAbsorptionFromMelanin", Kind::Bool, Origin::PreviewSurfaceExtension,
       &Params::hairAbsorptionFromMelanin, std::nullopt, false},
      {"penumbra:hairColor", Kind::Vector, Origin::PreviewSurfaceExtension, &Params::hairColor,
       MaterialInput::HairColor, true},
      {"penumbra:hairColorAzimuthalRoughness", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairColorAzimuthalRoughness, std::nullopt, true},
      {"penumbra:hairMelanin", Kind::Float, Origin::PreviewSurfaceExtension, &Params::hairMelanin,
       MaterialInput::HairMelanin, true},
      {"penumbra:hairMelaninRedness", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairMelaninRedness, MaterialInput::HairMelaninRedness, true},
      {"penumbra:hairLongitudinalRoughness", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairLongitudinalRoughness, MaterialInput::HairLongitudinalRoughness, true},
      {"penumbra:hairAzimuthalRoughness", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairAzimuthalRoughness, MaterialInput::HairAzimuthalRoughness, true},
      {"penumbra:hairLongitudinalScaleTT", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairLongitudinalScaleTT, std::nullopt, true},
      {"penumbra:hairLongitudinalScaleTRT", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairLongitudinalScaleTRT, std::nullopt, true},
      {"penumbra:hairAzimuthalScaleTT", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairAzimuthalScaleTT, std::nullopt, true},
      {"penumbra:hairAzimuthalScaleTRT", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairAzimuthalScaleTRT, std::nullopt, true},
      {"penumbra:hairCuticleAngle", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::hairCuticleAngle, MaterialInput::HairCuticleAngle, true},
      {"penumbra:hairIor", Kind::Float, Origin::PreviewSurfaceExtension, &Params::hairIor,
       std::nullopt, true},
      {"penumbra:hairTintR", Kind::Vector, Origin::PreviewSurfaceExtension, &Params::hairTintR,
       MaterialInput::HairTintR, true},
      {"penumbra:hairTintTT", Kind::Vector, Origin::PreviewSurfaceExtension, &Params::hairTintTT,
       MaterialInput::HairTintTT, true},
      {"penumbra:hairTintTRT", Kind::Vector, Origin::PreviewSurfaceExtension, &Params::hairTintTRT,
       MaterialInput::HairTintTRT, true},
      {"penumbra:subsurface", Kind::Float, Origin::PreviewSurfaceExtension, &Params::subsurface,
       MaterialInput::Subsurface, true},
      {"penumbra:subsurfaceColor", Kind::Vector, Origin::PreviewSurfaceExtension,
       &Params::subsurfaceColor, MaterialInput::SubsurfaceColor, true},
      {"penumbra:subsurfaceRadius", Kind::Vector, Origin::PreviewSurfaceExtension,
       &Params::subsurfaceRadius, MaterialInput::SubsurfaceRadius, true},
      {"penumbra:subsurfaceAnisotropy", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::subsurfaceAnisotropy, std::nullopt, true},
      {"penumbra:transmissionDepth", Kind::Float, Origin::PreviewSurfaceExtension,
       &Params::transmissionDepth, std::nullopt, true},
      {"penumbra:transmissionColor", Kind::Vector, Origin::PreviewSurfaceExtension,
       &Params::transmissionColor, std::nullopt, true},
      {"penumbra:clearcoatColor", Kind::Vector, Origin::Extension, &Params::clearcoatColor,
       MaterialInput::ClearcoatColor, true},
      {"penumbra:specularWeight", Kind::Float, Origin::Extension, &Params::specularWeight,
       std::nullopt, true},
      {"penumbra:sheen", Kind::Float, Origin::Extension, &Params::sheen, MaterialInput::Sheen,
       true},
      {"penumbra:sheenColor", Kind::Vector, Origin::Extension, &Params::sheenColor,
       MaterialInput::SheenColor, true},
      {"penumbra:sheenRoughness", Kind::Float, Origin::Extension, &Params::sheenRoughness,
       MaterialInput::SheenRoughness, true},
      {"penumbra:anisotropy", Kind::Float, Origin::Extension, &Params::anisotropy,
       MaterialInput::Anisotropy, true},
      {"penumbra:clearcoatAnisotropy", Kind::Float, Origin::Extension, &Params::clearcoatAnisotropy,
       MaterialInput::ClearcoatAnisotropy, true},
      {"penumbra:anisotropyRotation", Kind::Float, Origin::Extension, &Params::anisotropyRotation,
       MaterialInput::AnisotropyRotation, true},
      {"penumbra:anisotropyModel", Kind::Token, Origin::Extension, &Params::anisotropyModel,
       std::nullopt, false},
  };
  return inputs;
}

const MaterialInputInfo* findMaterialInput(std::string_view name) {
  const std::vector<MaterialInputInfo>& inputs = materialInputs();
  const auto found = std::find_if(inputs.begin(), inputs.end(),
                                  [&](const MaterialInputInfo& info) { return info.name == name; });
  return found == inputs.end() ? nullptr : &*found;
}

const MaterialInputInfo& materialInputInfo(MaterialInput input) {
  // Looked up for every connected input at every shading point: indexed, not searched.
  static const std::array<const MaterialInputInfo*, kConnectableCount> byInput = [] {
    std::array<const MaterialInputInfo*, kConnectableCount> result{};
    for (const MaterialInputInfo& info : materialInputs())
      if (info.connectable) result[size_t(*info.connectable)] = &info;
    if (std::find(result.begin(), result.end(), nullptr) != result.end())
      throw std::logic_error("a MaterialInput is missing from the material input table");
    return result;
  }();
  return *byInput[size_t(input)];
}

bool isVectorInput(MaterialInput input) {
  return materialInputInfo(input).kind == MaterialInputKind::Vector;
}

}  // namespace penumbra
