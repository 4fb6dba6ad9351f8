// Microfacet maths of the BSDF's lobes, in the local frame (z = macro normal): Fresnel
// reflectance, reflection and refraction of directions, and the GGX (Trowbridge–Reitz)
// distribution with Smith's masking-shadowing and visible-normal sampling. Inline: every BSDF
// evaluation and sample runs through them.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "penumbra/bsdf.h"
#include "penumbra/math.h"
#include "penumbra/warp.h"

namespace penumbra {

// --- Small helpers ---

/// Clamps to [0, 1]; NaN becomes 0, so that table indices computed from it stay defined.
inline float clamp01(float v) {
  return v > 0 ? (v < 1 ? v : 1.0f) : 0.0f;
}
inline Vec3f clamp01(const Vec3f& v) {
  return {clamp01(v.x), clamp01(v.y), clamp01(v.z)};
}
inline float square(float v) {
  return v * v;
}

// --- Fresnel reflectance; reflection and refraction of directions ---

/// Schlick's Fresnel approximation from F0 at normal incidence to F90 (1 unless a specular
/// weight scales the whole lobe) at grazing.
inline float schlickWeight(float cosTheta) {
  const float m = clamp01(1 - cosTheta);
  return (m * m) * (m * m) * m;
}
inline Vec3f schlickFresnel(const Vec3f& f0, float cosTheta, const Vec3f& f90 = Vec3f(1.0f)) {
  return f0 + (f90 - f0) * schlickWeight(cosTheta);
}
/// Hemispherical average 2∫F(μ)μ dμ of Schlick's Fresnel: 2∫(1 − μ)^5 μ dμ = 1/21.
inline Vec3f schlickAverage(const Vec3f& f0, const Vec3f& f90 = Vec3f(1.0f)) {
  return f0 + (f90 - f0) * (1.0f / 21.0f);
}

/// Exact Fresnel reflectance of unpolarised light meeting an interface at cos θ = cosThetaI from
/// the side of index n_i; eta = n_t / n_i. Total internal reflection gives 1.
inline float fresnelDielectric(float cosThetaI, float eta) {
  const float sin2ThetaT = (1 - cosThetaI * cosThetaI) / (eta * eta);
  if (sin2ThetaT >= 1) return 1;
  const float cosThetaT = std::sqrt(1 - sin2ThetaT);
  const float perpendicular = (cosThetaI - eta * cosThetaT) / (cosThetaI + eta * cosThetaT);
  const float parallel = (eta * cosThetaI - cosThetaT) / (eta * cosThetaI + cosThetaT);
  return 0.5f * (perpendicular * perpendicular + parallel * parallel);
}

/// Reflectance of a thin slab with interface reflectance r: the sum of the light reflected at the
/// first interface and of all paths bouncing inside, r + t²r/(1 − r²) with t = 1 − r.
inline float thinSlabReflectance(float r) {
  return r < 1 ? r + square(1 - r) * r / (1 - r * r) : 1.0f;
}

inline Vec3f reflect(const Vec3f& wo, const Vec3f& normal) {
  return normal * (2 * dot(wo, normal)) - wo;
}
/// Refracts wo (on the side `normal` points to, cos θ = dot(wo, normal) > 0) into the other side;
/// eta = n_t / n_i. Empty under total internal reflection.
inline std::optional<Vec3f> refract(const Vec3f& wo, const Vec3f& normal, float eta) {
  const float cosThetaI = dot(wo, normal);
  const float sin2ThetaT = (1 - cosThetaI * cosThetaI) / (eta * eta);
  if (sin2ThetaT >= 1) return std::nullopt;
  const float cosThetaT = std::sqrt(1 - sin2ThetaT);
  return -wo / eta + normal * (cosThetaI / eta - cosThetaT);
}
inline Vec3f mirrorThroughSurface(const Vec3f& w) {
  return {w.x, w.y, -w.z};
}

// --- GGX (Trowbridge–Reitz) microfacets ---
// GgxAlpha (bsdf.h) holds α along x and y. The isotropic formulas (kAnisotropic false) are kept
// apart from the anisotropic ones: isotropic lobes take the cheaper exact formulas. Each public
// function decides once which to use.

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

inline float ggxDensity(const Vec3f& h, GgxAlpha alpha) {
  return alpha.isotropic() ? ggxDensityOf<false>(h, alpha) : ggxDensityOf<true>(h, alpha);
}
inline float ggxMasking(const Vec3f& w, GgxAlpha alpha) {
  return 1 / (1 + (alpha.isotropic() ? ggxLambdaOf<false>(w, alpha) : ggxLambdaOf<true>(w, alpha)));
}
inline float ggxMaskingShadowing(const Vec3f& wo, const Vec3f& wi, GgxAlpha alpha) {
  return alpha.isotropic() ? ggxMaskingShadowingOf<false>(wo, wi, alpha)
                           : ggxMaskingShadowingOf<true>(wo, wi, alpha);
}
/// A microfacet normal distributed as the normals visible from wo (wo.z > 0), with density
/// G1(wo) max(0, wo·h) D(h) / wo.z (Heitz 2018): in the configuration stretched by (1/αx, 1/αy)
/// to α = 1 the visible normals are uniform over the projected hemisphere, i.e. over a disk of
/// which the part hidden behind the hemisphere's silhouette is folded onto the visible half.
inline Vec3f sampleGgxVisibleNormal(const Vec3f& wo, GgxAlpha alpha, Vec2f u) {
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
inline float ggxLambda(const Vec3f& w, GgxAlpha alpha) {
  return alpha.isotropic() ? ggxLambdaOf<false>(w, alpha) : ggxLambdaOf<true>(w, alpha);
}
/// The visible-normal density given Λ(wo) = lambdaO (lobes evaluated many times for one wo keep
/// it, see PreviewSurfaceBsdf::Outgoing).
template <bool kAnisotropic>
float ggxVisibleNormalPdfOf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha, float lambdaO) {
  return 1 / (1 + lambdaO) * std::max(0.0f, dot(wo, h)) * ggxDensityOf<kAnisotropic>(h, alpha) /
         wo.z;
}
inline float ggxVisibleNormalPdf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha) {
  const float lambdaO = ggxLambda(wo, alpha);
  return alpha.isotropic() ? ggxVisibleNormalPdfOf<false>(wo, h, alpha, lambdaO)
                           : ggxVisibleNormalPdfOf<true>(wo, h, alpha, lambdaO);
}

