// PreviewSurfaceBsdf's opaque part (its layers and their energy exchange), the lobe choice and
// the evaluate/pdf/sample entry points. The translucent part is in dielectric.cpp; the lobes'
// maths in microfacet.h, albedo_tables.h and sheen.h.
#include "penumbra/bsdf.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "albedo_tables.h"
#include "microfacet.h"
#include "penumbra/warp.h"
#include "sheen.h"

namespace penumbra {
namespace {

Vec3f lerp(const Vec3f& a, const Vec3f& b, float t) {
  return a * (1 - t) + b * t;
}

/// A specular layer: GGX (or a mirror when alpha = 0) with Schlick's Fresnel from f0 to f90 and
/// a Kulla–Conty multiple-scattering term scaled by `multipleScattering`.
struct SpecularLayer {
  GgxAlpha alpha;
  Vec3f f0;
  Vec3f multipleScattering;
  Vec3f f90{1.0f};

  /// Directional albedo E(w): everything the layer reflects for light from local direction w
  /// (only w.z matters to isotropic lobes).
  Vec3f albedo(const Vec3f& w) const {
    if (alpha.x == 0) return schlickFresnel(f0, w.z, f90);
    return albedo(ggxDirectionalAlbedo(w, alpha));
  }
  /// The same for a rough layer, from the table's entry for w and α.
  Vec3f albedo(const GgxAlbedoTable::Albedo& e) const {
    return f0 * e.scale + f90 * e.bias + multipleScattering * (1 - e.scale - e.bias);
  }
  /// Hemispherical average (1/π) ∫ E(w) cos θ dw, given ggxAverageAlbedo(alpha) (looked up
  /// once per BSDF).
  Vec3f averageAlbedo(const GgxAlbedoTable::Albedo& lobeAverage) const {
    if (alpha.x == 0) return schlickAverage(f0, f90);
    const GgxAlbedoTable::Albedo& e = lobeAverage;
    return f0 * e.scale + f90 * e.bias + multipleScattering * (1 - e.scale - e.bias);
  }
};

/// Kulla–Conty scale F_avg² E_avg / (1 − F_avg (1 − E_avg)) of the multiple-scattering lobe
/// (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)), which by itself reflects 1 − E(μo): the energy of
/// the light that bounces more than once between microfacets, each bounce attenuated by the
/// average Fresnel reflectance.
/// `averageAlbedo`: E_avg of the white lobe (0 for a delta lobe, which has no such term).
Vec3f multipleScatteringScale(const Vec3f& f0, float averageAlbedo,
                              const Vec3f& f90 = Vec3f(1.0f)) {
  if (averageAlbedo == 0) return Vec3f(0.0f);
  const Vec3f fresnel = schlickAverage(f0, f90);
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

/// Normal-incidence reflectance of a dielectric of index `ior` (in air).
float fresnelAtNormalIncidence(float ior) {
  return square((1 - ior) / (1 + ior));
}

/// The same for the clearcoat, in double: the common 1.5 gives 0.04f exactly, as before the
/// coat followed its IOR.
float coatReflectance(float ior) {
  const double ratio = (1.0 - double(ior)) / (1.0 + double(ior));
  return float(ratio * ratio);
}

}  // namespace

PreviewSurfaceBsdf::PreviewSurfaceBsdf(const MaterialParams& material, const Vec3f& normal,
                                       float ior, DielectricKind dielectricKind,
                                       const Vec3f& tangent, float minRoughness)
    : frame_(normal),
      opacity_(clamp01(material.opacity)),
      clearcoat_(clamp01(material.clearcoat)),
      coatAlpha_(lobeAlpha(std::max(material.clearcoatRoughness, minRoughness),
                           material.clearcoatAnisotropy, material.anisotropyModel)),
      sheen_(clamp01(material.sheen)),
      specularAlpha_(lobeAlpha(std::max(material.roughness, minRoughness), material.anisotropy,
                               material.anisotropyModel)),
      ior_(std::isfinite(ior) && ior > 0 ? ior : 1.0f),
      coatF0_(coatReflectance(material.clearcoatIor >= 0 ? material.clearcoatIor : material.ior)),
      // transmissionRoughness < 0 follows roughness.
      dielectricAlpha_(microfacetAlpha(std::max(
          material.transmissionRoughness < 0 ? material.roughness : material.transmissionRoughness,
          minRoughness))),
      dielectricKind_(dielectricKind) {
  if (!isotropic()) {
    // x along the tangent turned by the rotation (counter-clockwise about the normal).
    frame_ = Frame::withTangent(normal, tangent);
    const float angle =
        2 * kPi * (std::isfinite(material.anisotropyRotation) ? material.anisotropyRotation : 0.0f);
    const float c = std::cos(angle), s = std::sin(angle);
    const Vec3f turned = frame_.s * c + frame_.t * s;
    frame_.t = frame_.t * c - frame_.s * s;
    frame_.s = turned;
  }
  // The coat tint and the sheen are set up only where they act: materials without them pay
  // nothing for them.
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
  // A specular weight below 1 scales the dielectric lobe whole, its grazing reflection too (F90),
  // as MaterialX's weights do; at 1 the arithmetic is the unweighted one, bit for bit.
  const float specularWeight = clamp01(material.specularWeight);
  const bool weighted = specularWeight < 1;
  if (material.useSpecularWorkflow) {
    specularF0_ = clamp01(material.specularColor);
    if (weighted) {
      specularF0_ = specularF0_ * specularWeight;
      specularF90_ = Vec3f(specularWeight);
    }
    multipleScatteringScale_ = multipleScatteringScale(specularF0_, averageAlbedo, specularF90_);
    diffuseReflectance_ = albedo;
    diffuseCoverF0_ = specularF0_;
    diffuseCoverF90_ = specularF90_;
    diffuseCoverMultipleScattering_ = multipleScatteringScale_;
  } else {
    // A linear mix of a dielectric (weight 1 − metallic) and a conductor of reflectance
    // diffuseColor. Both specular lobes share α, so their sum is one lobe with the mixed F0.
    // The conductor's Fresnel runs from the albedo to F90: the albedo too for
    // UsdPreviewSurface, white for MaterialX's conductors (MaterialParams::metalWhiteEdge).
    const float metallic = clamp01(material.metallic);
    const Vec3f metalF90 = material.metalWhiteEdge ? Vec3f(1.0f) : albedo;
    Vec3f dielectricF0(fresnelAtNormalIncidence(ior_));
    if (weighted) {
      dielectricF0 = dielectricF0 * specularWeight;
      diffuseCoverF90_ = Vec3f(specularWeight);
    }
    specularF90_ = lerp(diffuseCoverF90_, metalF90, metallic);
    specularF0_ = lerp(dielectricF0, albedo, metallic);
    diffuseCoverF0_ = dielectricF0;
    diffuseCoverMultipleScattering_ =
        multipleScatteringScale(dielectricF0, averageAlbedo, diffuseCoverF90_);
    // Without metal the conductor's term would add exactly 0: it is not computed then.
    multipleScatteringScale_ =
        metallic > 0 ? diffuseCoverMultipleScattering_ * (1 - metallic) +
                           multipleScatteringScale(albedo, averageAlbedo, metalF90) * metallic
                     : diffuseCoverMultipleScattering_;
    diffuseReflectance_ = albedo * (1 - metallic);
  }
  const float subsurface = clamp01(material.subsurface);
  if (subsurface > 0) {
    // Subsurface scattering shares the diffuse layer (with its metallic weight): solids let
    // that share in; sheets, which hold no medium, reflect it with the subsurface colour.
    const float dielectricShare =
        material.useSpecularWorkflow ? 1.0f : 1 - clamp01(material.metallic);
    const Vec3f subsurfaceColor = clamp01(material.subsurfaceColor);
    if (dielectricKind_ == DielectricKind::Solid) {
      diffuseReflectance_ = diffuseReflectance_ * (1 - subsurface);
      subsurface_ = subsurface * dielectricShare;
      subsurfaceColor_ = subsurfaceColor;
    } else {
      diffuseReflectance_ =
          lerp(diffuseReflectance_, subsurfaceColor * dielectricShare, subsurface);
    }
  }
  const Vec3f coverAverage = SpecularLayer{specularAlpha_, diffuseCoverF0_,
                                           diffuseCoverMultipleScattering_, diffuseCoverF90_}
                                 .averageAlbedo(lobeAverage);
  const auto normalization = [](float average) {
    return average < 1 - 1e-4f ? kInvPi / (1 - average) : 0.0f;
  };
  diffuseNormalization_ = {normalization(coverAverage.x), normalization(coverAverage.y),
                           normalization(coverAverage.z)};
  if (clearcoat_ > 0) {
    // The coat takes its transmittance from light going in and from light coming out; the
    // diffuse layer gives back, on average, what the coat lets down to it (as the specular cover
    // above does), so that a white base under a coat stays white.
    const GgxAlbedoTable::Albedo coatLobe =
        coatAlpha_.x > 0 ? ggxAverageAlbedo(coatAlpha_) : GgxAlbedoTable::Albedo{};
    const float coatAverage =
        clearcoat_ *
        SpecularLayer{coatAlpha_, Vec3f(coatF0_), Vec3f(0.0f)}.averageAlbedo(coatLobe).x;
    diffuseNormalization_ = diffuseNormalization_ * (1 / (1 - coatAverage));
  }
}

PreviewSurfaceBsdf::PreviewSurfaceBsdf(const PreviewSurfaceBsdf& isotropic, const Vec3f& normal)
    : PreviewSurfaceBsdf(isotropic) {
  frame_ = Frame(normal);
}

bool PreviewSurfaceBsdf::isPurelySpecular() const {
  const bool opaqueIsDelta =
      opacity_ == 0 ||
      (sheen_ == 0 && (clearcoat_ == 0 || coatAlpha_.x == 0) && specularAlpha_.x == 0 &&
       isBlack(diffuseReflectance_ * diffuseNormalization_));
  const bool translucentIsDelta = opacity_ == 1 || dielectricAlpha_ == 0 || ior_ == 1;
  return opaqueIsDelta && translucentIsDelta;
}

// The private helpers on every evaluation's path are declared `inline` here (only this file
// uses them): in position-independent code GCC does not inline a function that is not inline,
// since another module could interpose it, so each would cost a call.
inline float PreviewSurfaceBsdf::coatTransmittance(const Vec3f& w) const {
  if (clearcoat_ == 0) return 1;
  return 1 - clearcoat_ * SpecularLayer{coatAlpha_, Vec3f(coatF0_), Vec3f(0.0f)}.albedo(w).x;
}

inline Vec3f PreviewSurfaceBsdf::tintUnderCoat(const Vec3f& value) const {
  return value * coatTint_;  // exact (bit-identical) where the tint is 1
}

inline float PreviewSurfaceBsdf::sheenAlbedo(float cosTheta) const {
  return sheen_ * sheenTables().albedo(cosTheta, sheenAlpha_);
}

inline float PreviewSurfaceBsdf::sheenTransmittance(float cosThetaO) const {
  return sheen_ > 0 ? 1 - sheenAlbedo(cosThetaO) : 1.0f;
}

inline const PreviewSurfaceBsdf::Outgoing& PreviewSurfaceBsdf::outgoing(const Vec3f& wo) const {
  if (wo.z != cachedWo_.z || wo.x != cachedWo_.x || wo.y != cachedWo_.y) {
    cachedWo_ = wo;
    cachedOutgoing_ = computeOutgoing(wo);
  }
  return cachedOutgoing_;
}

PreviewSurfaceBsdf::Outgoing PreviewSurfaceBsdf::computeOutgoing(const Vec3f& wo) const {
  const float cosThetaO = wo.z;
  Outgoing outgoing;
  const SpecularLayer cover{specularAlpha_, diffuseCoverF0_, diffuseCoverMultipleScattering_,
                            diffuseCoverF90_};
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
      p.specular =
          below * luminance(tintUnderCoat(schlickFresnel(specularF0_, cosThetaO, specularF90_)));
    } else {
      p.specular = below * luminance(tintUnderCoat(specularF0_ * e.scale + specularF90_ * e.bias));
      p.multipleScattering =
          below * luminance(tintUnderCoat(multipleScatteringScale_)) * outgoing.specularLoss;
    }
    p.diffuse = below * luminance(tintUnderCoat(diffuseReflectance_ * outgoing.underSpecular));
    if (subsurface_ > 0) {
      p.subsurface =
          below * subsurface_ * luminance(tintUnderCoat(subsurfaceColor_ * outgoing.underSpecular));
    }
  }
  p.dielectric = 1 - opacity_;  // its albedo is 1: energy-compensated, and nothing is absorbed
  // (Subsurface last: where it is 0 the sum is bit-identical to the one without it.)
  const float total = p.coat + p.specular + p.multipleScattering + p.diffuse + p.sheen +
                      p.dielectric + p.subsurface;
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
  p.subsurface *= scale;
  return outgoing;
}

