// Scattering from a hair or fur fibre: Chiang, Bitterli, Tappan and Burley 2016, "A Practical and
// Controllable Hair and Fur Model for Production Path Tracing", in the form pbrt-v4 (§9.9)
// describes, on Marschner et al.'s decomposition (docs/design.md, "Hair").
//
// The fibre is a rough dielectric cylinder (index `hairIor`) with an absorbing interior (σa per
// unit radius). Light leaves it after p internal paths: R (p = 0, reflected at the surface), TT
// (p = 1, through it), TRT (p = 2, one internal reflection) and a residual lobe for all p ≥ 3.
// Each lobe is a product M_p(θo, θi) · A_p(θo, h) · N_p(φ; h):
//   M_p  longitudinal scattering, d'Eon et al.'s normalised von Mises–Fisher-like lobe of
//        variance v_p (from β_m; v_TT = v_R·scaleTT², v_TRT = v_R·scaleTRT², the residual as
//        TRT), in its log-Bessel form for v ≤ 0.1 so narrow lobes do not overflow; the cuticle
//        scales tilt the lobes: θo becomes θo − 2α (R), θo + α (TT), θo + 4α (TRT);
//   A_p  attenuation: Fresnel reflectance f at cos θo·cos γo and the transmittance T of one
//        crossing of the interior, f, (1 − f)²T, (1 − f)²T²f, then the geometric series'
//        remainder (1 − f)²T³f²/(1 − Tf); each lobe's is multiplied by its tint (the residual
//        takes TRT's, as MaterialX's chiang_hair_bsdf does);
//   N_p  azimuthal scattering, a logistic of scale s_p (from β_n; s_TT = s_R·azimuthalScaleTT,
//        s_TRT = s_R·azimuthalScaleTRT) trimmed to [−π, π] around the ideal exit azimuth
//        Φ = 2pγt − 2γo + pπ; uniform for the residual.
// Angles: θ is the longitudinal angle (sin θ = w·fibre), φ the azimuth about the fibre, h = sin γo
// the offset across the fibre where the ray meets it, γt the refracted γ (Bravais' index).
//
// Geometry. The local frame's x axis is the fibre direction; z is the hit's normal made
// perpendicular to it. h is derived from wo and that normal: for a round tube the normal is the
// cylinder's and h exact; on a flat ribbon facing the ray the normal faces wo and h ≈ 0 (every hit
// is treated as meeting the fibre's centre, which narrows the azimuthal spread of the image of a
// fibre). On a surface that is not a fibre (no fibre direction) the fibre is the fixed tangent
// Frame(shadingNormal).s of the shading normal, and the normal the shading normal. The BSDF
// accounts for the whole passage through the fibre, so the integrator starts the rays it sends
// into a round tube at the tube's far wall (spawnRay in integrator.cpp): they must not scatter
// there a second time.
//
// Energy and reciprocity. With no absorption and white tints, ∫ evaluate dωi = Σ A_p = 1 for every
// wo (M_p and N_p are normalised). The model is not reciprocal in general: A_p and the cuticle
// tilt are evaluated for wo only (as in the paper and pbrt). It is reciprocal for the R lobe
// between a direction and its mirror image about the normal when α = 0, and for the whole BSDF when
// η = 1, α = 0 and σa = 0 (only TT, with Φ = π).
//
// Sampling follows the pdf exactly: a lobe by its tinted attenuation, θi from M_p (d'Eon's
// sampling), φ from the trimmed logistic (uniform for the residual). pdf() is Σ_p P(p)·M_p·N_p.
#pragma once

#include <array>
#include <optional>

#include "penumbra/bsdf.h"
#include "penumbra/material.h"
#include "penumbra/math.h"