/// f · cos θi of single-scattering GGX reflection without Fresnel: D G2 / (4 cos θo), given
/// D(h) = density and Λ(wo) = lambdaO (a BSDF evaluating and taking the density of one
/// direction computes D once for both).
inline float ggxReflectionWithoutFresnel(const Vec3f& wo, const Vec3f& wi, float density,
                                         GgxAlpha alpha, float lambdaO) {
  const float lambdaI =
      alpha.isotropic() ? ggxLambdaOf<false>(wi, alpha) : ggxLambdaOf<true>(wi, alpha);
  const float maskingShadowing = 1 / (1 + lambdaO + lambdaI);
  return density * maskingShadowing / (4 * wo.z);
}
inline float ggxReflectionWithoutFresnel(const Vec3f& wo, const Vec3f& wi, const Vec3f& h,
                                         GgxAlpha alpha, float lambdaO) {
  return ggxReflectionWithoutFresnel(wo, wi, ggxDensity(h, alpha), alpha, lambdaO);
}
inline float ggxReflectionWithoutFresnel(const Vec3f& wo, const Vec3f& wi, const Vec3f& h,
                                         GgxAlpha alpha) {
  return ggxReflectionWithoutFresnel(wo, wi, h, alpha, ggxLambda(wo, alpha));
}
/// Solid-angle density of wi = reflect(wo, h) with h sampled by sampleGgxVisibleNormal, given
/// D(h) = density and Λ(wo) = lambdaO.
inline float ggxReflectionPdf(const Vec3f& wo, const Vec3f& h, float density, float lambdaO) {
  const float cosThetaOH = dot(wo, h);
  if (!(cosThetaOH > 0)) return 0.0f;
  const float visible = 1 / (1 + lambdaO) * cosThetaOH * density / wo.z;
  return visible / (4 * cosThetaOH);
}
inline float ggxReflectionPdf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha, float lambdaO) {
  return ggxReflectionPdf(wo, h, ggxDensity(h, alpha), lambdaO);
}
inline float ggxReflectionPdf(const Vec3f& wo, const Vec3f& h, GgxAlpha alpha) {
  return ggxReflectionPdf(wo, h, alpha, ggxLambda(wo, alpha));
}

}  // namespace penumbra
