#include "penumbra/bsdf.h"

#include <array>

#include "penumbra/warp.h"

namespace penumbra {
namespace {

/// Clamps to [0, 1]; NaN becomes 0, so that table indices computed from it stay defined.
float clamp01(float v) {
  return v > 0 ? (v < 1 ? v : 1.0f) : 0.0f;
}
Vec3f clamp01(const Vec3f& v) {
  return {clamp01(v.x), clamp01(v.y), clamp01(v.z)};
}
float square(float v) {
  return v * v;
}
Vec3f lerp(const Vec3f& a, const Vec3f& b, float t) {
  return a * (1 - t) + b * t;
}

/// Schlick's Fresnel approximation from F0 at normal incidence to F90 = 1 at grazing.
float schlickWeight(float cosTheta) {
  const float m = clamp01(1 - cosTheta);
  return (m * m) * (m * m) * m;
}
Vec3f schlickFresnel(const Vec3f& f0, float cosTheta) {
  return f0 + (Vec3f(1.0f) - f0) * schlickWeight(cosTheta);
}
/// Hemispherical average 2∫F(μ)μ dμ of Schlick's Fresnel: 2∫(1 − μ)^5 μ dμ = 1/21.
Vec3f schlickAverage(const Vec3f& f0) {
  return f0 + (Vec3f(1.0f) - f0) * (1.0f / 21.0f);
}

/// Exact Fresnel reflectance of unpolarised light meeting an interface at cos θ = cosThetaI from
/// the side of index n_i; eta = n_t / n_i. Total internal reflection gives 1.
float fresnelDielectric(float cosThetaI, float eta) {
  const float sin2ThetaT = (1 - cosThetaI * cosThetaI) / (eta * eta);
  if (sin2ThetaT >= 1) return 1;
  const float cosThetaT = std::sqrt(1 - sin2ThetaT);
  const float perpendicular = (cosThetaI - eta * cosThetaT) / (cosThetaI + eta * cosThetaT);
  const float parallel = (eta * cosThetaI - cosThetaT) / (eta * cosThetaI + cosThetaT);
  return 0.5f * (perpendicular * perpendicular + parallel * parallel);
}

/// Reflectance of a thin slab with interface reflectance r: the sum of the light reflected at the
/// first interface and of all paths bouncing inside, r + t²r/(1 − r²) with t = 1 − r.
float thinSlabReflectance(float r) {
  return r < 1 ? r + square(1 - r) * r / (1 - r * r) : 1.0f;
}

Vec3f reflect(const Vec3f& wo, const Vec3f& normal) {
  return normal * (2 * dot(wo, normal)) - wo;
}
/// Refracts wo (on the side `normal` points to, cos θ = dot(wo, normal) > 0) into the other side;
/// eta = n_t / n_i. Empty under total internal reflection.
std::optional<Vec3f> refract(const Vec3f& wo, const Vec3f& normal, float eta) {
  const float cosThetaI = dot(wo, normal);
  const float sin2ThetaT = (1 - cosThetaI * cosThetaI) / (eta * eta);
  if (sin2ThetaT >= 1) return std::nullopt;
  const float cosThetaT = std::sqrt(1 - sin2ThetaT);
  return -wo / eta + normal * (cosThetaI / eta - cosThetaT);
}
Vec3f mirrorThroughSurface(const Vec3f& w) {
  return {w.x, w.y, -w.z};
}

// --- GGX (Trowbridge–Reitz) microfacets, in the local frame (z = macro normal) ---
// GgxAlpha (bsdf.h) holds α along x and y. The isotropic formulas (kAnisotropic false) are kept
// apart from the anisotropic ones: they are what every isotropic material computed before
// anisotropy existed, bit for bit, and cheaper. Each public function decides once which to use.

/// Distribution of microfacet normals D(h), per unit solid angle of h:
/// 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²).
template <bool kAnisotropic>
float ggxDensityOf(const Vec3f& h, GgxAlpha alpha) {
  if (h.z <= 0) return 0;
  if (!kAnisotropic) {
    const float alpha2 = alpha.x * alpha.x;
    const float d = h.z * h.z * (alpha2 - 1) + 1;
    return alpha2 / (kPi * d * d);
  }
  const float d = square(h.x / alpha.x) + square(h.y / alpha.y) + h.z * h.z;
  return 1 / (kPi * alpha.x * alpha.y * d * d);
}
/// Smith's Λ(w) = (√(1 + (αx² wx² + αy² wy²) / wz²) − 1) / 2: G1 = 1 / (1 + Λ).
template <bool kAnisotropic>
float ggxLambdaOf(const Vec3f& w, GgxAlpha alpha) {
  const float cos2 = w.z * w.z;
  if (cos2 == 0) return kInfinity;
  if (!kAnisotropic) {
    const float tan2 = std::max(0.0f, 1 - cos2) / cos2;
    return 0.5f * (std::sqrt(1 + alpha.x * alpha.x * tan2) - 1);
  }
  const float projected2 = square(alpha.x * w.x) + square(alpha.y * w.y);
  return 0.5f * (std::sqrt(1 + projected2 / cos2) - 1);
}
/// Height-correlated masking-shadowing G2 (Heitz 2014).
template <bool kAnisotropic>
float ggxMaskingShadowingOf(const Vec3f& wo, const Vec3f& wi, GgxAlpha alpha) {
  return 1 / (1 + ggxLambdaOf<kAnisotropic>(wo, alpha) + ggxLambdaOf<kAnisotropic>(wi, alpha));
}

float ggxDensity(const Vec3f& h, GgxAlpha alpha) {
  return alpha.isotropic() ? ggxDensityOf<false>(h, alpha) : ggxDensityOf<true>(h, alpha);
}
float ggxMasking(const Vec3f& w, GgxAlpha alpha) {
  return 1 / (1 + (alpha.isotropic() ? ggxLambdaOf<false>(w, alpha) : ggxLambdaOf<true>(w, alpha)));
}
float ggxMaskingShadowing(const Vec3f& wo, const Vec3f& wi, GgxAlpha alpha) {
  return alpha.isotropic() ? ggxMaskingShadowingOf<false>(wo, wi, alpha)
                           : ggxMaskingShadowingOf<true>(wo, wi, alpha);
}
/// A microfacet normal distributed as the normals visible from wo (wo.z > 0), with density
/// G1(wo) max(0, wo·h) D(h) / wo.z (Heitz 2018): in the configuration stretched by (1/αx, 1/αy)
/// to α = 1 the visible normals are uniform over the projected hemisphere, i.e. over a disk of
/// which the part hidden behind the hemisphere's silhouette is folded onto the visible half.
Vec3f sampleGgxVisibleNormal(const Vec3f& wo, GgxAlpha alpha, Vec2f u) {
  const Vec3f view = normalize(Vec3f(alpha.x * wo.x, alpha.y * wo.y, wo.z));
  const float lengthXY2 = view.x * view.x + view.y * view.y;
  const Vec3f tangent =
      lengthXY2 > 0 ? Vec3f(-view.y, view.x, 0) / std::sqrt(lengthXY2) : Vec3f(1, 0, 0);
  const Vec3f bitangent = cross(view, tangent);
  const Vec2f disk = polarSampleDisk(u);
  const float p1 = disk.x;
  const float diskY = disk.y;
  // Seen from `view`, the visible hemisphere projects to a disk whose lower half is foreshortened
  // by cos θ_view: blend the lower half towards the silhouette's half-ellipse.
  const float visibleFraction = 0.5f * (1 + view.z);
  const float p2 =
      (1 - visibleFraction) * std::sqrt(std::max(0.0f, 1 - p1 * p1)) + visibleFraction * diskY;
  const Vec3f stretched =
      tangent * p1 + bitangent * p2 + view * std::sqrt(std::max(0.0f, 1 - p1 * p1 - p2 * p2));
  return normalize(
      Vec3f(alpha.x * stretched.x, alpha.y * stretched.y, std::max(1e-7f, stretched.z)));
}
float ggxLambda(const Vec3f& w, GgxAlpha alpha) {
  return alpha.isotropic() ? ggxLambdaOf<false>(w, alpha) : ggxLambdaOf<true>(w, alpha);
}
/// The visible-normal density given Λ(wo) = lambdaO (lobes evaluated many times for one wo keep
/// it, see PreviewSurfaceBsdf::Outgoing).
template <bool kAnisotropic>
float ggxVisibleNormalPdfOf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha, float lambdaO) {
  return 1 / (1 + lambdaO) * std::max(0.0f, dot(wo, h)) * ggxDensityOf<kAnisotropic>(h, alpha) /
         wo.z;
}
float ggxVisibleNormalPdf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha) {
  const float lambdaO = ggxLambda(wo, alpha);
  return alpha.isotropic() ? ggxVisibleNormalPdfOf<false>(wo, h, alpha, lambdaO)
                           : ggxVisibleNormalPdfOf<true>(wo, h, alpha, lambdaO);
}