inline PreviewSurfaceBsdf::Reflection PreviewSurfaceBsdf::reflection(const Vec3f& wo,
                                                                     const Vec3f& wi) const {
  Reflection reflected;
  reflected.h = normalize(wo + wi);
  if (specularAlpha_.x > 0) reflected.specularDensity = ggxDensity(reflected.h, specularAlpha_);
  if (coatAlpha_.x > 0) reflected.coatDensity = ggxDensity(reflected.h, coatAlpha_);
  return reflected;
}

inline Vec3f PreviewSurfaceBsdf::evaluateOpaque(const Vec3f& wo, const Vec3f& wi,
                                                const Outgoing& forWo, const Reflection& reflected,
                                                Vec3f* diffusePart) const {
  const Vec3f& h = reflected.h;
  const SpecularLayer cover{specularAlpha_, diffuseCoverF0_, diffuseCoverMultipleScattering_,
                            diffuseCoverF90_};
  Vec3f base(0.0f), underSpecularForWi(1.0f);
  if (specularAlpha_.x > 0) {
    base += schlickFresnel(specularF0_, dot(wo, h), specularF90_) *
            ggxReflectionWithoutFresnel(wo, wi, reflected.specularDensity, specularAlpha_,
                                        forWo.specularLambda);
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
    value += Vec3f(
        clearcoat_ * schlickFresnel(Vec3f(coatF0_), dot(wo, h)).x *
        ggxReflectionWithoutFresnel(wo, wi, reflected.coatDensity, coatAlpha_, forWo.coatLambda));
  }
  if (sheen_ > 0) {
    const float underSheen = forWo.sheenTransmittance;
    if (diffusePart) *diffusePart *= underSheen;
    value = value * underSheen + sheenColor_ * (sheen_ * sheenReflection(wo, wi, sheenAlpha_));
  }
  return value * opacity_;
}

