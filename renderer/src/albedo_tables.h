// Directional and hemispherical-average albedos of GGX lobes, for energy compensation: the
// layering of the BSDF (what a specular layer or a coat lets through), Kulla–Conty's
// multiple-scattering term and the rough dielectric's albedo scaling. Tables are computed at
// first use by integrating with stratified visible-normal samples; their lookups are inline (on
// every evaluation's path), their construction out of line.
#pragma once

#include <array>

#include "microfacet.h"
#include "penumbra/math.h"

namespace penumbra {

/// Where `coordinate` in [0, 1] falls on a grid of `size` nodes including both ends.
struct GridCell {
  int index;       // lower node
  float fraction;  // position between it and the next, for linear interpolation
};
inline GridCell gridCell(float coordinate, int size) {
  const float x = clamp01(coordinate) * float(size - 1);
  const int index = std::min(int(x), size - 2);
  return {index, x - float(index)};
}

/// E_F(μ, α) = F0·A(μ, α) + B(μ, α) is the directional albedo of single-scattering GGX reflection
/// with Schlick's Fresnel (F90 = 1), and E = A + B the albedo for F = 1. Tabulated over
/// roughness r = √α and μ = cos θo, both on [0, 1] with end points included, and computed at
/// first use by integrating with stratified visible-normal samples.
class GgxAlbedoTable {
 public:
  static constexpr int kSize = 32;
  static constexpr int kStrata = 16;  // kStrata² samples per entry

  GgxAlbedoTable();

  struct Albedo {
    float scale = 0, bias = 0;  // A and B
  };
  Albedo directional(float cosTheta, float alpha) const {
    const GridCell r = cell(std::sqrt(alpha)), m = cell(cosTheta);
    const auto at = [&](const std::array<float, kSize * kSize>& table) {
      const float* row0 = &table[r.index * kSize];
      const float* row1 = row0 + kSize;
      const float lower = row0[m.index] + m.fraction * (row0[m.index + 1] - row0[m.index]);
      const float upper = row1[m.index] + m.fraction * (row1[m.index + 1] - row1[m.index]);
      return lower + r.fraction * (upper - lower);
    };
    return {at(scale_), at(bias_)};
  }
  /// 2∫ A(μ) μ dμ and 2∫ B(μ) μ dμ, exactly for directional()'s interpolation in μ.
  Albedo average(float alpha) const {
    const GridCell r = cell(std::sqrt(alpha));
    const auto at = [&](const std::array<float, kSize>& table) {
      return table[r.index] + r.fraction * (table[r.index + 1] - table[r.index]);
    };
    return {at(averageScale_), at(averageBias_)};
  }

 private:
  static GridCell cell(float coordinate) { return gridCell(coordinate, kSize); }

  std::array<float, kSize * kSize> scale_{}, bias_{};
  std::array<float, kSize> averageScale_{}, averageBias_{};
};

inline const GgxAlbedoTable& ggxAlbedoTable() {
  static const GgxAlbedoTable table;  // built once, thread-safe, immutable afterwards
  return table;
}

/// The albedo terms of an anisotropic lobe (see ggxDirectionalAlbedo), out of line with its
/// table's initialisation so that ggxDirectionalAlbedo stays small.
GgxAlbedoTable::Albedo anisotropicGgxDirectionalAlbedo(const Vec3f& w, GgxAlpha alpha);
/// Their hemispherical averages.
GgxAlbedoTable::Albedo anisotropicGgxAverageAlbedo(GgxAlpha alpha);

/// A GGX lobe's albedo terms for light from local direction w (w.z > 0; isotropic lobes read
/// only w.z), and their hemispherical averages. Always inlined: the isotropic lookup is on every
/// evaluation's path.
[[gnu::always_inline]] inline GgxAlbedoTable::Albedo ggxDirectionalAlbedo(const Vec3f& w,
                                                                          GgxAlpha alpha) {
  if (alpha.isotropic()) return ggxAlbedoTable().directional(w.z, alpha.x);
  return anisotropicGgxDirectionalAlbedo(w, alpha);
}
inline GgxAlbedoTable::Albedo ggxAverageAlbedo(GgxAlpha alpha) {
  return alpha.isotropic() ? ggxAlbedoTable().average(alpha.x) : anisotropicGgxAverageAlbedo(alpha);
}

/// Directional albedo E(μ, α, η) of single-scattering GGX on a solid dielectric interface: the
/// energy reflected plus refracted (as flux, so without the 1/η² radiance scaling) by the exact
/// Fresnel equations for light from μ = cos θ on the side of index n_i, η = n_t / n_i. The rest
/// is lost to masking; the BSDF divides by E to put it back (albedo scaling). The table spans
/// μ and roughness r = √α on [0, 1] and the normal-incidence reflection coefficient
/// (η − 1)/(η + 1), the same for η and 1/η, on [0, 0.5] (η up to 3), separately for η ≥ 1 and
/// η < 1 (total internal reflection), end points included. Computed at first use.
class GgxDielectricAlbedoTable {
 public:
  static constexpr int kCosines = 16, kRoughnesses = 16, kIors = 8;
  static constexpr int kStrata = 12;  // kStrata² samples per entry
  static constexpr float kMaxReflectionCoefficient = 0.5f;

  GgxDielectricAlbedoTable();

  float albedo(float cosTheta, float alpha, float eta) const {
    const int side = eta >= 1 ? 0 : 1;
    const GridCell k = gridCell(std::fabs(eta - 1) / (eta + 1) / kMaxReflectionCoefficient, kIors);
    const GridCell r = gridCell(std::sqrt(alpha), kRoughnesses);
    const GridCell m = gridCell(cosTheta, kCosines);
    float value = 0;
    for (int dk = 0; dk < 2; ++dk) {
      for (int dr = 0; dr < 2; ++dr) {
        for (int dm = 0; dm < 2; ++dm) {
          const float weight = (dk ? k.fraction : 1 - k.fraction) *
                               (dr ? r.fraction : 1 - r.fraction) *
                               (dm ? m.fraction : 1 - m.fraction);
          value += weight * albedo_[index(side, k.index + dk, r.index + dr, m.index + dm)];
        }
      }
    }
    return value;
  }

 private:
  static int index(int side, int ior, int roughness, int cosine) {
    return ((side * kIors + ior) * kRoughnesses + roughness) * kCosines + cosine;
  }
  /// Both continuations of each visible normal, weighted by their Fresnel probabilities, each
  /// with its visible-normal-sampling weight G2 / G1(wo).
  static float integrate(float cosThetaO, float alpha, float eta);

  std::array<float, 2 * kIors * kRoughnesses * kCosines> albedo_{};
};

inline const GgxDielectricAlbedoTable& ggxDielectricAlbedoTable() {
  static const GgxDielectricAlbedoTable table;  // built once, thread-safe, immutable afterwards
  return table;
}

}  // namespace penumbra
