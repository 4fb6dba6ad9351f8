// The UsdPreviewSurface BSDF (spec 2.5/2.6, docs/design.md §3): the scattering of one shading
// point.
//
// The surface is a mix of an opaque part (weight `opacity`) and a translucent part (weight
// 1 − opacity). The opaque part is a stack of layers, each attenuating the ones below by the
// energy it reflects:
//   sheen      Charlie microfibre distribution (Estevez and Kulla 2017), α = sheenRoughness
//              (≥ 0.01), Smith height-correlated masking-shadowing with Λ computed numerically,
//              no Fresnel, × sheen × sheenColor (Penumbra's extension; none when sheen is 0)
//   clearcoat  GGX, α = clearcoatRoughness² (stretched by clearcoatAnisotropy), Schlick F0 = 0.04
//              (ior 1.5), white, × `clearcoat`;
//              what lies under it is tinted by 1 − clearcoat + clearcoat × clearcoatColor
//   specular   GGX, α = roughness² (stretched by anisotropy), Schlick from F0 to F90 = 1 —
//              F0 = specularColor (specular
//              workflow) or ((1 − ior)/(1 + ior))² mixed towards diffuseColor by `metallic`
//              (metallic workflow) — plus Kulla–Conty multiple-scattering compensation
//   diffuse    Lambertian, diffuseColor (× (1 − metallic) in the metallic workflow)
//   subsurface on solids, a share `subsurface` of the diffuse layer enters the solid instead
//              (BsdfLobe::Subsurface: its light leaves elsewhere, through a random walk in
//              subsurface.h); on thin sheets that share reflects diffusely with subsurfaceColor
// The translucent part is a clear (untinted) dielectric interface with index of refraction `ior`
// and α = transmissionRoughness², reflection and refraction split by the exact Fresnel equations.
// Every GGX lobe is sampled by its visible normals (Heitz 2018) and uses Smith's
// height-correlated masking-shadowing; α below kDeltaAlpha makes the lobe a perfect mirror or
// refractor (a delta lobe).
//
// Anisotropy. The specular and clearcoat lobes may have different α along the shading tangent
// (αx) and bitangent (αy), from roughness and anisotropy by MaterialParams::anisotropyModel; the
// tangent is the one given to the constructor turned by anisotropyRotation. Their directional
// albedos (for the layering and the multiple-scattering term) depend on the azimuth too and come
// from a second table (about 0.15 s at first use of an anisotropic lobe); the lobe choice takes
// wo at azimuth 0. The translucent part stays isotropic.
//
// Conventions: directions are in world space, unit length, and point away from the surface; `wo`
// points towards where the ray came from. Values are for radiance transport (the integrator traces
// from the camera): refraction into a denser medium scales radiance by 1/η².
//
// Sides. The opaque part is two-sided: seen from the back, it scatters as if the shading normal
// were flipped. The translucent part knows an outside (the side the shading normal points to)
// and an inside; see DielectricKind for how it treats the inside.
//
// Layering. The diffuse layer under the specular layer is scaled by
// (1 − E(μo))(1 − E(μi)) / (1 − E_avg), E being the specular layer's directional albedo (Kelemen
// and Szirmay-Kalos 2001; Kulla and Conty 2017), which keeps it reciprocal and makes a white
// diffuse surface under any specular layer reflect exactly all energy. The layers under the
// clearcoat are scaled by (1 − c·E_cc(μo))(1 − c·E_cc(μi)) — light crosses the coat twice — which
// is reciprocal and never creates energy but drops the light bouncing between coat and base (a
// white rough metal under a full coat keeps 86–95 %). Everything under the sheen is scaled by
// 1 − sheen·E_sh(μo), E_sh being the white sheen lobe's directional albedo (albedo scaling, as
// MaterialX's layer node): exact in energy over any base (a white diffuse base under a white
// sheen reflects everything) but, like the rough dielectric below, not reciprocal. The sheen is
// sampled uniformly over the hemisphere (it scatters most towards grazing directions).
//
// Energy. The conductor/specular lobe gets Kulla–Conty's reciprocal multiple-scattering term; the
// rough dielectric is divided by its single-scattering albedo for wo (albedo scaling), which
// conserves energy for every wo but is not reciprocal — fine for a path tracer tracing from the
// camera, wrong for light tracing. The albedos are tabulated numerically at first use (about
// 20 ms for the GGX reflection table, 50 ms for the dielectric one, built only when a rough
// dielectric is first evaluated, and 0.1 s for the sheen's, built only when a sheen is first
// evaluated).
#pragma once

#include <cstdint>
#include <optional>

#include "penumbra/material.h"
#include "penumbra/math.h"