inline float PreviewSurfaceBsdf::pdfOpaque(const Vec3f& wo, const Vec3f& wi, const Outgoing& forWo,
                                           const Reflection& reflected) const {
  const LobeProbabilities& p = forWo.probabilities;
  const Vec3f& h = reflected.h;
  float density = (p.multipleScattering + p.diffuse) * wi.z * kInvPi;
  if (specularAlpha_.x > 0) {
    density +=
        p.specular * ggxReflectionPdf(wo, h, reflected.specularDensity, forWo.specularLambda);
  }
  if (coatAlpha_.x > 0)
    density += p.coat * ggxReflectionPdf(wo, h, reflected.coatDensity, forWo.coatLambda);
  if (sheen_ > 0) density += p.sheen * kUniformHemispherePdf;
  return density;
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
  Vec3f value(0.0f);
  if (opacity_ > 0 && wi.z > 0)
    value = evaluateOpaque(wo, wi, outgoing(wo), reflection(wo, wi), diffusePart);
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
  float density =
      p.dielectric < 1 && wi.z > 0 ? pdfOpaque(wo, wi, forWo, reflection(wo, wi)) : 0.0f;
  if (p.dielectric > 0 && dielectricAlpha_ > 0 && ior_ != 1) {
    density += p.dielectric * pdfDielectric(wo, wi, pair.flipped ? 1 / ior_ : ior_);
  }
  return density;
}

