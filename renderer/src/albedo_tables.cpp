#include "albedo_tables.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

namespace penumbra {
namespace {

/// 2∫ f(μ) μ dμ of the piecewise-linear interpolant of f at μ_k = k/(count − 1): on each
/// segment the integrand is quadratic and Simpson's rule is exact.
float hemisphericalAverage(const float* values, int count) {
  const double width = 1.0 / (count - 1);
  double sum = 0;
  for (int k = 0; k + 1 < count; ++k) {
    const double mu0 = k * width, mu1 = (k + 1) * width;
    sum += width * (values[k] * (2 * mu0 + mu1) + values[k + 1] * (mu0 + 2 * mu1)) / 6;
  }
  return float(2 * sum);
}

/// Both terms of a GGX lobe's Schlick-Fresnel albedo (GgxAlbedoTable) for light from wo, by
/// kStrata² stratified visible-normal samples.
template <int kStrata>
void integrateGgxAlbedo(const Vec3f& wo, GgxAlpha alpha, float* scale, float* bias) {
  double scaleSum = 0, biasSum = 0;
  const float masking = ggxMasking(wo, alpha);
  for (int i = 0; i < kStrata; ++i) {
    for (int j = 0; j < kStrata; ++j) {
      const Vec2f u{(float(i) + 0.5f) / kStrata, (float(j) + 0.5f) / kStrata};
      const Vec3f h = sampleGgxVisibleNormal(wo, alpha, u);
      const Vec3f wi = reflect(wo, h);
      if (wi.z <= 0) continue;
      // f cos θi / pdf for visible-normal sampling is G2 / G1(wo).
      const float weight = ggxMaskingShadowing(wo, wi, alpha) / masking;
      const float fresnel = schlickWeight(dot(wo, h));
      scaleSum += weight * (1 - fresnel);
      biasSum += weight * fresnel;
    }
  }
  *scale = float(scaleSum / (kStrata * kStrata));
  *bias = float(biasSum / (kStrata * kStrata));
}

/// The albedo terms A and B of GgxAlbedoTable for anisotropic lobes, which depend on the
/// azimuth φ of the direction too. Tabulated over μ = cos θ on [0, 1], φ folded into [0, π/2]
/// (the lobe is symmetric about both axes), √(αx / kMaxAlpha) on [0, 1] (OpenPBR's αx reaches √2)
/// and αy / αx on [0, 1] (the larger α is along x; lookups swap the axes otherwise), end points
/// included. Computed at first use (about 0.15 s), only when an anisotropic lobe is first
/// evaluated.
class AnisotropicGgxAlbedoTable {
 public:
  static constexpr int kCosines = 16, kAzimuths = 8, kRoughnesses = 12, kRatios = 8;
  static constexpr int kStrata = 12;  // kStrata² samples per entry
  static constexpr float kMaxAlpha = 1.41421356f;

  AnisotropicGgxAlbedoTable() {
    for (int r = 0; r < kRoughnesses; ++r) {
      for (int q = 0; q < kRatios; ++q) {
        const GgxAlpha alpha = nodeAlpha(r, q);
        for (int a = 0; a < kAzimuths; ++a) {
          const float phi = 0.5f * kPi * float(a) / (kAzimuths - 1);
          for (int m = 0; m < kCosines; ++m) {
            // At μ = 0 the integral has a limit but the sampling does not; evaluate just above.
            const float cosThetaO = std::max(float(m) / (kCosines - 1), 1e-3f);
            const float sinThetaO = std::sqrt(1 - cosThetaO * cosThetaO);
            const Vec3f wo(sinThetaO * std::cos(phi), sinThetaO * std::sin(phi), cosThetaO);
            const int i = index(r, q, a, m);
            integrateGgxAlbedo<kStrata>(wo, alpha, &scale_[size_t(i)], &bias_[size_t(i)]);
          }
        }
        // (1/π) ∫ E μ dμ dφ: Simpson-exact in μ, trapezoidal in φ.
        double scale = 0, bias = 0;
        for (int a = 0; a < kAzimuths; ++a) {
          const double weight = (a == 0 || a == kAzimuths - 1 ? 0.5 : 1.0) / (kAzimuths - 1);
          scale += weight * hemisphericalAverage(&scale_[size_t(index(r, q, a, 0))], kCosines);
          bias += weight * hemisphericalAverage(&bias_[size_t(index(r, q, a, 0))], kCosines);
        }
        averageScale_[size_t(r * kRatios + q)] = float(scale);
        averageBias_[size_t(r * kRatios + q)] = float(bias);
      }
    }
  }

  /// A and B for light from local direction w (w.z > 0).
  GgxAlbedoTable::Albedo directional(const Vec3f& w, GgxAlpha alpha) const {
    const float x = alpha.x >= alpha.y ? w.x : w.y, y = alpha.x >= alpha.y ? w.y : w.x;
    const GridCell a = gridCell(std::atan2(std::fabs(y), std::fabs(x)) / (0.5f * kPi), kAzimuths);
    const GridCell m = gridCell(w.z, kCosines);
    const auto [r, q] = cells(alpha);
    GgxAlbedoTable::Albedo result;
    for (int corner = 0; corner < 16; ++corner) {
      const int dr = corner & 1, dq = (corner >> 1) & 1, da = (corner >> 2) & 1, dm = corner >> 3;
      const float weight = (dr ? r.fraction : 1 - r.fraction) * (dq ? q.fraction : 1 - q.fraction) *
                           (da ? a.fraction : 1 - a.fraction) * (dm ? m.fraction : 1 - m.fraction);
      const size_t i = size_t(index(r.index + dr, q.index + dq, a.index + da, m.index + dm));
      result.scale += weight * scale_[i];
      result.bias += weight * bias_[i];
    }
    return result;
  }
  /// (1/π) ∫ A μ dω and (1/π) ∫ B μ dω over the hemisphere.
  GgxAlbedoTable::Albedo average(GgxAlpha alpha) const {
    const auto [r, q] = cells(alpha);
    GgxAlbedoTable::Albedo result;
    for (int corner = 0; corner < 4; ++corner) {
      const int dr = corner & 1, dq = corner >> 1;
      const float weight = (dr ? r.fraction : 1 - r.fraction) * (dq ? q.fraction : 1 - q.fraction);
      const size_t i = size_t((r.index + dr) * kRatios + q.index + dq);
      result.scale += weight * averageScale_[i];
      result.bias += weight * averageBias_[i];
    }
    return result;
  }