namespace penumbra {

/// GGX roughness α along the local frame's x (the shading tangent) and y (bitangent) axes.
struct GgxAlpha {
  float x = 0, y = 0;
  GgxAlpha() = default;
  GgxAlpha(float alpha) : x(alpha), y(alpha) {}  // NOLINT(google-explicit-constructor): isotropic
  GgxAlpha(float alongX, float alongY) : x(alongX), y(alongY) {}
  bool isotropic() const { return x == y; }
};

enum class BsdfLobe : uint8_t {
  Diffuse,
  Glossy,        // rough reflection (microfacet, incl. its multiple-scattering term)
  Specular,      // delta reflection
  Transmission,  // refraction, rough or delta (see BsdfSample::isDelta)
  /// Entry into a solid's scattering interior (MaterialParams::subsurface): a direction into
  /// the surface, cosine-distributed about the normal on the side away from wo, weighted by
  /// what the diffuse layer's share would have reflected (its Fresnel and coat losses for wo,
  /// without colour: the walk's albedo gives that). Light does not return through this lobe at
  /// this point: evaluate() and pdf() have no part of it; the integrator follows a random walk
  /// (subsurfaceRandomWalk) to where the light leaves.
  Subsurface,
};

struct BsdfSample {
  Vec3f direction;  // wi
  /// The factor the path throughput is multiplied by: f · |cos θi| / pdf. For a delta lobe, its
  /// reflectance or (radiance) transmittance divided by the probability of choosing it.
  Vec3f weight;
  /// Solid-angle density of `direction` over all non-delta lobes (what pdf() returns); for a
  /// delta lobe the discrete probability of having chosen it.
  float pdf = 0;
  BsdfLobe lobe = BsdfLobe::Diffuse;
  bool isDelta = false;
  bool transmitted = false;  // wi is on the other side of the shading normal than wo
  /// The direction is the hero wavelength's alone (refraction into a dispersive solid,
  /// PreviewSurfaceBsdf::disperse): the other channels' weight is 0, and the path's secondary
  /// wavelengths end here (SampledWavelengths::keepHeroOnly).
  bool heroOnly = false;
};

/// A BSDF's value and density for one pair of directions (evaluateWithPdf).
struct BsdfEvaluation {
  Vec3f value;    // f(wo, wi) · |cos θi| over the non-delta lobes, as evaluate()
  float pdf = 0;  // as pdf()
};

/// How the translucent part treats the side behind its shading normal. The renderer cannot tell
/// from a single hit whether a mesh is closed; the integrator (or the scene, e.g. by checking that
/// every edge of a mesh has exactly two faces) must choose:
///  - Solid: every surface is the boundary of a solid of index `ior` (the side behind the normal is
///    inside). Correct for closed meshes. An open single-sheet mesh (a window modelled as one
///    quad) then refracts once without refracting back: the image behind it is shifted and, by
///    the 1/η² radiance scaling, darkened (to 1/1.5² ≈ 44 % for ior 1.5).
///  - ThinSheet: the surface is an infinitesimally thin slab. Light passes through without
///    bending or radiance scaling; reflection and transmission include the slab's internal
///    bounces, R' = R + T²R/(1 − R²) for the exact Fresnel reflectance R. A rough sheet transmits
///    its glossy reflection lobe mirrored through the surface plane. Right for open meshes;
///    wrong (no refraction) for solids.
enum class DielectricKind : uint8_t { Solid, ThinSheet };

class PreviewSurfaceBsdf {
 public:
  /// GGX α below which a lobe is a perfect mirror or refractor (roughness ≲ 0.03): narrower lobes
  /// are indistinguishable from mirrors at film resolution and overflow the microfacet density.
  static constexpr float kDeltaAlpha = 1e-3f;

  /// `normal`: unit shading normal on the side of the authored front face. `ior`: the index of
  /// refraction to use instead of material.ior (wavelength-dependent under dispersion, see
  /// dispersiveIor); it also sets F0 in the metallic workflow. `tangent`: the surface's tangent
  /// (SurfaceHit::tangent), read only by anisotropic lobes; where it is zero or along the normal
  /// they take a fixed tangent of the normal's (Frame(normal).s). `minRoughness`: the least
  /// roughness of every microfacet lobe (the glossy filter's, IntegratorSettings::glossyFilter);
  /// 0 leaves them as authored.
  PreviewSurfaceBsdf(const MaterialParams& material, const Vec3f& normal, float ior,
                     DielectricKind dielectricKind = DielectricKind::Solid,
                     const Vec3f& tangent = Vec3f(0.0f), float minRoughness = 0);
  /// `isotropic` turned to face `normal`: bit for bit the BSDF its material would give there.
  /// Everything else the constructor derives depends on the material alone, so a material
  /// that does not vary over its surfaces sets up its BSDF once (MaterialTable::bsdfPrototype)
  /// instead of at every hit. Only for isotropic lobes, whose frame needs no tangent.
  PreviewSurfaceBsdf(const PreviewSurfaceBsdf& isotropic, const Vec3f& normal);