/// f · cos θi of single-scattering GGX reflection without Fresnel: D G2 / (4 cos θo), given
/// Λ(wo) = lambdaO.
float ggxReflectionWithoutFresnel(const Vec3f& wo, const Vec3f& wi, const Vec3f& h, GgxAlpha alpha,
                                  float lambdaO) {
  if (alpha.isotropic()) {
    const float maskingShadowing = 1 / (1 + lambdaO + ggxLambdaOf<false>(wi, alpha));
    return ggxDensityOf<false>(h, alpha) * maskingShadowing / (4 * wo.z);
  }
  const float maskingShadowing = 1 / (1 + lambdaO + ggxLambdaOf<true>(wi, alpha));
  return ggxDensityOf<true>(h, alpha) * maskingShadowing / (4 * wo.z);
}
float ggxReflectionWithoutFresnel(const Vec3f& wo, const Vec3f& wi, const Vec3f& h,
                                  GgxAlpha alpha) {
  return ggxReflectionWithoutFresnel(wo, wi, h, alpha, ggxLambda(wo, alpha));
}
/// Solid-angle density of wi = reflect(wo, h) with h sampled by sampleGgxVisibleNormal, given
/// Λ(wo) = lambdaO.
float ggxReflectionPdf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha, float lambdaO) {
  const float cosThetaOH = dot(wo, h);
  if (!(cosThetaOH > 0)) return 0.0f;
  const float visible = alpha.isotropic() ? ggxVisibleNormalPdfOf<false>(wo, h, alpha, lambdaO)
                                          : ggxVisibleNormalPdfOf<true>(wo, h, alpha, lambdaO);
  return visible / (4 * cosThetaOH);
}
float ggxReflectionPdf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha) {
  return ggxReflectionPdf(wo, h, alpha, ggxLambda(wo, alpha));
}

// --- Directional albedos of GGX lobes, for energy compensation ---

/// Where `coordinate` in [0, 1] falls on a grid of `size` nodes including both ends.
struct GridCell {
  int index;       // lower node
  float fraction;  // position between it and the next, for linear interpolation
};
GridCell gridCell(float coordinate, int size) {
  const float x = clamp01(coordinate) * float(size - 1);
  const int index = std::min(int(x), size - 2);
  return {index, x - float(index)};
}

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

/// E_F(μ, α) = F0·A(μ, α) + B(μ, α) is the directional albedo of single-scattering GGX reflection
/// with Schlick's Fresnel (F90 = 1), and E = A + B the albedo for F = 1. Tabulated over
/// roughness r = √α and μ = cos θo, both on [0, 1] with end points included, and computed at
/// first use by integrating with stratified visible-normal samples.
class GgxAlbedoTable {
 public:
  static constexpr int kSize = 32;
  static constexpr int kStrata = 16;  // kStrata² samples per entry