BsdfEvaluation PreviewSurfaceBsdf::evaluateWithPdf(const Vec3f& woWorld, const Vec3f& wiWorld,
                                                   Vec3f* diffusePart) const {
  if (diffusePart) *diffusePart = Vec3f(0.0f);
  const OrientedPair pair = orient(frame_, woWorld, wiWorld);
  const Vec3f &wo = pair.wo, &wi = pair.wi;
  BsdfEvaluation result{Vec3f(0.0f), 0.0f};
  if (wo.z == 0 || wi.z == 0) return result;
  const Outgoing& forWo = outgoing(wo);
  const LobeProbabilities& p = forWo.probabilities;
  const bool opaqueValue = opacity_ > 0, opaqueDensity = p.dielectric < 1;
  if (wi.z > 0 && (opaqueValue || opaqueDensity)) {
    const Reflection reflected = reflection(wo, wi);
    if (opaqueValue) result.value = evaluateOpaque(wo, wi, forWo, reflected, diffusePart);
    if (opaqueDensity) result.pdf = pdfOpaque(wo, wi, forWo, reflected);
  }
  if (dielectricAlpha_ > 0 && ior_ != 1) {
    const float eta = pair.flipped ? 1 / ior_ : ior_;
    if (opacity_ < 1) result.value += Vec3f((1 - opacity_) * evaluateDielectric(wo, wi, eta));
    if (p.dielectric > 0) result.pdf += p.dielectric * pdfDielectric(wo, wi, eta);
  }
  return result;
}

