// Participating media bounded by volume prims (UsdVolVolume): fields (volume_field.h) combined
// by a volume material into the coefficients light transport needs, and a coarse grid of
// majorants over them so that free-flight sampling skips empty space. Plain data only; no USD.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "penumbra/math.h"
#include "penumbra/volume_field.h"

namespace penumbra {

/// What a volume is made of, per scene unit of length. With d(x) = density × the density
/// field (1 without one) and c(x) the colour field (1 without one):
///   scattering σs(x) = d(x) · scattering ⊙ c(x)
///   absorption σa(x) = d(x) · (absorption + principledAbsorption ⊙ max(1 − scattering ⊙ c(x), 0))
///   emission   E(x)  = emission ⊙ (the emission field, 1 without one)
///                      + blackbody(T(x)) · blackbodyTint · σ_SB T⁴ 10⁻⁶/π · blackbodyIntensity,
///                      T(x) = temperature × the temperature field (1 without one)
/// E is radiance added per unit length (as Cycles' volume emission). Cycles' Principled Volume
/// is scattering = colour, absorption = 0, principledAbsorption = 1 − √absorptionColour;
/// MaterialX's anisotropic_vdf is scattering and absorption as authored, principledAbsorption 0.
struct VolumeMaterial {
  float density = 1;
  Vec3f scattering{0.5f};
  Vec3f absorption{0.0f};
  Vec3f principledAbsorption{1.0f};
  float anisotropy = 0;  // Henyey–Greenstein g, in (−1, 1)
  Vec3f emission{0.0f};
  float blackbodyIntensity = 0;
  Vec3f blackbodyTint{1.0f};
  float temperature = 1000;  // kelvin, scaling the temperature field
};

/// A volume's fields and material. Any field may be absent; the medium fills `objectBounds`
/// (object space) where given, else the union of its fields' bounds.
struct VolumeData {
  std::shared_ptr<const VolumeField> density;      // scalar
  std::shared_ptr<const VolumeField> color;        // 1 or 3 components
  std::shared_ptr<const VolumeField> temperature;  // scalar
  std::shared_ptr<const VolumeField> emission;     // 1 or 3 components
  VolumeMaterial material;
  Bounds3f objectBounds;
};

/// Checks that a volume can be built: finite, non-negative coefficients and temperature,
/// anisotropy in (−1, 1), scalar density and temperature fields, and bounds that are finite
/// and not empty. Throws std::invalid_argument saying which value is wrong.
void validateVolume(const VolumeData& data);

/// The coefficients at a point (see VolumeMaterial).
struct MediumCoefficients {
  Vec3f scattering, absorption, emission;
};

/// A validated volume, in object space, immutable once built.
class Volume {
 public:
  /// Validates (validateVolume) and builds the majorant grid.
  explicit Volume(VolumeData data);

  MediumCoefficients at(const Vec3f& objectPoint) const;
  float anisotropy() const { return data_.material.anisotropy; }
  const Bounds3f& objectBounds() const { return bounds_; }
  bool emits() const { return emits_; }

  /// Bounds every component of σs + σa over a cell of the majorant grid, and exceeds 0 in
  /// cells where E may not be 0 (so that free-flight sampling visits them).
  float majorantOfCell(int x, int y, int z) const {
    return majorants_[size_t((z * cells_[1] + y) * cells_[0] + x)];
  }
  const int* majorantCells() const { return cells_; }
  const Vec3f& majorantCellSize() const { return cellSize_; }

  /// Bytes held by the fields and the majorant grid.
  size_t memoryBytes() const;
  uint64_t activeVoxels() const;

 private:
  VolumeData data_;
  Bounds3f bounds_;
  bool emits_ = false;
  // The majorant grid: cells_ cells over bounds_, x fastest.
  int cells_[3] = {1, 1, 1};
  Vec3f cellSize_;
  std::vector<float> majorants_;
};

/// A stretch [tStart, tEnd) of a ray over which `majorant` bounds every component of σs + σa.
struct MajorantSegment {
  float tStart = 0, tEnd = 0;
  float majorant = 0;
};

/// The majorant grid's cells that the object-space ray origin + t·direction crosses within
/// [tMin, tMax), nearest first (a 3D DDA); t is the ray's own parameter, so a ray placed by an
/// affine transform keeps its distances.
class MajorantWalk {
 public:
  MajorantWalk() = default;  // an empty walk
  MajorantWalk(const Volume& volume, const Vec3f& origin, const Vec3f& direction, float tMin,
               float tMax);
  /// The next segment; false when the ray has left the medium or reached tMax.
  bool next(MajorantSegment* segment);

 private:
  const Volume* volume_ = nullptr;
  float t_ = 0, tEnd_ = 0;
  int cell_[3] = {0, 0, 0};
  int step_[3] = {0, 0, 0};
  float tNext_[3] = {0, 0, 0};
  float tDelta_[3] = {0, 0, 0};
  bool done_ = true;
};

}  // namespace penumbra