  GgxAlbedoTable() {
    for (int row = 0; row < kSize; ++row) {
      const float alpha =
          std::max(square(float(row) / (kSize - 1)), PreviewSurfaceBsdf::kDeltaAlpha);
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

const GgxAlbedoTable& ggxAlbedoTable() {
  static const GgxAlbedoTable table;  // built once, thread-safe, immutable afterwards
  return table;
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

/// The anisotropic table's lookup, kept out of line (with its table's initialisation) so that
/// ggxDirectionalAlbedo stays small.
GgxAlbedoTable::Albedo anisotropicGgxDirectionalAlbedo(const Vec3f& w, GgxAlpha alpha) {
  return anisotropicGgxAlbedoTable().directional(w, alpha);
}
/// A GGX lobe's albedo terms for light from local direction w (w.z > 0; isotropic lobes read
/// only w.z), and their hemispherical averages. Always inlined: the isotropic lookup is on every
/// evaluation's path, and was inlined before anisotropy existed.
[[gnu::always_inline]] inline GgxAlbedoTable::Albedo ggxDirectionalAlbedo(const Vec3f& w,
                                                                          GgxAlpha alpha) {
  if (alpha.isotropic()) return ggxAlbedoTable().directional(w.z, alpha.x);
  return anisotropicGgxDirectionalAlbedo(w, alpha);
}
GgxAlbedoTable::Albedo ggxAverageAlbedo(GgxAlpha alpha) {
  return alpha.isotropic() ? ggxAlbedoTable().average(alpha.x)
                           : anisotropicGgxAlbedoTable().average(alpha);
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

  GgxDielectricAlbedoTable() {
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
  static float integrate(float cosThetaO, float alpha, float eta) {
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

  std::array<float, 2 * kIors * kRoughnesses * kCosines> albedo_{};
};

const GgxDielectricAlbedoTable& ggxDielectricAlbedoTable() {
  static const GgxDielectricAlbedoTable table;  // built once, thread-safe, immutable afterwards
  return table;
}

// --- Sheen: the "Charlie" distribution (Estevez and Kulla 2017) ---

/// The smallest sheen α: below it (sin θh)^(1/α) underflows and the lobe carries no energy.
constexpr float kMinSheenAlpha = 0.01f;

/// The Charlie distribution of microfibre normals D(h) = (2 + 1/α) sin^(1/α) θh / (2π),
/// normalised so that ∫ D(h) cos θh dh = 1.
float charlieDensity(float cosThetaH, float alpha) {
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

  SheenTables() {
    for (int row = 0; row < kSize; ++row) {
      const float alpha = rowAlpha(row);
      for (int column = 0; column < kSize; ++column)
        projectedArea_[row * kSize + column] = integrateProjectedArea(columnCosine(column), alpha);
    }
    for (int row = 0; row < kSize; ++row) {
      const float alpha = rowAlpha(row);
      for (int column = 0; column < kSize; ++column) {
        const float cosThetaO = columnCosine(column);
        const Vec3f wo(std::sqrt(1 - cosThetaO * cosThetaO), 0, cosThetaO);
        const float lambdaO = lambda(cosThetaO, alpha);
        double sum = 0;
        for (int i = 0; i < kCosines; ++i) {
          const float z = (float(i) + 0.5f) / kCosines;
          const float radius = std::sqrt(1 - z * z);
          const float lambdaI = lambda(z, alpha);
          for (int j = 0; j < kAzimuths; ++j) {
            const float phi = kPi * (float(j) + 0.5f) / kAzimuths;
            const Vec3f wi(radius * std::cos(phi), radius * std::sin(phi), z);
            sum += reflection(wo, wi, alpha, lambdaO, lambdaI);
          }
        }
        // dωi = d(cos θi) dφ, doubled for φ in [π, 2π].
        albedo_[row * kSize + column] = float(sum * 2 * kPi / (double(kCosines) * kAzimuths));
      }
    }
  }

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
  static float integrateProjectedArea(float cosTheta, float alpha) {
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - double(cosTheta) * cosTheta));
    double sum = 0;
    for (int k = 0; k < kAreaSteps; ++k) {
      const double z = (k + 0.5) / kAreaSteps;
      const double a = sinTheta * std::sqrt(1 - z * z), b = cosTheta * z;
      double arc;
      if (b >= a) {
        arc = 2 * kPi * b;
      } else {
        const double phi0 = std::acos(-b / a);
        arc = 2 * (a * std::sin(phi0) + b * phi0);
      }
      sum += arc * charlieDensity(float(z), alpha);
    }
    return float(sum / kAreaSteps);
  }

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

const SheenTables& sheenTables() {
  static const SheenTables tables;  // built once, thread-safe, immutable afterwards
  return tables;
}

/// f · cos θi of the white sheen lobe with weight 1, for wo.z, wi.z > 0. Symmetric in wo and wi
/// once divided by cos θi.
float sheenReflection(const Vec3f& wo, const Vec3f& wi, float alpha) {
  const SheenTables& tables = sheenTables();
  return SheenTables::reflection(wo, wi, alpha, tables.lambda(wo.z, alpha),
                                 tables.lambda(wi.z, alpha));
}

/// A specular layer: GGX (or a mirror when alpha = 0) with Schlick's Fresnel from f0 to 1 and a
/// Kulla–Conty multiple-scattering term scaled by `multipleScattering`.
struct SpecularLayer {
  GgxAlpha alpha;
  Vec3f f0;
  Vec3f multipleScattering;

  /// Directional albedo E(w): everything the layer reflects for light from local direction w
  /// (only w.z matters to isotropic lobes).
  Vec3f albedo(const Vec3f& w) const {
    if (alpha.x == 0) return schlickFresnel(f0, w.z);
    return albedo(ggxDirectionalAlbedo(w, alpha));
  }
  /// The same for a rough layer, from the table's entry for w and α.
  Vec3f albedo(const GgxAlbedoTable::Albedo& e) const {
    return f0 * e.scale + Vec3f(e.bias) + multipleScattering * (1 - e.scale - e.bias);
  }
  /// Hemispherical average (1/π) ∫ E(w) cos θ dw, given ggxAverageAlbedo(alpha) (looked up
  /// once per BSDF).
  Vec3f averageAlbedo(const GgxAlbedoTable::Albedo& lobeAverage) const {
    if (alpha.x == 0) return schlickAverage(f0);
    const GgxAlbedoTable::Albedo& e = lobeAverage;
    return f0 * e.scale + Vec3f(e.bias) + multipleScattering * (1 - e.scale - e.bias);
  }
};

/// Kulla–Conty scale F_avg² E_avg / (1 − F_avg (1 − E_avg)) of the multiple-scattering lobe
/// (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)), which by itself reflects 1 − E(μo): the energy of
/// the light that bounces more than once between microfacets, each bounce attenuated by the
/// average Fresnel reflectance.
/// `averageAlbedo`: E_avg of the white lobe (0 for a delta lobe, which has no such term).
Vec3f multipleScatteringScale(const Vec3f& f0, float averageAlbedo) {
  if (averageAlbedo == 0) return Vec3f(0.0f);
  const Vec3f fresnel = schlickAverage(f0);
  const auto scale = [&](float f) { return f * f * averageAlbedo / (1 - f * (1 - averageAlbedo)); };
  return {scale(fresnel.x), scale(fresnel.y), scale(fresnel.z)};
}

/// GGX α for a UsdPreviewSurface roughness; 0 (a delta lobe) below kDeltaAlpha.
float microfacetAlpha(float roughness) {
  const float alpha = square(clamp01(roughness));
  return alpha < PreviewSurfaceBsdf::kDeltaAlpha ? 0.0f : alpha;
}

/// A lobe's (αx, αy) for a roughness and an anisotropy (MaterialParams::anisotropyModel); 0
/// (a delta lobe) where αx is below kDeltaAlpha, αy at least kDeltaAlpha otherwise.
GgxAlpha lobeAlpha(float roughness, float anisotropy, AnisotropyModel model) {
  if (!(anisotropy > 0)) return microfacetAlpha(roughness);
  const float alpha = square(clamp01(roughness));
  const float a = clamp01(anisotropy);
  float alongX = 0, alongY = 0;
  if (model == AnisotropyModel::OpenPbr) {
    alongX = alpha * std::sqrt(2 / (1 + square(1 - a)));
    alongY = (1 - a) * alongX;
  } else {
    const float aspect = std::sqrt(1 - std::min(a, 0.98f));
    alongX = std::min(alpha / aspect, 1.0f);
    alongY = alpha * aspect;
  }
  if (alongX < PreviewSurfaceBsdf::kDeltaAlpha) return 0.0f;
  return {alongX, std::max(alongY, PreviewSurfaceBsdf::kDeltaAlpha)};
}

constexpr float kClearcoatF0 = 0.04f;  // ((1 − 1.5) / (1 + 1.5))², fixed by the spec

}  // namespace

PreviewSurfaceBsdf::PreviewSurfaceBsdf(const MaterialParams& material, const Vec3f& normal,
                                       float ior, DielectricKind dielectricKind,
                                       const Vec3f& tangent)
    : frame_(normal),
      opacity_(clamp01(material.opacity)),
      clearcoat_(clamp01(material.clearcoat)),
      coatAlpha_(lobeAlpha(material.clearcoatRoughness, material.clearcoatAnisotropy,
                           material.anisotropyModel)),
      sheen_(clamp01(material.sheen)),
      specularAlpha_(lobeAlpha(material.roughness, material.anisotropy, material.anisotropyModel)),
      ior_(std::isfinite(ior) && ior > 0 ? ior : 1.0f),
      dielectricAlpha_(microfacetAlpha(material.transmissionRoughness < 0
                                           ? material.roughness
                                           : material.transmissionRoughness)),
      dielectricKind_(dielectricKind) {
  if (!specularAlpha_.isotropic() || !coatAlpha_.isotropic()) {
    // x along the tangent turned by the rotation (counter-clockwise about the normal).
    frame_ = Frame::withTangent(normal, tangent);
    const float angle =
        2 * kPi * (std::isfinite(material.anisotropyRotation) ? material.anisotropyRotation : 0.0f);
    const float c = std::cos(angle), s = std::sin(angle);
    const Vec3f turned = frame_.s * c + frame_.t * s;
    frame_.t = frame_.t * c - frame_.s * s;
    frame_.s = turned;
  }
  // The coat tint and the sheen are set up only where they act: materials without them cost
  // what they did before.
  if (clearcoat_ > 0) coatTint_ = lerp(Vec3f(1.0f), clamp01(material.clearcoatColor), clearcoat_);
  if (sheen_ > 0) {
    sheenColor_ = clamp01(material.sheenColor);
    sheenAlpha_ = std::max(clamp01(material.sheenRoughness), kMinSheenAlpha);
  }
  GgxAlbedoTable::Albedo lobeAverage;  // of the white specular lobe
  float averageAlbedo = 0;
  if (specularAlpha_.x > 0) {
    lobeAverage = ggxAverageAlbedo(specularAlpha_);
    averageAlbedo = lobeAverage.scale + lobeAverage.bias;
    specularAverageLoss_ = std::max(0.0f, 1 - lobeAverage.scale - lobeAverage.bias);
  }
  const Vec3f albedo = clamp01(material.diffuseColor);
  if (material.useSpecularWorkflow) {
    specularF0_ = clamp01(material.specularColor);
    multipleScatteringScale_ = multipleScatteringScale(specularF0_, averageAlbedo);
    diffuseReflectance_ = albedo;
    diffuseCoverF0_ = specularF0_;
    diffuseCoverMultipleScattering_ = multipleScatteringScale_;
  } else {
    // A linear mix of a dielectric (weight 1 − metallic) and a conductor of reflectance
    // diffuseColor. Both specular lobes share α, so their sum is one lobe with the mixed F0.
    const float metallic = clamp01(material.metallic);
    const Vec3f dielectricF0(square((1 - ior_) / (1 + ior_)));
    specularF0_ = lerp(dielectricF0, albedo, metallic);
    diffuseCoverF0_ = dielectricF0;
    diffuseCoverMultipleScattering_ = multipleScatteringScale(dielectricF0, averageAlbedo);
    multipleScatteringScale_ = diffuseCoverMultipleScattering_ * (1 - metallic) +
                               multipleScatteringScale(albedo, averageAlbedo) * metallic;
    diffuseReflectance_ = albedo * (1 - metallic);
  }
  const Vec3f coverAverage =
      SpecularLayer{specularAlpha_, diffuseCoverF0_, diffuseCoverMultipleScattering_}.averageAlbedo(
          lobeAverage);
  const auto normalization = [](float average) {
    return average < 1 - 1e-4f ? kInvPi / (1 - average) : 0.0f;
  };
  diffuseNormalization_ = {normalization(coverAverage.x), normalization(coverAverage.y),
                           normalization(coverAverage.z)};
}

bool PreviewSurfaceBsdf::isPurelySpecular() const {
  const bool opaqueIsDelta =
      opacity_ == 0 ||
      (sheen_ == 0 && (clearcoat_ == 0 || coatAlpha_.x == 0) && specularAlpha_.x == 0 &&
       isBlack(diffuseReflectance_ * diffuseNormalization_));
  const bool translucentIsDelta = opacity_ == 1 || dielectricAlpha_ == 0 || ior_ == 1;
  return opaqueIsDelta && translucentIsDelta;
}

float PreviewSurfaceBsdf::coatTransmittance(const Vec3f& w) const {
  if (clearcoat_ == 0) return 1;
  return 1 - clearcoat_ * SpecularLayer{coatAlpha_, Vec3f(kClearcoatF0), Vec3f(0.0f)}.albedo(w).x;
}

Vec3f PreviewSurfaceBsdf::tintUnderCoat(const Vec3f& value) const {
  return value * coatTint_;  // exact (bit-identical) where the tint is 1
}

float PreviewSurfaceBsdf::sheenAlbedo(float cosTheta) const {
  return sheen_ * sheenTables().albedo(cosTheta, sheenAlpha_);
}

float PreviewSurfaceBsdf::sheenTransmittance(float cosThetaO) const {
  return sheen_ > 0 ? 1 - sheenAlbedo(cosThetaO) : 1.0f;
}

const PreviewSurfaceBsdf::Outgoing& PreviewSurfaceBsdf::outgoing(const Vec3f& wo) const {
  if (wo.z != cachedWo_.z || wo.x != cachedWo_.x || wo.y != cachedWo_.y) {
    cachedWo_ = wo;
    cachedOutgoing_ = computeOutgoing(wo);
  }
  return cachedOutgoing_;
}

PreviewSurfaceBsdf::Outgoing PreviewSurfaceBsdf::computeOutgoing(const Vec3f& wo) const {
  const float cosThetaO = wo.z;
  Outgoing outgoing;
  const SpecularLayer cover{specularAlpha_, diffuseCoverF0_, diffuseCoverMultipleScattering_};
  GgxAlbedoTable::Albedo e;  // of the rough specular layer for wo
  if (specularAlpha_.x == 0) {
    outgoing.underSpecular = Vec3f(1.0f) - cover.albedo(wo);
  } else {
    e = ggxDirectionalAlbedo(wo, specularAlpha_);
    outgoing.specularLoss = std::max(0.0f, 1 - e.scale - e.bias);
    outgoing.underSpecular = Vec3f(1.0f) - cover.albedo(e);
  }
  outgoing.coatTransmittance = coatTransmittance(wo);
  outgoing.sheenTransmittance = sheenTransmittance(cosThetaO);
  if (specularAlpha_.x > 0) outgoing.specularLambda = ggxLambda(wo, specularAlpha_);
  if (coatAlpha_.x > 0) outgoing.coatLambda = ggxLambda(wo, coatAlpha_);

  // Each lobe's albedo for this wo. The layers under the coat are attenuated by its
  // transmittance for wo only, the one for wi being unknown yet.
  LobeProbabilities& p = outgoing.probabilities;
  if (opacity_ > 0) {
    // What the sheen lets through to the layers below (albedo scaling: for wo only).
    float underSheen = opacity_;
    if (sheen_ > 0) {
      const float sheen = sheenAlbedo(cosThetaO);
      p.sheen = opacity_ * luminance(sheenColor_) * sheen;
      underSheen = opacity_ * (1 - sheen);
    }
    const float coat = outgoing.coatTransmittance;
    const float below = underSheen * coat;
    p.coat = underSheen * (1 - coat);
    if (specularAlpha_.x == 0) {
      p.specular = below * luminance(tintUnderCoat(schlickFresnel(specularF0_, cosThetaO)));
    } else {
      p.specular = below * luminance(tintUnderCoat(specularF0_ * e.scale + Vec3f(e.bias)));
      p.multipleScattering =
          below * luminance(tintUnderCoat(multipleScatteringScale_)) * outgoing.specularLoss;
    }
    p.diffuse = below * luminance(tintUnderCoat(diffuseReflectance_ * outgoing.underSpecular));
  }
  p.dielectric = 1 - opacity_;  // its albedo is 1: energy-compensated, and nothing is absorbed
  const float total =
      p.coat + p.specular + p.multipleScattering + p.diffuse + p.sheen + p.dielectric;
  if (!(total > 0)) {
    p = {};
    return outgoing;
  }
  const float scale = 1 / total;
  p.sheen *= scale;
  p.coat *= scale;
  p.specular *= scale;
  p.multipleScattering *= scale;
  p.diffuse *= scale;
  p.dielectric *= scale;
  return outgoing;
}

Vec3f PreviewSurfaceBsdf::evaluateOpaque(const Vec3f& wo, const Vec3f& wi,
                                         Vec3f* diffusePart) const {
  if (wi.z <= 0) return Vec3f(0.0f);
  const Outgoing& forWo = outgoing(wo);
  const Vec3f h = normalize(wo + wi);
  const SpecularLayer cover{specularAlpha_, diffuseCoverF0_, diffuseCoverMultipleScattering_};
  Vec3f base(0.0f), underSpecularForWi(1.0f);
  if (specularAlpha_.x > 0) {
    base += schlickFresnel(specularF0_, dot(wo, h)) *
            ggxReflectionWithoutFresnel(wo, wi, h, specularAlpha_, forWo.specularLambda);
    // The diffuse layer's cover is the specular layer, with its own F0: one table entry each.
    const GgxAlbedoTable::Albedo ei = ggxDirectionalAlbedo(wi, specularAlpha_);
    if (specularAverageLoss_ > 0) {
      base +=
          multipleScatteringScale_ * (forWo.specularLoss * std::max(0.0f, 1 - ei.scale - ei.bias) *
                                      wi.z / (kPi * specularAverageLoss_));
    }
    underSpecularForWi = Vec3f(1.0f) - cover.albedo(ei);
  } else {
    underSpecularForWi = Vec3f(1.0f) - cover.albedo(wi);
  }
  Vec3f diffuse(0.0f);
  if (!isBlack(diffuseReflectance_)) {
    diffuse = diffuseReflectance_ * diffuseNormalization_ * forWo.underSpecular *
              underSpecularForWi * wi.z;
    base += diffuse;
  }
  const float coat = forWo.coatTransmittance * coatTransmittance(wi);
  if (diffusePart) *diffusePart = tintUnderCoat(diffuse) * (coat * opacity_);
  Vec3f value = tintUnderCoat(base) * coat;
  if (clearcoat_ > 0 && coatAlpha_.x > 0) {
    value += Vec3f(clearcoat_ * schlickFresnel(Vec3f(kClearcoatF0), dot(wo, h)).x *
                   ggxReflectionWithoutFresnel(wo, wi, h, coatAlpha_, forWo.coatLambda));
  }
  if (sheen_ > 0) {
    const float underSheen = forWo.sheenTransmittance;
    if (diffusePart) *diffusePart *= underSheen;
    value = value * underSheen + sheenColor_ * (sheen_ * sheenReflection(wo, wi, sheenAlpha_));
  }
  return value * opacity_;
}

float PreviewSurfaceBsdf::pdfOpaque(const Vec3f& wo, const Vec3f& wi, const Outgoing& forWo) const {
  if (wi.z <= 0) return 0;
  const LobeProbabilities& p = forWo.probabilities;
  const Vec3f h = normalize(wo + wi);
  float density = (p.multipleScattering + p.diffuse) * wi.z * kInvPi;
  if (specularAlpha_.x > 0)
    density += p.specular * ggxReflectionPdf(wo, h, specularAlpha_, forWo.specularLambda);
  if (coatAlpha_.x > 0) density += p.coat * ggxReflectionPdf(wo, h, coatAlpha_, forWo.coatLambda);
  if (sheen_ > 0) density += p.sheen * kUniformHemispherePdf;
  return density;
}

float PreviewSurfaceBsdf::dielectricReflectance(float cosTheta, float eta) const {
  return dielectricKind_ == DielectricKind::ThinSheet
             ? thinSlabReflectance(fresnelDielectric(cosTheta, ior_))
             : fresnelDielectric(cosTheta, eta);
}

// Rough dielectric (Walter et al. 2007). Reflection: h = normalize(wo + wi). Refraction through a
// solid: h = ±normalize(wo + η wi) with wo·h > 0 > wi·h; the density of wi given h has Jacobian
// dh/dwi = η² |wi·h| / (wo·h + η wi·h)², and the energy-conserving (flux) BTDF times cos θi is
// D G2 (1 − F) (wo·h) / cos θo · dh/dwi. Radiance is that divided by η². A thin sheet transmits
// the reflection lobe mirrored through the surface. The light lost to masking is put back by
// dividing by the directional albedo for wo (albedo scaling): exact in energy for every wo, but not
// reciprocal — harmless for a path tracer that only traces from the camera.
float PreviewSurfaceBsdf::dielectricAlbedo(float cosThetaO, float eta) const {
  if (dielectricKind_ == DielectricKind::ThinSheet) {
    // Each microfacet reflects R' and transmits 1 − R' into mirror-image directions, which are
    // masked alike: the albedo is that of a white GGX mirror.
    const GgxAlbedoTable::Albedo e = ggxAlbedoTable().directional(cosThetaO, dielectricAlpha_);
    return e.scale + e.bias;
  }
  return ggxDielectricAlbedoTable().albedo(cosThetaO, dielectricAlpha_, eta);
}

float PreviewSurfaceBsdf::evaluateDielectric(const Vec3f& wo, const Vec3f& wi, float eta) const {
  const float singleScattering = evaluateDielectricSingleScattering(wo, wi, eta);
  return singleScattering > 0 ? singleScattering / dielectricAlbedo(wo.z, eta) : 0.0f;
}

namespace {
/// The microfacet normal of a refraction from wo (above, z > 0) to wi (below) with relative
/// index eta, on wo's side, and the cosines with it; false when no microfacet refracts so.
bool refractionHalfVector(const Vec3f& wo, const Vec3f& wi, float eta, Vec3f* h, float* cosThetaOH,
                          float* cosThetaIH) {
  Vec3f half = wo + wi * eta;
  if (dot(half, half) == 0) return false;
  half = normalize(half);
  if (half.z < 0) half = -half;
  *h = half;
  *cosThetaOH = dot(wo, half);
  *cosThetaIH = dot(wi, half);
  return *cosThetaOH > 0 && *cosThetaIH < 0;
}
}  // namespace

float PreviewSurfaceBsdf::evaluateDielectricSingleScattering(const Vec3f& wo, const Vec3f& wi,
                                                             float eta) const {
  const float alpha = dielectricAlpha_;
  if (wi.z > 0) {
    const Vec3f h = normalize(wo + wi);
    return dielectricReflectance(dot(wo, h), eta) * ggxReflectionWithoutFresnel(wo, wi, h, alpha);
  }
  if (dielectricKind_ == DielectricKind::ThinSheet) {
    const Vec3f mirrored = mirrorThroughSurface(wi);
    const Vec3f h = normalize(wo + mirrored);
    return (1 - dielectricReflectance(dot(wo, h), eta)) *
           ggxReflectionWithoutFresnel(wo, mirrored, h, alpha);
  }
  Vec3f h;
  float cosThetaOH = 0, cosThetaIH = 0;
  if (!refractionHalfVector(wo, wi, eta, &h, &cosThetaOH, &cosThetaIH)) return 0;
  const float denominator = square(cosThetaOH + eta * cosThetaIH);
  return ggxDensity(h, alpha) * ggxMaskingShadowing(wo, wi, alpha) *
         (1 - fresnelDielectric(cosThetaOH, eta)) * cosThetaOH * -cosThetaIH / (wo.z * denominator);
}

float PreviewSurfaceBsdf::pdfDielectric(const Vec3f& wo, const Vec3f& wi, float eta) const {
  const float alpha = dielectricAlpha_;
  if (wi.z > 0) {
    const Vec3f h = normalize(wo + wi);
    return dielectricReflectance(dot(wo, h), eta) * ggxReflectionPdf(wo, h, alpha);
  }
  if (dielectricKind_ == DielectricKind::ThinSheet) {
    const Vec3f h = normalize(wo + mirrorThroughSurface(wi));
    return (1 - dielectricReflectance(dot(wo, h), eta)) * ggxReflectionPdf(wo, h, alpha);
  }
  Vec3f h;
  float cosThetaOH = 0, cosThetaIH = 0;
  if (!refractionHalfVector(wo, wi, eta, &h, &cosThetaOH, &cosThetaIH)) return 0;
  const float jacobian = eta * eta * -cosThetaIH / square(cosThetaOH + eta * cosThetaIH);
  return (1 - fresnelDielectric(cosThetaOH, eta)) * ggxVisibleNormalPdf(wo, h, alpha) * jacobian;
}

namespace {

/// The local frame seen from wo's side: the opaque part is two-sided and the dielectric is
/// symmetric once the relative index is inverted, so everything is computed with wo.z > 0.
struct OrientedPair {
  Vec3f wo, wi;
  bool flipped;
};
OrientedPair orient(const Frame& frame, const Vec3f& wo, const Vec3f& wi) {
  OrientedPair pair{frame.toLocal(wo), frame.toLocal(wi), false};
  if (pair.wo.z < 0) {
    pair.wo.z = -pair.wo.z;
    pair.wi.z = -pair.wi.z;
    pair.flipped = true;
  }
  return pair;
}

}  // namespace

Vec3f PreviewSurfaceBsdf::evaluate(const Vec3f& woWorld, const Vec3f& wiWorld,
                                   Vec3f* diffusePart) const {
  if (diffusePart) *diffusePart = Vec3f(0.0f);
  const OrientedPair pair = orient(frame_, woWorld, wiWorld);
  const Vec3f &wo = pair.wo, &wi = pair.wi;
  if (wo.z == 0 || wi.z == 0) return Vec3f(0.0f);
  Vec3f value = opacity_ > 0 ? evaluateOpaque(wo, wi, diffusePart) : Vec3f(0.0f);
  if (opacity_ < 1 && dielectricAlpha_ > 0 && ior_ != 1) {
    const float eta = pair.flipped ? 1 / ior_ : ior_;
    value += Vec3f((1 - opacity_) * evaluateDielectric(wo, wi, eta));
  }
  return value;
}

float PreviewSurfaceBsdf::pdf(const Vec3f& woWorld, const Vec3f& wiWorld) const {
  const OrientedPair pair = orient(frame_, woWorld, wiWorld);
  const Vec3f &wo = pair.wo, &wi = pair.wi;
  if (wo.z == 0 || wi.z == 0) return 0;
  const Outgoing& forWo = outgoing(wo);
  const LobeProbabilities& p = forWo.probabilities;
  float density = p.dielectric < 1 ? pdfOpaque(wo, wi, forWo) : 0.0f;
  if (p.dielectric > 0 && dielectricAlpha_ > 0 && ior_ != 1) {
    density += p.dielectric * pdfDielectric(wo, wi, pair.flipped ? 1 / ior_ : ior_);
  }
  return density;
}

std::optional<BsdfSample> PreviewSurfaceBsdf::sample(const Vec3f& woWorld, float uLobe,
                                                     Vec2f u) const {
  Vec3f wo = frame_.toLocal(woWorld);
  const bool flipped = wo.z < 0;
  if (flipped) wo.z = -wo.z;
  if (!(wo.z > 0)) return std::nullopt;
  const Outgoing forWo = outgoing(wo);
  const LobeProbabilities& p = forWo.probabilities;

  // Picks lobe k if uLobe falls in its interval and rescales uLobe to [0, 1) within it, so that
  // the dielectric can reuse it for its reflect/refract choice.
  const std::array<float, 6> probabilities{p.coat,    p.specular, p.multipleScattering,
                                           p.diffuse, p.sheen,    p.dielectric};
  int lobe = -1;
  float cumulative = 0;
  for (int k = 0; k < 6; ++k) {
    if (probabilities[k] > 0 && uLobe < cumulative + probabilities[k]) {
      lobe = k;
      uLobe = std::min((uLobe - cumulative) / probabilities[k], 0.99999994f);
      break;
    }
    cumulative += probabilities[k];
  }
  if (lobe < 0) {  // rounding left uLobe past the last interval: take the last non-empty lobe
    for (int k = 5; k >= 0 && lobe < 0; --k) {
      if (probabilities[k] > 0) lobe = k;
    }
    if (lobe < 0) return std::nullopt;
    uLobe = 0.5f;
  }

  BsdfSample result;
  Vec3f wi;
  const auto toWorld = [&](Vec3f local) {
    if (flipped) local.z = -local.z;
    return normalize(frame_.toWorld(local));
  };
  const auto delta = [&](const Vec3f& local, const Vec3f& weight, float probability,
                         BsdfLobe kind) {
    result.direction = toWorld(local);
    result.weight = weight / probability;
    result.pdf = probability;
    result.lobe = kind;
    result.isDelta = true;
    result.transmitted = local.z < 0;
    return result;
  };
  const Vec3f mirror(-wo.x, -wo.y, wo.z);
  switch (lobe) {
    case 0:  // clearcoat
      if (coatAlpha_.x == 0) {
        return delta(mirror,
                     Vec3f(opacity_ * clearcoat_ * schlickFresnel(Vec3f(kClearcoatF0), wo.z).x *
                           forWo.sheenTransmittance),
                     p.coat, BsdfLobe::Specular);
      }
      wi = reflect(wo, sampleGgxVisibleNormal(wo, coatAlpha_, u));
      result.lobe = BsdfLobe::Glossy;
      break;
    case 1:  // specular layer, single scattering
      if (specularAlpha_.x == 0) {
        const float coat = forWo.coatTransmittance;
        return delta(mirror,
                     tintUnderCoat(schlickFresnel(specularF0_, wo.z)) *
                         (opacity_ * coat * coat * forWo.sheenTransmittance),
                     p.specular, BsdfLobe::Specular);
      }
      wi = reflect(wo, sampleGgxVisibleNormal(wo, specularAlpha_, u));
      result.lobe = BsdfLobe::Glossy;
      break;
    case 2:  // specular layer, multiple scattering
      wi = sampleCosineHemisphere(u);
      result.lobe = BsdfLobe::Glossy;
      break;
    case 3:
      wi = sampleCosineHemisphere(u);
      result.lobe = BsdfLobe::Diffuse;
      break;
    case 4:
      wi = sampleUniformHemisphere(u);
      result.lobe = BsdfLobe::Glossy;
      break;
    default: {  // translucent part
      const float eta = flipped ? 1 / ior_ : ior_;
      const float weight = 1 - opacity_;
      if (ior_ == 1) {  // an index-matched interface: light passes unchanged
        return delta(-wo, Vec3f(weight), p.dielectric, BsdfLobe::Transmission);
      }
      if (dielectricAlpha_ == 0) {
        const float reflectance = dielectricReflectance(wo.z, eta);
        if (uLobe < reflectance) {
          return delta(mirror, Vec3f(weight * reflectance), p.dielectric * reflectance,
                       BsdfLobe::Specular);
        }
        const float transmittance = 1 - reflectance;
        if (dielectricKind_ == DielectricKind::ThinSheet) {
          return delta(-wo, Vec3f(weight * transmittance), p.dielectric * transmittance,
                       BsdfLobe::Transmission);
        }
        const Vec3f refracted = *refract(wo, Vec3f(0, 0, 1), eta);  // reflectance < 1: no TIR
        return delta(refracted, Vec3f(weight * transmittance / (eta * eta)),
                     p.dielectric * transmittance, BsdfLobe::Transmission);
      }
      const Vec3f h = sampleGgxVisibleNormal(wo, dielectricAlpha_, u);
      const float reflectance = dielectricReflectance(dot(wo, h), eta);
      if (uLobe < reflectance) {
        wi = reflect(wo, h);
        result.lobe = BsdfLobe::Glossy;
      } else if (dielectricKind_ == DielectricKind::ThinSheet) {
        wi = mirrorThroughSurface(reflect(wo, h));
        result.lobe = BsdfLobe::Transmission;
      } else {
        const std::optional<Vec3f> refracted = refract(wo, h, eta);
        if (!refracted) return std::nullopt;  // reflectance is 1 under TIR; rounding only
        wi = *refracted;
        result.lobe = BsdfLobe::Transmission;
      }
      break;
    }
  }
  // A microfacet lobe may send wi to the wrong side of the macro surface: nothing scatters there.
  const bool transmitted = result.lobe == BsdfLobe::Transmission;
  if (transmitted ? wi.z >= 0 : wi.z <= 0) return std::nullopt;
  result.direction = toWorld(wi);
  result.transmitted = transmitted;
  result.pdf = pdf(woWorld, result.direction);
  if (!(result.pdf > 0)) return std::nullopt;
  result.weight = evaluate(woWorld, result.direction) / result.pdf;
  return result;
}

float dispersiveIor(float iorD, float abbeNumber, float wavelengthNm) {
  if (!(abbeNumber > 0)) return iorD;
  constexpr double kLineD = 587.6, kLineF = 486.1, kLineC = 656.3;  // nm
  const double b =
      (double(iorD) - 1) / (double(abbeNumber) * (1 / (kLineF * kLineF) - 1 / (kLineC * kLineC)));
  const double a = double(iorD) - b / (kLineD * kLineD);
  return float(a + b / (double(wavelengthNm) * double(wavelengthNm)));
}

}  // namespace penumbra
