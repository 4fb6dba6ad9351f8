// The translucent part of PreviewSurfaceBsdf: a dielectric interface, smooth or rough (GGX),
// on a solid or a thin sheet; and the wavelength dependence of its index of refraction.
#include <cmath>

#include "albedo_tables.h"
#include "microfacet.h"
#include "penumbra/bsdf.h"

namespace penumbra {

float PreviewSurfaceBsdf::dielectricReflectance(float cosTheta, float eta) const {
  return dielectricReflectance(cosTheta, eta, ior_);
}

float PreviewSurfaceBsdf::dielectricReflectance(float cosTheta, float eta, float sheetIor) const {
  return dielectricKind_ == DielectricKind::ThinSheet
             ? thinSlabReflectance(fresnelDielectric(cosTheta, sheetIor))
             : fresnelDielectric(cosTheta, eta);
}

bool PreviewSurfaceBsdf::disperse(const Vec3f& woWorld, const Vec3f& channelIors, float choiceIor) {
  const bool fromOutside =
      dielectricKind_ == DielectricKind::ThinSheet || dot(woWorld, frame_.n) > 0;
  const bool aboveOne = channelIors.x > 1 && channelIors.y > 1 && channelIors.z > 1 &&
                        choiceIor > 1 && std::isfinite(maxComponent(channelIors)) &&
                        std::isfinite(choiceIor);
  if (!(opacity_ == 0 && dielectricAlpha_ == 0 && fromOutside && aboveOne)) return false;
  channelIors_ = channelIors;
  choiceIor_ = choiceIor;
  return true;
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

float dispersiveIor(float iorD, float abbeNumber, float wavelengthNm) {
  if (!(abbeNumber > 0)) return iorD;
  constexpr double kLineD = 587.6, kLineF = 486.1, kLineC = 656.3;  // nm
  const double b =
      (double(iorD) - 1) / (double(abbeNumber) * (1 / (kLineF * kLineF) - 1 / (kLineC * kLineC)));
  const double a = double(iorD) - b / (kLineD * kLineD);
  return float(a + b / (double(wavelengthNm) * double(wavelengthNm)));
}

}  // namespace penumbra