namespace penumbra {

/// exp(−σ) of eumelanin's and pheomelanin's absorption (d'Eon et al. 2011), as MaterialX's
/// deon_hair_absorption_from_melanin takes them.
constexpr Vec3f kEumelaninColor{0.657704f, 0.498077f, 0.254107f};
constexpr Vec3f kPheomelaninColor{0.829444f, 0.670320f, 0.349938f};

/// σa (per unit fibre radius) giving a fibre of azimuthal roughness β_n the multiply scattered
/// colour `color` (Chiang et al. 2016, eq. 9): σa = (ln c / (5.969 − 0.215β_n + 2.532β_n² −
/// 10.73β_n³ + 5.574β_n⁴ + 0.245β_n⁵))², c clamped to [0.001, 1] as MaterialX's
/// chiang_hair_absorption_from_color does.
Vec3f hairAbsorptionFromColor(const Vec3f& color, float azimuthalRoughness);

/// The inverse of hairAbsorptionFromColor: the colour c = exp(−√σa · denominator(β_n)) a fibre
/// of absorption σa shows under multiple scattering (for an albedo AOV).
Vec3f hairColorFromAbsorption(const Vec3f& absorption, float azimuthalRoughness);

/// σa from melanin (d'Eon et al. 2011, as MaterialX's deon_hair_absorption_from_melanin): the
/// melanin amount m = −ln(1 − concentration), split by `redness` into eumelanin m(1 − redness)
/// and pheomelanin m·redness, each absorbing −ln of its colour.
Vec3f hairAbsorptionFromMelanin(float concentration, float redness,
                                const Vec3f& eumelaninColor = kEumelaninColor,
                                const Vec3f& pheomelaninColor = kPheomelaninColor);

/// σa of a hair material at a shading point (its inputs evaluated there): hairAbsorption, or
/// derived from its colour or melanin as its hairAbsorptionFrom* switches say (material.h).
Vec3f hairAbsorptionAt(const MaterialParams& material);
/// The colour a hair material's fibre shows under multiple scattering (the albedo AOV's): its
/// hairColor, clamped as the conversion clamps it, when σa derives from that; else the colour of
/// its σa (hairColorFromAbsorption with β_n).
Vec3f hairColorAt(const MaterialParams& material);

/// The hair BSDF's longitudinal variance v from β_m (pbrt-v4, Chiang et al. eq. 7):
/// (0.726β + 0.812β² + 3.7β²⁰)².
float hairLongitudinalVariance(float longitudinalRoughness);
/// The azimuthal logistic's scale s from β_n (eq. 8): √(π/8)(0.265β + 1.194β² + 5.372β²²).
float hairAzimuthalScale(float azimuthalRoughness);
/// M_p: the longitudinal lobe of variance v for light from θi leaving at θo (both as sin, cos),
/// normalised so that ∫ M_p cos θi dθi = 1 over [−π/2, π/2].
float hairLongitudinalScattering(float sinThetaI, float cosThetaI, float sinThetaO, float cosThetaO,
                                 float variance);

class HairBsdf {
 public:
  /// The lobes: R, TT, TRT and the residual (p ≥ 3).
  static constexpr int kLobes = 4;
  /// β_m and β_n are kept within [kMinRoughness, 1]: narrower lobes underflow M_p's sampling.
  static constexpr float kMinRoughness = 0.01f;

  /// `fibreDirection`: the fibre's unit direction (SurfaceHit::fibreDirection), zero on other
  /// surfaces. `normal`: the unit geometric normal (read for h on fibres, and for the side of
  /// every direction: BsdfSample::transmitted). `shadingNormal`: the unit shading normal (the
  /// fibre's frame where there is no fibre direction).
  HairBsdf(const MaterialParams& material, const Vec3f& fibreDirection, const Vec3f& normal,
           const Vec3f& shadingNormal);

  /// f(wo, wi)·|cos θi| = Σ_p M_p A_p N_p. `diffusePart`, if given, is set to zero: no lobe is
  /// diffuse.
  Vec3f evaluate(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart = nullptr) const;
  /// Solid-angle density of sample()'s directions; integrates to 1 over the sphere.
  float pdf(const Vec3f& wo, const Vec3f& wi) const;
  /// A lobe chosen with `uLobe` by its tinted attenuation (the rest of `uLobe`, rescaled, samples
  /// the azimuth), θi from M_p with `u`. Weight = evaluate / pdf. R, TRT and the residual are
  /// Glossy lobes, TT Transmission. Empty when nothing scatters.
  std::optional<BsdfSample> sample(const Vec3f& wo, float uLobe, Vec2f u) const;

  bool isPurelySpecular() const { return false; }
  /// Light goes through the fibre: lights on both sides of it count.
  bool hasTransmission() const { return true; }

 private:
  /// What depends on wo alone, in the local frame.
  struct Outgoing {
    float sinThetaO = 0, cosThetaO = 1, phiO = 0;
    float gammaO = 0, gammaT = 0;
    std::array<Vec3f, kLobes> attenuation;  // A_p × tint_p
    std::array<float, kLobes> probability;  // of choosing lobe p
    /// sin and cos of θo tilted for each lobe's M_p.
    std::array<float, kLobes> sinThetaTilted, cosThetaTilted;
  };
  Outgoing outgoing(const Vec3f& woLocal) const;
  /// N_p for the azimuth difference φ = φi − φo.
  float azimuthal(int lobe, float phi, const Outgoing& o) const;
  /// Σ_p M_p N_p × (A_p tint_p, or P(p) when `probabilities`), in the local frame.
  Vec3f sum(const Outgoing& o, const Vec3f& wiLocal, bool probabilities) const;

  Frame frame_;  // s: fibre (x), t: y, n: the normal across the fibre (z)
  Vec3f sideNormal_;
  float eta_;
  Vec3f absorption_;
  std::array<Vec3f, 3> tints_;          // R, TT, TRT (the residual's is TRT's)
  std::array<float, kLobes> variance_;  // v_p of M_p
  std::array<float, 3> logisticScale_;  // s_p of N_p (R, TT, TRT)
  // sin and cos of 2^k α for k = 0, 1, 2 (α, 2α, 4α).
  std::array<float, 3> sin2kAlpha_, cos2kAlpha_;
};

}  // namespace penumbra