  /// f(wo, wi) · |cos θi| over the non-delta lobes. `diffusePart`, if given, receives the
  /// diffuse lobe's share (lights scale diffuse and specular response separately).
  Vec3f evaluate(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart = nullptr) const;
  /// Solid-angle density with which sample() produces wi through its non-delta lobes. It
  /// integrates to the probability of choosing a non-delta lobe (less the rare samples a
  /// microfacet lobe sends below the surface), which is all MIS needs.
  float pdf(const Vec3f& wo, const Vec3f& wi) const;
  /// evaluate() and pdf() at once, bit for bit the same, for callers that need both: the local
  /// directions, the half vector and the microfacet densities there are computed once.
  BsdfEvaluation evaluateWithPdf(const Vec3f& wo, const Vec3f& wi,
                                 Vec3f* diffusePart = nullptr) const;
  /// Chooses a lobe with `uLobe` (by its estimated albedo) and a direction in it with `u`.
  /// Non-delta samples are weighted against the whole BSDF (weight = evaluate / pdf), so the
  /// result does not depend on which lobe produced the direction. Empty when nothing scatters.
  std::optional<BsdfSample> sample(const Vec3f& wo, float uLobe, Vec2f u) const;
  /// sample() among the lobes above the diffuse layer alone (clearcoat, and the specular layer's
  /// single and multiple scattering), chosen in the same proportions: `weight` is what
  /// evaluate() gives less its diffusePart, over `pdf`, the density of this sampling (for a
  /// delta lobe, its probability here). For the light tracer, which takes that part of a
  /// material's light (caustics.h). Only for opaque materials without sheen or subsurface
  /// scattering; empty where those lobes scatter nothing.
  std::optional<BsdfSample> sampleAboveDiffuse(const Vec3f& wo, float uLobe, Vec2f u) const;

  /// Dispersion, for paths that carry three wavelengths (channel i at wavelength i, the hero
  /// first): gives each channel its index of refraction (`channelIors.x` the hero's, the
  /// constructor's `ior`), so that sample() reflects every channel with its own Fresnel factor,
  /// and a thin sheet transmits every channel, since these directions do not depend on the
  /// wavelength; only refraction into a solid is the hero's alone (BsdfSample::heroOnly).
  /// `choiceIor` (the material's own) sets the reflect/refract choice, which must not depend on
  /// the wavelengths: it decides whether the secondary wavelengths end, and so how the light the
  /// path gathered before is counted. Only where that choice is all there is to sample: the
  /// whole material is a smooth dielectric (opacity 0) seen from outside or a thin sheet, and
  /// every index is above 1 (no total internal reflection). Returns false, changing nothing,
  /// elsewhere: the path must keep its hero alone from here on.
  bool disperse(const Vec3f& wo, const Vec3f& channelIors, float choiceIor);
  /// Every lobe with non-zero weight is a delta: light sampling cannot hit any of them.
  bool isPurelySpecular() const;
  bool hasTransmission() const { return opacity_ < 1; }
  /// Whether every lobe is isotropic: the frame about the normal needs no tangent then.
  bool isotropic() const { return specularAlpha_.isotropic() && coatAlpha_.isotropic(); }

 private:
  struct LobeProbabilities {
    float coat = 0, specular = 0, multipleScattering = 0, diffuse = 0, sheen = 0, dielectric = 0,
          subsurface = 0;
  };
  /// What depends on the outgoing direction alone (wo, local, wo.z > 0): the lobe choice
  /// probabilities and the factors for wo of evaluateOpaque. Isotropic lobes read only wo.z.
  struct Outgoing {
    LobeProbabilities probabilities;
    float specularLoss = 0;     // 1 − E(wo) of the rough specular layer (single scattering)
    Vec3f underSpecular{1.0f};  // 1 − E(wo) of the diffuse layer's cover
    float coatTransmittance = 1;
    float sheenTransmittance = 1;
    float specularLambda = 0, coatLambda = 0;  // Smith Λ(wo) of the rough specular and coat
  };
  const Outgoing& outgoing(const Vec3f& wo) const;
  Outgoing computeOutgoing(const Vec3f& wo) const;
  /// Clearcoat transmittance 1 − c·E_cc(w) for light from local direction w (isotropic coats
  /// read only w.z).
  float coatTransmittance(const Vec3f& w) const;
  /// `value` (of a layer under the clearcoat) tinted by the coat's colour.
  Vec3f tintUnderCoat(const Vec3f& value) const;
  /// Directional albedo of the sheen layer, weight included and colour excluded: s·E_sh(μ).
  float sheenAlbedo(float cosTheta) const;
  /// What the sheen lets through to the layers under it for wo at cos θo: 1 − s·E_sh(μo).
  float sheenTransmittance(float cosThetaO) const;