 private:
  static int index(int roughness, int ratio, int azimuth, int cosine) {
    return ((roughness * kRatios + ratio) * kAzimuths + azimuth) * kCosines + cosine;
  }
  static GgxAlpha nodeAlpha(int roughness, int ratio) {
    const float alongX = std::max(kMaxAlpha * square(float(roughness) / (kRoughnesses - 1)),
                                  PreviewSurfaceBsdf::kDeltaAlpha);
    return {alongX,
            std::max(alongX * float(ratio) / (kRatios - 1), PreviewSurfaceBsdf::kDeltaAlpha)};
  }
  static std::pair<GridCell, GridCell> cells(GgxAlpha alpha) {
    const float larger = std::max(alpha.x, alpha.y), smaller = std::min(alpha.x, alpha.y);
    return {gridCell(std::sqrt(larger / kMaxAlpha), kRoughnesses),
            gridCell(larger > 0 ? smaller / larger : 1.0f, kRatios)};
  }

  std::array<float, kRoughnesses * kRatios * kAzimuths * kCosines> scale_{}, bias_{};
  std::array<float, kRoughnesses * kRatios> averageScale_{}, averageBias_{};
};

const AnisotropicGgxAlbedoTable& anisotropicGgxAlbedoTable() {
  static const AnisotropicGgxAlbedoTable table;  // built once, thread-safe, immutable afterwards
  return table;
}

}  // namespace

GgxAlbedoTable::GgxAlbedoTable() {
  for (int row = 0; row < kSize; ++row) {
    const float alpha = std::max(square(float(row) / (kSize - 1)), PreviewSurfaceBsdf::kDeltaAlpha);
    for (int column = 0; column < kSize; ++column) {
      // At μ = 0 the integral has a limit but the sampling does not; evaluate just above.
      const float cosThetaO = std::max(float(column) / (kSize - 1), 1e-3f);
      const Vec3f wo(std::sqrt(1 - cosThetaO * cosThetaO), 0, cosThetaO);
      integrateGgxAlbedo<kStrata>(wo, alpha, &scale_[row * kSize + column],
                                  &bias_[row * kSize + column]);
    }
    averageScale_[row] = hemisphericalAverage(&scale_[row * kSize], kSize);
    averageBias_[row] = hemisphericalAverage(&bias_[row * kSize], kSize);
  }
}

GgxAlbedoTable::Albedo anisotropicGgxDirectionalAlbedo(const Vec3f& w, GgxAlpha alpha) {
  return anisotropicGgxAlbedoTable().directional(w, alpha);
}

GgxAlbedoTable::Albedo anisotropicGgxAverageAlbedo(GgxAlpha alpha) {
  return anisotropicGgxAlbedoTable().average(alpha);
}

GgxDielectricAlbedoTable::GgxDielectricAlbedoTable() {
  for (int side = 0; side < 2; ++side) {
    for (int k = 0; k < kIors; ++k) {
      const float coefficient = kMaxReflectionCoefficient * float(k) / (kIors - 1);
      const float denser = (1 + coefficient) / (1 - coefficient);
      const float eta = side == 0 ? denser : 1 / denser;
      for (int r = 0; r < kRoughnesses; ++r) {
        const float alpha =
            std::max(square(float(r) / (kRoughnesses - 1)), PreviewSurfaceBsdf::kDeltaAlpha);
        for (int m = 0; m < kCosines; ++m) {
          const float cosThetaO = std::max(float(m) / (kCosines - 1), 1e-3f);
          albedo_[index(side, k, r, m)] = integrate(cosThetaO, alpha, eta);
        }
      }
    }
  }
}

float GgxDielectricAlbedoTable::integrate(float cosThetaO, float alpha, float eta) {
  const Vec3f wo(std::sqrt(1 - cosThetaO * cosThetaO), 0, cosThetaO);
  const float masking = ggxMasking(wo, alpha);
  double sum = 0;
  for (int i = 0; i < kStrata; ++i) {
    for (int j = 0; j < kStrata; ++j) {
      const Vec2f u{(float(i) + 0.5f) / kStrata, (float(j) + 0.5f) / kStrata};
      const Vec3f h = sampleGgxVisibleNormal(wo, alpha, u);
      const float reflectance = fresnelDielectric(dot(wo, h), eta);
      const Vec3f reflected = reflect(wo, h);
      if (reflected.z > 0) {
        sum += reflectance * ggxMaskingShadowing(wo, reflected, alpha) / masking;
      }
      const std::optional<Vec3f> refracted = refract(wo, h, eta);
      if (refracted && refracted->z < 0) {
        sum += (1 - reflectance) * ggxMaskingShadowing(wo, *refracted, alpha) / masking;
      }
    }
  }
  return float(sum / (kStrata * kStrata));
}

}  // namespace penumbra
