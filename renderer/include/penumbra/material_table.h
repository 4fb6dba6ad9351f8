// The scene's materials, the textures they read, and the registry of the primvar names that
// enter the scene (so that lookups by a name's 64-bit key never mistake one primvar for another).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "penumbra/bsdf.h"
#include "penumbra/material.h"
#include "penumbra/mesh.h"
#include "penumbra/texture.h"

namespace penumbra {

/// Whether a material cuts whole surfaces out (constant opacity below its threshold).
bool cutsOutWhole(const Material& material);
/// Whether a material cuts surfaces out per hit (textured opacity with a threshold).
bool cutsOutPerHit(const Material& material);

class MaterialTable {
 public:
  /// Material index meaning "none bound": displayColor is the albedo.
  static constexpr int kNoMaterial = -1;

  /// `colorConfig`: the OCIO config that linearises textures (empty: $OCIO).
  explicit MaterialTable(const std::string& colorConfig);

  /// What replacing a material changed of its cut-outs (cutsOutWhole, cutsOutPerHit): only
  /// those make the surfaces using it depend on it outside of shading.
  struct CutoutChange {
    bool whole = false;
    bool perHit = false;
  };
  /// Sets the material at `index` (at most materialCount(): that appends one), leaving the
  /// others as they are, and registers the primvar names it reads. Materials are referenced by
  /// index; their texture handles refer to textures(). Scene::setMaterial has the surfaces
  /// using it follow the change. Throws std::out_of_range for an index past the end,
  /// std::invalid_argument (leaving the table as it was) for a primvar name whose key another
  /// name has.
  CutoutChange replace(size_t index, Material material);
  size_t materialCount() const { return materials_.size(); }
  /// The material at `index`, or null for kNoMaterial or an index past the end.
  const Material* find(int index) const {
    return index < 0 || size_t(index) >= materials_.size() ? nullptr : &materials_[size_t(index)];
  }

  /// The parameters every hit of the material at `index` takes where it does not vary: its
  /// constants with the opacity threshold applied (applyOpacityThreshold). Made once here, so
  /// that hits read them in place. `index` must be a material's.
  const MaterialParams& shadedConstants(int index) const { return shadedConstants_[size_t(index)]; }
  /// The BSDF of the material at `index` as set up for any hit (see PreviewSurfaceBsdf's
  /// turning constructor), for the dielectric kind of the surface hit; null where a hit must set
  /// it up itself: no material, a varying or anisotropic one, or a hair material.
  const PreviewSurfaceBsdf* bsdfPrototype(int index, DielectricKind kind) const {
    if (!find(index)) return nullptr;
    const auto& prototypes = bsdfPrototypes_[size_t(index)];
    return prototypes ? &(*prototypes)[size_t(kind)] : nullptr;
  }
  /// The textures materials read; open files here before referencing them.
  TextureSystem& textures() { return *textures_; }
  const TextureSystem& textures() const { return *textures_; }
  /// The same, for what may outlive the scene (light textures read through it).
  const std::shared_ptr<TextureSystem>& sharedTextures() { return textures_; }

  /// Remembers a primvar name entering the scene. Throws std::invalid_argument when another
  /// name has its key.
  void registerPrimvarName(const PrimvarName& name);
  /// The same check, for a name that is looked up without being stored (an AOV's).
  void checkPrimvarName(const PrimvarName& name) const;

  /// Decides spectral() from the materials as they are now (at Scene::commit).
  void commit();
  /// True when a material disperses light (abbeNumber > 0 on a translucent material): paths
  /// are then traced spectrally.
  bool spectral() const { return spectral_; }

 private:
  std::vector<Material> materials_;
  std::vector<MaterialParams> shadedConstants_;  // by material index (shadedConstants)
  /// By material index and DielectricKind: the BSDFs of materials that do not vary (as
  /// shading sees their constants), empty for the others.
  std::vector<std::optional<std::array<PreviewSurfaceBsdf, 2>>> bsdfPrototypes_;
  std::unordered_map<uint64_t, std::string> primvarNames_;  // by key, every name registered
  std::shared_ptr<TextureSystem> textures_;
  bool spectral_ = false;
};

}  // namespace penumbra
