// The sheen lobe: the "Charlie" distribution of microfibre normals (Estevez and Kulla 2017) with
// Smith's masking-shadowing computed numerically, and its directional albedo for the layering.
#pragma once

#include <array>

#include "albedo_tables.h"
#include "microfacet.h"
#include "penumbra/math.h"

namespace penumbra {

/// The smallest sheen α: below it (sin θh)^(1/α) underflows and the lobe carries no energy.
constexpr float kMinSheenAlpha = 0.01f;

/// The Charlie distribution of microfibre normals D(h) = (2 + 1/α) sin^(1/α) θh / (2π),
/// normalised so that ∫ D(h) cos θh dh = 1.
inline float charlieDensity(float cosThetaH, float alpha) {
  const float sin2ThetaH = std::max(0.0f, 1 - cosThetaH * cosThetaH);
  return (2 + 1 / alpha) * std::pow(sin2ThetaH, 0.5f / alpha) / (2 * kPi);
}

/// The sheen as a microfacet lobe without Fresnel: f cos θi = D(h) G2(wo, wi) / (4 cos θo), with
/// Smith's height-correlated G2 = 1 / (1 + Λ(wo) + Λ(wi)). Smith's Λ of the Charlie distribution
/// has no closed form (Estevez and Kulla fit one); it is computed here from its definition,
/// 1 + Λ(ω) = ∫ max(0, ω·m) D(m) dm / cos θ (the microfibres' projected area seen from ω over
/// the macro surface's). Tabulated at first use (only when a material has sheen), with the
/// lobe's directional albedo E(μ) for albedo scaling, over √α and √μ (μ = cos θ) on [0, 1] (α
/// clamped to kMinSheenAlpha), end points included: about 0.1 s, once.
class SheenTables {
 public:
  static constexpr int kSize = 32;
  static constexpr int kAreaSteps = 512;               // quadrature over cos θm per area entry
  static constexpr int kCosines = 64, kAzimuths = 32;  // quadrature grid per albedo entry

  SheenTables();

  /// Smith's Λ for a direction at cos θ = cosTheta (> 0).
  float lambda(float cosTheta, float alpha) const {
    return std::max(0.0f, lookup(projectedArea_, cosTheta, alpha) / cosTheta - 1);
  }
  /// Directional albedo of the white lobe.
  float albedo(float cosTheta, float alpha) const { return lookup(albedo_, cosTheta, alpha); }

  /// f · cos θi of the white lobe for wo.z, wi.z > 0, given Λ(wo) and Λ(wi).
  static float reflection(const Vec3f& wo, const Vec3f& wi, float alpha, float lambdaO,
                          float lambdaI) {
    const Vec3f h = normalize(wo + wi);
    return charlieDensity(h.z, alpha) / ((1 + lambdaO + lambdaI) * 4 * wo.z);
  }

 private:
  // Rows are spaced evenly in √α, which resolves the small α where the albedo changes fastest.
  static float rowAlpha(int row) {
    return std::max(square(float(row) / (kSize - 1)), kMinSheenAlpha);
  }
  // Columns are spaced evenly in √μ: the albedo changes fastest towards grazing angles. At μ = 0,
  // Λ is infinite; evaluate just above.
  static float columnCosine(int column) {
    return std::max(square(float(column) / (kSize - 1)), 1e-3f);
  }

  /// ∫ max(0, ω·m) D(m) dm for ω at cos θ = cosTheta: over φm in closed form (ω·m = a cos φm + b
  /// is positive on an arc), over cos θm by the midpoint rule.
  static float integrateProjectedArea(float cosTheta, float alpha);

  float lookup(const std::array<float, kSize * kSize>& table, float cosTheta, float alpha) const {
    const GridCell r = gridCell(std::sqrt(alpha), kSize), m = gridCell(std::sqrt(cosTheta), kSize);
    const float* row0 = &table[r.index * kSize];
    const float* row1 = row0 + kSize;
    const float lower = row0[m.index] + m.fraction * (row0[m.index + 1] - row0[m.index]);
    const float upper = row1[m.index] + m.fraction * (row1[m.index + 1] - row1[m.index]);
    return lower + r.fraction * (upper - lower);
  }

  std::array<float, kSize * kSize> projectedArea_{}, albedo_{};
};

inline const SheenTables& sheenTables() {
  static const SheenTables tables;  // built once, thread-safe, immutable afterwards
  return tables;
}

/// f · cos θi of the white sheen lobe with weight 1, for wo.z, wi.z > 0. Symmetric in wo and wi
/// once divided by cos θi.
inline float sheenReflection(const Vec3f& wo, const Vec3f& wi, float alpha) {
  const SheenTables& tables = sheenTables();
  return SheenTables::reflection(wo, wi, alpha, tables.lambda(wo.z, alpha),
                                 tables.lambda(wi.z, alpha));
}

}  // namespace penumbra