  /// What the opaque part's value and density share for a pair of local directions with
  /// wo.z > 0 and wi.z > 0: the half vector and the GGX densities D(h) of the rough specular
  /// and clearcoat lobes (0 for delta lobes).
  struct Reflection {
    Vec3f h;
    float specularDensity = 0, coatDensity = 0;
  };
  Reflection reflection(const Vec3f& wo, const Vec3f& wi) const;

  /// Everything below in the local frame (z = shading normal); "opaque" functions expect
  /// wo.z > 0 (and wi.z > 0 with a Reflection), "dielectric" functions wo.z > 0 and the
  /// relative index η = n(wi side)/n(wo side) of the reflection–refraction pair (1 for a thin
  /// sheet).
  Vec3f evaluateOpaque(const Vec3f& wo, const Vec3f& wi, const Outgoing& forWo,
                       const Reflection& reflected, Vec3f* diffusePart) const;
  float pdfOpaque(const Vec3f& wo, const Vec3f& wi, const Outgoing& forWo,
                  const Reflection& reflected) const;
  float evaluateDielectric(const Vec3f& wo, const Vec3f& wi, float eta) const;
  float evaluateDielectricSingleScattering(const Vec3f& wo, const Vec3f& wi, float eta) const;
  /// Directional albedo of the single-scattering dielectric lobe (reflected plus transmitted flux).
  float dielectricAlbedo(float cosThetaO, float eta) const;
  float pdfDielectric(const Vec3f& wo, const Vec3f& wi, float eta) const;
  /// Fresnel reflectance of the dielectric (of the whole slab for a thin sheet).
  float dielectricReflectance(float cosTheta, float eta) const;
  /// The same for a solid of relative index `eta` or a thin sheet of index `sheetIor`.
  float dielectricReflectance(float cosTheta, float eta, float sheetIor) const;

  Frame frame_;
  float opacity_;
  // Clearcoat; α = 0 marks a delta lobe, here and below.
  float clearcoat_;
  GgxAlpha coatAlpha_;
  Vec3f coatTint_{1.0f};  // of the layers under the coat
  // Sheen (0: none) and its Charlie α.
  float sheen_;
  Vec3f sheenColor_{0.0f};
  float sheenAlpha_ = 1;
  // Specular layer.
  GgxAlpha specularAlpha_;
  Vec3f specularF0_;
  Vec3f specularF90_{1.0f};  // below 1 with a specular weight (MaterialParams::specularWeight)
  Vec3f multipleScatteringScale_;  // Kulla–Conty F_ms (F_avg² E_avg / (1 − F_avg (1 − E_avg)))
  // Diffuse layer and the specular layer it lies under (the dielectric one in the metallic
  // workflow, whose contribution the metallic mix then weights by 1 − metallic).
  Vec3f diffuseReflectance_;
  Vec3f diffuseCoverF0_;
  Vec3f diffuseCoverF90_{1.0f};
  Vec3f diffuseCoverMultipleScattering_;
  Vec3f diffuseNormalization_;  // 1 / (π (1 − E_avg)) of that cover, 0 where nothing gets through
  // The diffuse layer's share entering a solid (× (1 − metallic) in the metallic workflow; 0:
  // none) and the colour it shows, which weighs the lobe's choice.
  float subsurface_ = 0;
  Vec3f subsurfaceColor_{0.0f};
  // Translucent part.
  float ior_;
  float coatF0_;  // the clearcoat's normal-incidence reflectance, from its IOR
  float dielectricAlpha_;
  DielectricKind dielectricKind_;
  // Dispersion (disperse()): each channel's index and the one that sets the reflect/refract
  // choice; 0: none.
  Vec3f channelIors_{0.0f};
  float choiceIor_ = 0;
  // 1 − E_avg of the rough specular layer (0 when it is a mirror or loses nothing).
  float specularAverageLoss_ = 0;
  // outgoing() for the last wo asked (zero: none yet): one vertex asks for its wo several times
  // (each light sample's evaluate and pdf, then sample). A BSDF lives on one thread, within one
  // vertex.
  mutable Vec3f cachedWo_{0.0f};
  mutable Outgoing cachedOutgoing_;
};

/// Index of refraction at `wavelengthNm` from the Cauchy fit n(λ) = A + B/λ² through n_d = iorD at
/// the Fraunhofer d line (587.6 nm) with Abbe number V_d = (n_d − 1)/(n_F − n_C), F = 486.1 nm,
/// C = 656.3 nm. abbeNumber <= 0 means no dispersion (iorD at every wavelength).
float dispersiveIor(float iorD, float abbeNumber, float wavelengthNm);

}  // namespace penumbra