std::optional<BsdfSample> PreviewSurfaceBsdf::sample(const Vec3f& woWorld, float uLobe,
                                                     Vec2f u) const {
  Vec3f wo = frame_.toLocal(woWorld);
  const bool flipped = wo.z < 0;
  if (flipped) wo.z = -wo.z;
  if (!(wo.z > 0)) return std::nullopt;
  const Outgoing& forWo = outgoing(wo);
  const LobeProbabilities& p = forWo.probabilities;

  // Picks lobe k if uLobe falls in its interval and rescales uLobe to [0, 1) within it, so that
  // the dielectric can reuse it for its reflect/refract choice. Subsurface comes last, so that
  // materials without it choose exactly as before.
  constexpr int kLobes = 7;
  const std::array<float, kLobes> probabilities{
      p.coat, p.specular, p.multipleScattering, p.diffuse, p.sheen, p.dielectric, p.subsurface};
  int lobe = -1;
  float cumulative = 0;
  for (int k = 0; k < kLobes; ++k) {
    if (probabilities[k] > 0 && uLobe < cumulative + probabilities[k]) {
      lobe = k;
      uLobe = std::min((uLobe - cumulative) / probabilities[k], 0.99999994f);
      break;
    }
    cumulative += probabilities[k];
  }
  if (lobe < 0) {  // rounding left uLobe past the last interval: take the last non-empty lobe
    for (int k = kLobes - 1; k >= 0 && lobe < 0; --k) {
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
                     Vec3f(opacity_ * clearcoat_ * schlickFresnel(Vec3f(coatF0_), wo.z).x *
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
                     tintUnderCoat(schlickFresnel(specularF0_, wo.z, specularF90_)) *
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
    case 6: {  // into the solid: what the diffuse share would have reflected, without colour
      Vec3f inward = sampleCosineHemisphere(u);
      inward.z = -inward.z;
      const float coat = forWo.coatTransmittance;
      result.direction = toWorld(inward);
      result.weight = tintUnderCoat(forWo.underSpecular) *
                      (opacity_ * subsurface_ * coat * forWo.sheenTransmittance / p.subsurface);
      result.pdf = p.subsurface * -inward.z * kInvPi;
      result.lobe = BsdfLobe::Subsurface;
      result.transmitted = true;
      if (!(result.pdf > 0)) return std::nullopt;
      return result;
    }
    default: {  // translucent part
      const float eta = flipped ? 1 / ior_ : ior_;
      const float weight = 1 - opacity_;
      if (ior_ == 1) {  // an index-matched interface: light passes unchanged
        return delta(-wo, Vec3f(weight), p.dielectric, BsdfLobe::Transmission);
      }
      if (dielectricAlpha_ == 0) {
        // Under dispersion (disperse()) each channel reflects by its own index's Fresnel factor
        // and the choice takes choiceIor_; wo is then outside a solid, so eta is ior_, the hero's.
        const bool dispersed = choiceIor_ > 0;
        const auto reflectanceOf = [&](float ior) { return dielectricReflectance(wo.z, ior, ior); };
        const float reflected =
            dispersed ? reflectanceOf(choiceIor_) : dielectricReflectance(wo.z, eta);
        const Vec3f reflectance =
            dispersed ? Vec3f(reflectanceOf(channelIors_.x), reflectanceOf(channelIors_.y),
                              reflectanceOf(channelIors_.z))
                      : Vec3f(reflected);
        if (uLobe < reflected) {
          return delta(mirror, reflectance * weight, p.dielectric * reflected, BsdfLobe::Specular);
        }
        const Vec3f transmittance = Vec3f(1.0f) - reflectance;
        const float transmitted = 1 - reflected;
        if (dielectricKind_ == DielectricKind::ThinSheet) {
          return delta(-wo, transmittance * weight, p.dielectric * transmitted,
                       BsdfLobe::Transmission);
        }
        // Refraction bends each wavelength its own way: under dispersion the hero's alone.
        result.heroOnly = dispersed;
        const Vec3f refracted = *refract(wo, Vec3f(0, 0, 1), eta);  // reflectance < 1: no TIR
        const float heroWeight = weight * transmittance.x / (eta * eta);
        return delta(refracted, dispersed ? Vec3f(heroWeight, 0, 0) : Vec3f(heroWeight),
                     p.dielectric * transmitted, BsdfLobe::Transmission);
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
  const BsdfEvaluation evaluated = evaluateWithPdf(woWorld, result.direction);
  result.pdf = evaluated.pdf;
  if (!(result.pdf > 0)) return std::nullopt;
  result.weight = evaluated.value / result.pdf;
  return result;
}

std::optional<BsdfSample> PreviewSurfaceBsdf::sampleAboveDiffuse(const Vec3f& woWorld, float uLobe,
                                                                 Vec2f u) const {
  Vec3f wo = frame_.toLocal(woWorld);
  if (wo.z < 0) wo.z = -wo.z;
  if (!(wo.z > 0)) return std::nullopt;
  const Outgoing& forWo = outgoing(wo);
  const LobeProbabilities& p = forWo.probabilities;
  // Those lobes come first in sample()'s order: [0, above) of its lobe choice picks among them
  // alone, in proportion to their probabilities.
  const float above = p.coat + p.specular + p.multipleScattering;
  if (!(above > 0)) return std::nullopt;
  std::optional<BsdfSample> result =
      sample(woWorld, std::min(uLobe * above, std::nextafter(above, 0.0f)), u);
  if (!result || result->lobe == BsdfLobe::Diffuse) return std::nullopt;
  if (result->isDelta) {
    result->weight *= above;
    result->pdf /= above;
    return result;
  }
  const OrientedPair pair = orient(frame_, woWorld, result->direction);
  Outgoing withoutDiffuse = forWo;
  withoutDiffuse.probabilities.diffuse = 0;
  const Reflection reflected = reflection(pair.wo, pair.wi);
  Vec3f diffusePart;
  const Vec3f value = evaluateOpaque(pair.wo, pair.wi, forWo, reflected, &diffusePart);
  result->pdf = pdfOpaque(pair.wo, pair.wi, withoutDiffuse, reflected) / above;
  if (!(result->pdf > 0)) return std::nullopt;
  result->weight = componentMax(value - diffusePart, Vec3f(0.0f)) / result->pdf;
  return result;
}

}  // namespace penumbra
