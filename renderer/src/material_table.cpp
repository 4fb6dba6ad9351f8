#include "penumbra/material_table.h"

#include <algorithm>
#include <stdexcept>

#include "penumbra/spectrum.h"

namespace penumbra {

bool cutsOutWhole(const Material& material) {
  const MaterialParams& constants = material.constants;
  return !material.opacityVaries() && constants.opacityThreshold > 0 &&
         constants.opacity < constants.opacityThreshold;
}

bool cutsOutPerHit(const Material& material) {
  return material.opacityVaries() && material.constants.opacityThreshold > 0;
}

namespace {

/// The constants as every hit of the material takes them (MaterialTable::shadedConstants).
MaterialParams constantsAsShaded(const Material& material) {
  MaterialParams shaded = material.constants;
  applyOpacityThreshold(shaded);
  return shaded;
}

/// The BSDFs a material gives every hit, facing +z, for a solid and a thin sheet (`shaded`: its
/// shadedConstants); none where they depend on the hit (varying or anisotropic lobes) or it is
/// no UsdPreviewSurface (hair).
std::optional<std::array<PreviewSurfaceBsdf, 2>> bsdfPrototypes(const Material& material,
                                                                const MaterialParams& shaded) {
  if (material.varies() || material.constants.hair) return {};
  const Vec3f up(0, 0, 1);
  std::array<PreviewSurfaceBsdf, 2> prototypes{
      PreviewSurfaceBsdf(shaded, up, shaded.ior, DielectricKind::Solid),
      PreviewSurfaceBsdf(shaded, up, shaded.ior, DielectricKind::ThinSheet)};
  if (!prototypes[0].isotropic()) return {};  // its frame follows each hit's tangent
  return prototypes;
}

}  // namespace

MaterialTable::MaterialTable(const std::string& colorConfig)
    : textures_(std::make_shared<TextureSystem>(colorConfig)) {}

MaterialTable::CutoutChange MaterialTable::replace(size_t index, Material material) {
  if (index > materials_.size())
    throw std::out_of_range("material index " + std::to_string(index) + " past the " +
                            std::to_string(materials_.size()) + " materials");
  for (const InputConnection& connection : material.connections)
    registerPrimvarName(connection.primvar);
  for (const TextureReader& reader : material.textures)
    registerPrimvarName(reader.coordinates.primvar);
  for (const ExpressionProgram& program : material.programs)
    for (const ExpressionNode& node : program.nodes) registerPrimvarName(node.primvar);
  if (index == materials_.size()) {
    materials_.emplace_back();
    shadedConstants_.emplace_back();
    bsdfPrototypes_.emplace_back();
  }
  Material& replaced = materials_[index];
  const CutoutChange change{cutsOutWhole(material) != cutsOutWhole(replaced),
                            cutsOutPerHit(material) != cutsOutPerHit(replaced)};
  shadedConstants_[index] = constantsAsShaded(material);
  bsdfPrototypes_[index] = bsdfPrototypes(material, shadedConstants_[index]);
  replaced = std::move(material);
  return change;
}

void MaterialTable::checkPrimvarName(const PrimvarName& name) const {
  const auto found = primvarNames_.find(name.key());
  if (found != primvarNames_.end() && found->second != name.str())
    throw std::invalid_argument("primvar names '" + found->second + "' and '" + name.str() +
                                "' have the same 64-bit key; rename one of them");
}

void MaterialTable::registerPrimvarName(const PrimvarName& name) {
  if (name.empty()) return;
  checkPrimvarName(name);
  primvarNames_.emplace(name.key(), name.str());
}

void MaterialTable::commit() {
  spectral_ = std::any_of(materials_.begin(), materials_.end(), [](const Material& m) {
    return m.constants.abbeNumber > 0 && (m.constants.opacity < 1 || m.opacityVaries());
  });
  if (spectral_) prepareSpectralTables();  // now rather than on the first ray
}

}  // namespace penumbra
