#include "penumbra/integrator.h"

#include <array>
#include <type_traits>
#include <utility>
#include <variant>

#include "path_spectrum.h"
#include "penumbra/bsdf.h"
#include "penumbra/caustic_photons.h"
#include "penumbra/caustics.h"
#include "penumbra/guiding.h"
#include "penumbra/hair_bsdf.h"
#include "penumbra/light_images.h"
#include "penumbra/phase.h"
#include "penumbra/random_stream.h"
#include "penumbra/ray_log.h"
#include "penumbra/sampler.h"
#include "penumbra/spectrum.h"
#include "penumbra/subsurface.h"
#include "penumbra/surface_hit.h"
#include "penumbra/warp.h"
#include "volume_transport.h"

namespace penumbra {
namespace {

/// How the ray being traced was produced, for weighting the emission it finds.
struct ScatteringRecord {
  float pdf = 0;  // solid-angle density of a non-delta BSDF sample; 0: no MIS
  bool fromSurface = false;
  /// Per channel, the share of the BSDF's value in the ray's direction that its diffuse lobe
  /// holds: what a light's diffuse multiplier scales (the specular one, the rest).
  Vec3f diffuseShare{0.0f};
  Receiver receiver;          // the surface it left, as next-event estimation saw it there
  uint32_t linkingClass = 0;  // the surface's placement's (linking.h): the lights it receives
  /// The share of its MIS weight next-event estimation kept for the constant domes at the
  /// surface it left (IntegratorSettings::firstSurfaceConstantDomeShare): this ray takes the rest.
  float constantDomeShare = 1;
  /// The light estimates made at the surface it left (IntegratorSettings::lightSamples): MIS
  /// weighs that many light samples against this ray (the power heuristic with sample counts).
  float lightEstimates = 1;
};

/// `part` over `whole`, channel by channel (0 where `whole` is not positive).
Vec3f shareOf(const Vec3f& part, const Vec3f& whole) {
  const auto share = [](float p, float w) { return w > 0 ? p / w : 0.0f; };
  return {share(part.x, whole.x), share(part.y, whole.y), share(part.z, whole.z)};
}

/// What light `light`'s diffuse and specular multipliers make of the light `origin`'s ray
/// brings back from it: camera rays see lights as they are.
Vec3f lobeMultiplier(const Light& light, const ScatteringRecord& origin) {
  if (!origin.fromSurface) return Vec3f(1.0f);
  const float diffuse = light.diffuseMultiplier(), specular = light.specularMultiplier();
  if (diffuse == specular) return Vec3f(diffuse);
  return origin.diffuseShare * diffuse + (Vec3f(1.0f) - origin.diffuseShare) * specular;
}

/// Whether light `index` lights what `origin`'s ray left (light linking). Camera rays see every
/// light; a surface or medium excluded from a light's light link gets nothing from it, by light
/// sampling or BSDF (phase) sampling alike, so the two strategies stay consistent.
bool lightReaches(const Scene& scene, const ScatteringRecord& origin, size_t index) {
  return !origin.fromSurface || !scene.geometry().linking().lightExcluded(
                                    origin.linkingClass, scene.lights().all()[index].linkSlot());
}

/// Whether light `index`'s shadow link leaves something out. Its shadow rays pass through what
/// BSDF rays stop at: where next-event estimation can draw its light, it takes all of it.
bool passesExcludedShadows(const Scene& scene, size_t index) {
  return scene.geometry().linking().shadowLinked(scene.lights().all()[index].linkSlot());
}

/// MIS weight of a BSDF-sampled ray that met light `index` (`lightPdf`: the density of sampling
/// that point of the light once chosen).
float bsdfStrategyWeight(const Scene& scene, const ScatteringRecord& origin, size_t index,
                         float lightPdf, DirectLighting mode) {
  if (origin.pdf <= 0) return 1;  // camera rays and delta lobes: light sampling cannot find these
  if (mode == DirectLighting::MultipleImportance && passesExcludedShadows(scene, index))
    mode = DirectLighting::LightSamplingOnly;
  switch (mode) {
    case DirectLighting::MultipleImportance:
      return powerHeuristic(
          origin.pdf,
          origin.lightEstimates *
              (scene.lights().lightSampler().probability(origin.receiver, index) * lightPdf));
    case DirectLighting::LightSamplingOnly:
      return scene.lights().lightSampler().probability(origin.receiver, index) * lightPdf > 0
                 ? 0.0f
                 : 1.0f;
    case DirectLighting::BsdfSamplingOnly:
      return 1;
  }
  return 1;
}

/// A camera sample, for knowing which lights it integrates over their image
/// (lightsSeenDirectly): its camera ray passes those.
struct CameraSampleView {
  const LightImages* images = nullptr;  // none: it integrates none
  int x = 0, y = 0;
  Vec2f lensSample;
  float time = 0;

  bool integrates(uint32_t index) const {
    return images && images->integratesAt(index, x, y, concentricSampleDisk(lensSample), time);
  }
};

/// Emission from the lights a ray meets before `tMax` (area lights) or, if it escapes, from the
/// infinite ones, weighted against the BSDF sampling that produced it.
/// Camera rays find the emission of the lights that `cameraSample` integrates over their image
/// all the same (for depth and alpha) but do not add it. Where the origin gave the constant
/// domes a share of 0 and `domeSamplingShift` is given, what a share of 1 would have taken from
/// this ray's light is subtracted there. Of the lights the light tracer takes, on a path it
/// takes (`leftToLightTracing`), nothing is added, or the share `kept` past an AboveDiffuse
/// caster.
struct LeftToLightTracing {
  const CausticTakeover& takeover;
  bool pastAboveDiffuse;
  Vec3f kept;
};
Vec3f emittedAlongRay(const Scene& scene, const Ray& ray, float tMax, bool escaped,
                      const ScatteringRecord& origin, DirectLighting mode,
                      const PathSpectrum& spectrum, const CameraSampleView& cameraSample,
                      float* nearestLight, bool* sawLight, Vec3f* domeSamplingShift,
                      const LeftToLightTracing* leftToLightTracing) {
  const std::vector<Light>& lights = scene.lights().all();
  Vec3f total{0.0f};
  float nearest = kInfinity;
  const auto add = [&](uint32_t index, const LightHit& hit) {
    const Light& light = lights[index];
    if (!origin.fromSurface && !light.cameraVisible()) return;
    if (!lightReaches(scene, origin, index)) return;
    // Light surfaces may overlap; each contributes, and the nearest defines depth. A visible
    // light (the dome too) makes the pixel opaque.
    nearest = std::min(nearest, hit.distance);
    *sawLight = true;
    if (!origin.fromSurface && cameraSample.integrates(index)) return;
    const bool taken = leftToLightTracing && leftToLightTracing->takeover.takesLightPast(
                                                 index, leftToLightTracing->pastAboveDiffuse);
    if (taken && !leftToLightTracing->pastAboveDiffuse) return;
    const float weight = bsdfStrategyWeight(scene, origin, index, hit.pdf, mode);
    const Vec3f multiplier = lobeMultiplier(light, origin);
    if (origin.constantDomeShare < 1 && light.isConstantDome() &&
        !passesExcludedShadows(scene, index)) {
      const Vec3f emitted = spectrum.emission(hit.radiance) * multiplier;
      total += emitted * (1 - origin.constantDomeShare * (1 - weight));
      if (domeSamplingShift) *domeSamplingShift += emitted * (weight - 1);
      return;
    }
    const Vec3f emitted = spectrum.emission(hit.radiance) * (multiplier * weight);
    total += taken ? emitted * leftToLightTracing->kept : emitted;
  };
  scene.lights().forEachLightHit(ray, tMax, add);
  if (escaped)
    for (const uint32_t index : scene.lights().infiniteLights())
      if (const std::optional<LightHit> hit =
              lights[index].escaped(ray.direction, origin.receiver.normal))
        add(index, *hit);
  *nearestLight = nearest;
  return total;
}

/// Light reaching the camera by way of at least two surface interactions, limited (when `clamp`
/// is positive) to that maximum component as Cycles' indirect clamp does: a biased way to cut
/// fireflies.
Vec3f clampIndirect(const Vec3f& contribution, int interactions, float clamp) {
  if (clamp <= 0 || interactions < 2) return contribution;
  const float largest = maxComponent(contribution);
  return largest > clamp ? contribution * (clamp / largest) : contribution;
}

/// The GGX α below which the glossy filter (IntegratorSettings::glossyFilter) does not let lobes
/// go, after bounces whose smallest direction density was `minRayPdf`; 0 where it does not act.
float filteredAlpha(float glossyFilter, float minRayPdf) {
  const float blurPdf = glossyFilter * minRayPdf;
  return glossyFilter > 0 && blurPdf < 1 ? 0.5f * std::sqrt(1 - blurPdf) : 0.0f;
}

/// A hair material's fibre BSDF: σa is derived first (hairAbsorptionAt: a colour is converted
/// with β_n as authored, as MaterialX's node converts it with its own), then the glossy filter
/// raises β_m and β_n as it raises roughness; in spectral scenes the tints are upsampled as
/// reflectances and σa through the transmittance e^(−σa) of one unit of length, which lies in
/// [0, 1] like a reflectance.
HairBsdf makeHairBsdf(const SurfaceHit& hit, const PathSpectrum& spectrum, float minAlpha) {
  MaterialParams material = hit.material();
  material.hairAbsorption = hairAbsorptionAt(material);
  if (minAlpha > 0) {
    const float minRoughness = std::sqrt(minAlpha);
    material.hairLongitudinalRoughness = std::max(material.hairLongitudinalRoughness, minRoughness);
    material.hairAzimuthalRoughness = std::max(material.hairAzimuthalRoughness, minRoughness);
  }
  if (spectrum.spectral) {
    for (Vec3f* tint : {&material.hairTintR, &material.hairTintTT, &material.hairTintTRT})
      *tint = spectrum.reflectance(*tint);
    const Vec3f& a = material.hairAbsorption;
    const Vec3f transmittance =
        spectrum.reflectance({std::exp(-a.x), std::exp(-a.y), std::exp(-a.z)});
    const auto absorption = [](float t) { return -std::log(std::max(t, 1e-30f)); };
    material.hairAbsorption = {absorption(transmittance.x), absorption(transmittance.y),
                               absorption(transmittance.z)};
  }
  return HairBsdf(material, hit.fibreDirection, hit.normal, hit.shadingNormal);
}

/// The scattering function at a hit: the UsdPreviewSurface BSDF, or a hair material's fibre BSDF.
class SurfaceBsdf {
 public:
  explicit SurfaceBsdf(HairBsdf bsdf) : bsdf_(std::move(bsdf)) {}
  /// Constructs the BSDF in place from `arguments` (a BSDF is some 250 bytes: no copy of it).
  template <class Bsdf, class... Arguments>
  explicit SurfaceBsdf(std::in_place_type_t<Bsdf> type, Arguments&&... arguments)
      : bsdf_(type, std::forward<Arguments>(arguments)...) {}

  Vec3f evaluate(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart) const {
    return std::visit([&](const auto& b) { return b.evaluate(wo, wi, diffusePart); }, bsdf_);
  }
  float pdf(const Vec3f& wo, const Vec3f& wi) const {
    return std::visit([&](const auto& b) { return b.pdf(wo, wi); }, bsdf_);
  }
  /// evaluate() and pdf() at once (the UsdPreviewSurface BSDF shares their work).
  BsdfEvaluation evaluateWithPdf(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart) const {
    return std::visit(
        [&](const auto& b) {
          if constexpr (std::is_same_v<std::decay_t<decltype(b)>, PreviewSurfaceBsdf>)
            return b.evaluateWithPdf(wo, wi, diffusePart);
          else
            return BsdfEvaluation{b.evaluate(wo, wi, diffusePart), b.pdf(wo, wi)};
        },
        bsdf_);
  }
  std::optional<BsdfSample> sample(const Vec3f& wo, float uLobe, Vec2f u) const {
    return std::visit([&](const auto& b) { return b.sample(wo, uLobe, u); }, bsdf_);
  }
  bool isPurelySpecular() const {
    return std::visit([](const auto& b) { return b.isPurelySpecular(); }, bsdf_);
  }
  bool hasTransmission() const {
    return std::visit([](const auto& b) { return b.hasTransmission(); }, bsdf_);
  }
  /// PreviewSurfaceBsdf::disperse; hair does not disperse.
  bool disperse(const Vec3f& wo, const Vec3f& channelIors, float choiceIor) {
    PreviewSurfaceBsdf* preview = std::get_if<PreviewSurfaceBsdf>(&bsdf_);
    return preview && preview->disperse(wo, channelIors, choiceIor);
  }

 private:
  std::variant<PreviewSurfaceBsdf, HairBsdf> bsdf_;
};

/// Whether a lobe `material` has is narrower than the glossy filter lets it be. The roughness of
/// a lobe it lacks (a coat of weight 0; transmission where it is opaque) changes nothing it
/// scatters: such a material keeps its prototype (the BSDF set up once). UsdPreviewSurface's
/// clearcoatRoughness defaults to 0.01, so otherwise every material would be set up anew at
/// every vertex the filter acts on.
bool raisesRoughness(const MaterialParams& material, float minRoughness) {
  if (!(minRoughness > 0)) return false;
  const bool coated = material.clearcoat > 0, translucent = !(material.opacity >= 1);
  return material.roughness < minRoughness ||
         (coated && material.clearcoatRoughness < minRoughness) ||
         (translucent && material.transmissionRoughness >= 0 &&
          material.transmissionRoughness < minRoughness);
}

/// The UsdPreviewSurface BSDF of a hit's material.
SurfaceBsdf makePreviewSurfaceBsdf(const SurfaceHit& hit, const MaterialTable& materials,
                                   const PathSpectrum& spectrum, float ior, float minAlpha) {
  constexpr std::in_place_type_t<PreviewSurfaceBsdf> kPreviewSurface;
  // Open meshes cannot hold a medium: their translucency is a thin sheet (DielectricKind).
  const DielectricKind dielectricKind =
      hit.closed ? DielectricKind::Solid : DielectricKind::ThinSheet;
  const MaterialParams& authored = hit.material();
  const float minRoughness = minAlpha > 0 ? std::sqrt(minAlpha) : 0.0f;
  if (!spectrum.spectral) {
    // The material is taken as it is, never copied, and where it does not vary and the glossy
    // filter leaves it as it is, not even set up (set up once; ior is its own where paths are
    // not spectral).
    if (!raisesRoughness(authored, minRoughness))
      if (const PreviewSurfaceBsdf* prototype =
              materials.bsdfPrototype(hit.materialIndex, dielectricKind))
        return SurfaceBsdf(kPreviewSurface, *prototype, hit.shadingNormal);
    return SurfaceBsdf(kPreviewSurface, authored, hit.shadingNormal, ior, dielectricKind,
                       hit.tangent, minRoughness);
  }
  return SurfaceBsdf(kPreviewSurface, spectrum.surfaceColours(authored), hit.shadingNormal, ior,
                     dielectricKind, hit.tangent, minRoughness);
}

/// `ior`: the material's, or its value at the hero wavelength under dispersion; `minAlpha`: the
/// glossy filter's (filteredAlpha).
SurfaceBsdf makeBsdf(const SurfaceHit& hit, const MaterialTable& materials,
                     const PathSpectrum& spectrum, float ior, float minAlpha) {
  if (hit.material().hair) return SurfaceBsdf(makeHairBsdf(hit, spectrum, minAlpha));
  return makePreviewSurfaceBsdf(hit, materials, spectrum, ior, minAlpha);
}

/// Whether paths may be guided at a surface (and train the guide there): opaque, rough, not
/// hair and without subsurface scattering, so that every direction the guide draws is one of
/// the BSDF's reflection lobes.
bool guidable(const SurfaceHit& hit, const SurfaceBsdf& bsdf) {
  return !hit.material().hair && hit.material().subsurface <= 0 && !bsdf.hasTransmission() &&
         !bsdf.isPurelySpecular();
}

/// A surface's BSDF beside the guiding field's distribution at its vertex (one-sample MIS: a
/// direction comes from the field with the cell's guide probability, else from the BSDF, and
/// is weighted by the mixture of the two densities). Without a distribution it is the BSDF.
class GuidedBsdf {
 public:
  GuidedBsdf(const SurfaceBsdf& bsdf, const DirectionalDistribution* guide)
      : bsdf_(bsdf), guide_(guide), probability_(guide ? guide->guideProbability() : 0.0f) {}

  Vec3f evaluate(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart) const {
    return bsdf_.evaluate(wo, wi, diffusePart);
  }
  BsdfEvaluation evaluateWithPdf(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart) const {
    BsdfEvaluation evaluation = bsdf_.evaluateWithPdf(wo, wi, diffusePart);
    if (guide_) evaluation.pdf = mixedPdf(guide_->pdf(wi), evaluation.pdf);
    return evaluation;
  }
  /// `uChoice` picks the strategy (and, rescaled, the BSDF's lobe or the guide's leaf).
  std::optional<BsdfSample> sample(const Vec3f& wo, float uChoice, Vec2f u) const {
    if (!guide_) return bsdf_.sample(wo, uChoice, u);
    if (uChoice < probability_) {
      BsdfSample sample;
      float guidePdf = 0;
      sample.direction = guide_->sample(uChoice / probability_, u, &guidePdf);
      Vec3f diffusePart;
      const Vec3f f = bsdf_.evaluate(wo, sample.direction, &diffusePart);
      if (isBlack(f)) return std::nullopt;
      sample.pdf = mixedPdf(guidePdf, bsdf_.pdf(wo, sample.direction));
      if (!(sample.pdf > 0)) return std::nullopt;
      sample.weight = f / sample.pdf;
      // Which lobe the direction counts for (depth caps, ray visibility, light multipliers).
      sample.lobe =
          luminance(diffusePart) >= 0.5f * luminance(f) ? BsdfLobe::Diffuse : BsdfLobe::Glossy;
      return sample;
    }
    std::optional<BsdfSample> sample = bsdf_.sample(
        wo, std::min((uChoice - probability_) / (1 - probability_), 0x1.fffffep-1f), u);
    if (!sample) return sample;
    if (sample->isDelta) {
      sample->weight = sample->weight / (1 - probability_);
      sample->pdf *= 1 - probability_;
    } else {
      // The BSDF's weight is f / its pdf: rescaled to f / the mixture's.
      const float pdf = mixedPdf(guide_->pdf(sample->direction), sample->pdf);
      sample->weight = sample->weight * (sample->pdf / pdf);
      sample->pdf = pdf;
    }
    return sample;
  }

 private:
  float mixedPdf(float guidePdf, float bsdfPdf) const {
    return probability_ * guidePdf + (1 - probability_) * bsdfPdf;
  }

  const SurfaceBsdf& bsdf_;
  const DirectionalDistribution* guide_;
  float probability_;  // of drawing from guide_
};

/// The vertices of a training path that the guide learns from: the direction each left in,
/// its density, the path's throughput after it, and the light found beyond it.
class GuidingTrainer {
 public:
  static constexpr int kMaxVertices = 16;

  /// `scattered`: the BSDF's sample there; `throughput`: the path's after it.
  void addVertex(const Vec3f& position, const Vec3f& normal, const BsdfSample& scattered,
                 const Vec3f& throughput, int bounce) {
    if (count_ == kMaxVertices) return;
    vertices_[size_t(count_++)] = {position,
                                   orientationOf(normal),
                                   scattered.direction,
                                   std::max(dot(normal, scattered.direction), 0.0f) / scattered.pdf,
                                   scattered.pdf,
                                   scattered.weight,
                                   throughput,
                                   Vec3f(0.0f),
                                   bounce};
  }
  /// Light reaching the camera by way of every vertex so far.
  void addLight(const Vec3f& light) {
    for (int i = 0; i < count_; ++i) vertices_[size_t(i)].light += light;
  }
  /// Hands the vertices to `recorder` as records of sample `sampleIndex` of pixel (x, y).
  void record(GuidingRecorder& recorder, int x, int y, uint32_t sampleIndex) const {
    if (count_ == 0) return;
    std::array<GuidingRecord, kMaxVertices> records;
    for (int i = 0; i < count_; ++i) {
      const Vertex& v = vertices_[size_t(i)];
      // The radiance that arrived along the vertex's direction: what reached the camera over
      // the throughput that carried it there.
      const auto arrived = [](float light, float throughput) {
        return throughput > 0 ? light / throughput : 0.0f;
      };
      const Vec3f incident{arrived(v.light.x, v.throughput.x), arrived(v.light.y, v.throughput.y),
                           arrived(v.light.z, v.throughput.z)};
      GuidingRecord& r = records[size_t(i)];
      r.position = v.position;
      r.orientation = v.orientation;
      r.direction = directionToSquare(v.direction);
      r.flux = std::max(luminance(incident), 0.0f) * v.cosineOverPdf;
      r.sampledPdf = v.pdf;
      r.estimate = std::max(luminance(incident * v.weight), 0.0f);
      r.key = GuidingRecord::makeKey(uint32_t(x), uint32_t(y), sampleIndex, uint32_t(v.bounce));
    }
    recorder.add(records.data(), size_t(count_));
  }

 private:
  struct Vertex {
    Vec3f position;
    uint32_t orientation;
    Vec3f direction;
    float cosineOverPdf;  // |cos θ| over the direction's density
    float pdf;
    Vec3f weight;  // the BSDF sample's f·|cos θ| / pdf
    Vec3f throughput, light;
    int bounce;
  };
  std::array<Vertex, kMaxVertices> vertices_;
  int count_ = 0;
};

/// The white Lambertian lobe through which light leaves a solid at the end of a subsurface
/// random walk (the walk's throughput carries the colour): f·cos = cos θ/π on the outside,
/// whatever wo (it takes wo only to be evaluated as the BSDFs are).
class LambertianExit {
 public:
  explicit LambertianExit(const Vec3f& outward) : frame_(outward) {}

  Vec3f evaluate(const Vec3f&, const Vec3f& wi, Vec3f* diffusePart) const {
    const Vec3f f(std::max(dot(wi, frame_.n), 0.0f) * kInvPi);
    *diffusePart = f;
    return f;
  }
  float pdf(const Vec3f&, const Vec3f& wi) const {
    return std::max(dot(wi, frame_.n), 0.0f) * kInvPi;
  }
  BsdfEvaluation evaluateWithPdf(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart) const {
    return {evaluate(wo, wi, diffusePart), pdf(wo, wi)};
  }
  BsdfSample sample(Vec2f u) const {
    const Vec3f local = sampleCosineHemisphere(u);
    BsdfSample result;
    result.direction = frame_.toWorld(local);
    result.weight = Vec3f(1.0f);
    result.pdf = cosineHemispherePdf(local.z);
    return result;
  }

 private:
  Frame frame_;
};

/// What next-event estimation needs of a path vertex: f·|cos| towards a light (with its diffuse
/// part, which lights scale by their diffuse multiplier), the density of the vertex's own
/// sampling of that direction (found with f: evaluateWithPdf), and the shadow ray towards it.
template <class Scatter>
struct SurfaceVertex {
  const Scene& scene;
  const SurfaceHit& hit;
  const Scatter& bsdf;
  Vec3f wo;
  float time;

  Vec3f evaluate(const Vec3f& wi, Vec3f* diffusePart) const {
    return bsdf.evaluate(wo, wi, diffusePart);
  }
  BsdfEvaluation evaluateWithPdf(const Vec3f& wi, Vec3f* diffusePart) const {
    return bsdf.evaluateWithPdf(wo, wi, diffusePart);
  }
  Ray shadowRay(const Vec3f& wi, float tFar) const { return spawnRay(scene, hit, wi, tFar, time); }
};

template <class Scatter>
SurfaceVertex<Scatter> surfaceVertex(const Scene& scene, const SurfaceHit& hit, const Scatter& bsdf,
                                     const Vec3f& wo, float time) {
  return {scene, hit, bsdf, wo, time};
}

/// A scattering event in a medium: the phase function in the BSDF's place, all of it diffuse.
struct MediumVertex {
  HenyeyGreenstein phase;
  Vec3f incoming;  // the direction the ray travelled
  Vec3f position;
  float time;

  Vec3f evaluate(const Vec3f& wi, Vec3f* diffusePart) const {
    *diffusePart = Vec3f(phase.evaluate(incoming, wi));
    return *diffusePart;
  }
  float pdf(const Vec3f& wi) const { return phase.evaluate(incoming, wi); }
  BsdfEvaluation evaluateWithPdf(const Vec3f& wi, Vec3f* diffusePart) const {
    return {evaluate(wi, diffusePart), pdf(wi)};
  }
  Ray shadowRay(const Vec3f& wi, float tFar) const {
    Ray shadow;
    shadow.origin = position;
    shadow.direction = wi;
    shadow.tFar = tFar;
    shadow.time = time;
    return shadow;
  }
};

/// The subsurface medium of a hit's material, at the path's wavelengths when it carries a
/// spectrum (the colour upsampled as a reflectance, the radius as an unbounded spectrum).
SubsurfaceMedium subsurfaceMediumAt(const SurfaceHit& hit, const PathSpectrum& spectrum) {
  if (!spectrum.spectral) return subsurfaceMedium(hit.material());
  MaterialParams material = hit.material();
  material.subsurfaceColor = spectrum.reflectance(material.subsurfaceColor);
  material.subsurfaceRadius =
      RgbSpectrum::unbounded(material.subsurfaceRadius).at(spectrum.wavelengths.lambda);
  return subsurfaceMedium(material);
}

/// σa inside absorbing glass, at the path's wavelengths when it carries a spectrum.
Vec3f glassAbsorptionAt(const SurfaceHit& hit, const PathSpectrum& spectrum) {
  if (!spectrum.spectral) return transmissionAbsorption(hit.material());
  MaterialParams material = hit.material();
  material.transmissionColor = spectrum.reflectance(material.transmissionColor);
  return transmissionAbsorption(material);
}

/// Inside absorbing glass (a solid whose surface `hit` a ray along `direction` meets from
/// within): the Beer–Lambert transmittance of the ray's way there; 1 elsewhere.
Vec3f glassTransmittance(const SurfaceHit& hit, const Vec3f& direction,
                         const PathSpectrum& spectrum) {
  if (!hit.closed || !(hit.material().transmissionDepth > 0) || !(dot(direction, hit.normal) > 0))
    return Vec3f(1.0f);
  const Vec3f absorption = glassAbsorptionAt(hit, spectrum) * hit.distance;
  return {std::exp(-absorption.x), std::exp(-absorption.y), std::exp(-absorption.z)};
}

/// The sampler dimensions of lightsSeenDirectly's draws, one per light: far above any path's,
/// so that they are not correlated with the path's draws.
constexpr uint32_t kLightImageDimensions = 0x80000000u;
/// The purpose of the random stream of their rays' transmittance (RandomStream): neither the
/// volumes' along the path (0) nor a subsurface walk's (1 + its vertex).
constexpr uint32_t kLightImageStream = 0xffffffffu;

/// The emission that pixel (x, y)'s camera sample (lens sample `lensSample`, shutter time
/// `time`) sees directly of the lights `images` integrates over their image (light_images.h).
/// For each light near the pixel: a filter offset drawn as the camera ray's are but only within
/// the box around the light's image as the sample's lens point sees it (for a sphere, disk or
/// rect light, in a row that crosses its image and within the image's span of that row), and
/// the emission the camera ray through it sees there, weighted by the share of the filter in
/// that box (or in those rows and that span). Adds the rays it traces to `rays`.
Vec3f lightsSeenDirectly(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                         const LightImages& images, const SampleStream& sampler, int x, int y,
                         uint32_t sampleIndex, uint32_t seed, Vec2f lensSample, float time,
                         const PathSpectrum& spectrum, uint32_t* rays) {
  const auto [begin, end] = images.near(x, y);
  Vec3f total{0.0f};
  if (begin == end) return total;
  const Vec2f lens = concentricSampleDisk(lensSample);
  const std::optional<Camera::Moment> moment = images.momentAt(time);
  const Vec2f centre{float(x) + 0.5f, float(y) + 0.5f};
  const ImageBox filterReach = ImageBox{centre, centre}.widened(filter.radius());
  const std::vector<Light>& lights = scene.lights().all();
  std::optional<RandomStream> volumeRandom;
  // The camera's rays at the sample's lens point and moment (a perspective camera's: lights
  // have an outline only there), made for the first light with one.
  std::optional<Camera::RayFamily> family;
  for (const uint32_t* position = begin; position != end; ++position) {
    const LightImages::Integrated& image = images.integrated()[*position];
    const std::optional<ImageBox> box = images.integratedBox(image, centre, lens, moment);
    if (!box) continue;
    const ImageBox region = box->intersected(filterReach);
    if (region.empty()) continue;
    const Vec2f lower{region.lower.x - centre.x, region.lower.y - centre.y};
    const Vec2f upper{region.upper.x - centre.x, region.upper.y - centre.y};
    const Vec2f u = sampler.draw2D(kLightImageDimensions + image.lightIndex);
    if (image.outline && !family) family = camera.rayFamily(lensSample, time);
    PixelFilter::OffsetWithin drawn;
    if (image.outline && family) {
      // The offset is drawn in a row that crosses the light's image within the region, then in
      // the image's span of that row, so that every draw sees the light (unless something hides
      // it), not only those that happen to land on it.
      const OutlineImage outlineImage(*family, *image.outline, centre, image.margin);
      const std::optional<OutlineImage::Span> rows = outlineImage.rowsWithin(lower.x, upper.x);
      if (!rows) continue;
      const PixelFilter::CoordinateWithin drawnY =
          filter.sampleCoordinateWithin(float(std::max(double(lower.y), rows->first)),
                                        float(std::min(double(upper.y), rows->second)), u.y);
      const std::optional<OutlineImage::Span> span = outlineImage.row(drawnY.offset);
      if (!span) continue;
      const PixelFilter::CoordinateWithin drawnX =
          filter.sampleCoordinateWithin(float(std::max(double(lower.x), span->first)),
                                        float(std::min(double(upper.x), span->second)), u.x);
      drawn = {{drawnX.offset, drawnY.offset}, drawnX.share * drawnY.share};
    } else {
      drawn = filter.sampleOffsetWithin(lower, upper, u);
    }
    if (!(drawn.share > 0)) continue;
    const Ray ray =
        camera.generateRay(centre.x + drawn.offset.x, centre.y + drawn.offset.y, lensSample, time);
    const std::optional<LightHit> hit =
        lights[image.lightIndex].intersect(ray.origin, ray.direction, ray.tFar);
    if (!hit) continue;
    ++*rays;
    // What the camera ray would count: the light in front of the first surface it sees, dimmed
    // as the camera ray is inside absorbing glass.
    const std::optional<SurfaceHit> surface =
        intersectSurface(scene, ray, RayKind::Camera, camera.pixelCone());
    if (surface && surface->distance < hit->distance) continue;
    Vec3f transmittance =
        surface ? glassTransmittance(*surface, ray.direction, spectrum) : Vec3f(1.0f);
    if (!scene.volumes().empty()) {
      if (!volumeRandom)
        volumeRandom.emplace(seed, uint32_t(x), uint32_t(y), sampleIndex, kLightImageStream);
      const MediumSpectrum mediumSpectrum{spectrum.spectral ? &spectrum.wavelengths : nullptr};
      transmittance *= estimateTransmittance(scene.volumes(), ray, hit->distance, mediumSpectrum,
                                             *volumeRandom, scene.geometry().linking(), -1);
    }
    total += spectrum.emission(hit->radiance) * transmittance * drawn.share;
  }
  return total;
}

/// Records what the camera ray `ray` met first: a surface (`hit`), or only a light at
/// `firstHitDistance` (infinity: nothing).
void recordFirstHit(const Camera& camera, const Ray& ray, const SurfaceHit* hit,
                    float firstHitDistance, FirstHitSample* record) {
  if (firstHitDistance < kInfinity) {
    record->distance =
        length(ray.origin + ray.direction * firstHitDistance - camera.centre(ray.time));
    record->z = camera.viewDepth(ray, firstHitDistance);
  }
  if (!hit) return;
  record->hit = true;
  record->position = hit->position;
  record->normal = hit->shadingNormal;
  record->cameraNormal = camera.toCameraSpace(hit->shadingNormal, ray.time);
  record->albedo = surfaceAlbedo(hit->material());
  record->primId = int(hit->meshId);
  record->instanceId = hit->instance;
  record->elementId = hit->shape->elementOf(hit->primitive);
  record->faceSlot = hit->faceSlot;
  record->shape = hit->shape;
  record->primitive = hit->primitive;
  record->u = hit->u;
  record->v = hit->v;
  record->instancePrimvars = hit->instancePrimvars;
}

/// Where a camera ray first meets a smooth dispersive solid, each of its paths goes on as this
/// many copies, copy k refracting with wavelength k as its hero: refraction there keeps one
/// wavelength, and a lone hero would leave the colours of what is seen through the solid to
/// chance from sample to sample (coloured speckles).
constexpr int kWavelengthCopies = 3;

/// `v` with channel k first: the channels of the path's wavelengths as copy k orders them.
Vec3f heroFirst(const Vec3f& v, int k) {
  return k == 0 ? v : k == 1 ? Vec3f(v.y, v.z, v.x) : Vec3f(v.z, v.x, v.y);
}

/// What a path carries from vertex to vertex. Copied where it branches at its first surface
/// (IntegratorSettings::indirectSamples): each branch then goes on with random numbers of its own.
struct PathState {
  explicit PathState(const SampleStream& stream) : sampler(stream) {}

  SampleStream sampler;
  /// Added to the purposes of the path's random streams (volumes, subsurface walks): a branch's
  /// differ from every other branch's and from an unbranched path's.
  uint32_t streamPurposeOffset = 0;
  /// Which of its camera sample's paths this is: copy pathIndex % copies of branch
  /// pathIndex / copies (0 where the sample does not branch).
  int pathIndex = 0;
  PathSpectrum spectrum;
  Ray ray;
  RayCone cone;
  Vec3f throughput{1.0f};
  ScatteringRecord scattering;
  int diffuseBounces = 0, glossyBounces = 0, transmissionBounces = 0, volumeBounces = 0;
  RayKind rayKind = RayKind::Camera;  // which objects the ray may see (PassVisibility)
  bool lastVertex = false;      // a lobe's depth is exhausted: only collect what the ray reaches
  float minRayPdf = kInfinity;  // the smallest density of a scattered direction so far
  // Volumes: their decisions take as many random numbers as the medium asks, from a stream of
  // their own so that the sampler's dimensions stay aligned with the path's vertices.
  std::optional<RandomStream> volumeRandom;
  /// What a path that waits its turn found as it left the first surface (the exit of a
  /// subsurface walk is lit there), added to what it finds when it goes on.
  Vec3f radianceBeforeWaiting{0.0f};
  /// Casters met since a first surface that receives caustics (IntegratorSettings::caustics),
  /// or since the first receiving surface the camera sees through casters alone where photons
  /// are gathered (kThroughCasters until then); -1 once anything else was met, or where that
  /// surface does not receive them.
  int castersSinceFirstSurface = -1;
  /// The most casters on the paths from that surface whose lights' light the light tracer adds:
  /// those no depth limit cuts from there.
  int castersTaken = 0;
  /// The last of them is an AboveDiffuse caster (CasterKind), the last such a path may have.
  bool pastAboveDiffuse = false;
  /// There, the share of the light along the ray it scattered that the path tracer keeps: the
  /// diffuse layer's part of the BSDF's value, per channel.
  Vec3f keptAboveDiffuse{0.0f};

  /// castersSinceFirstSurface while the camera's path has met casters alone.
  static constexpr int kThroughCasters = -2;

  /// Turns the path at its first surface into branch `index` of `branches` of camera sample
  /// `sampleIndex`: its dimensions from here on take sample index sampleIndex · branches +
  /// index, so that a pixel's branches together are as well stratified as its camera samples.
  void branchOff(int index, int branches, uint32_t seed, int x, int y, uint32_t sampleIndex) {
    sampler = sampler.atSample(sampleIndex * uint32_t(branches) + uint32_t(index));
    streamPurposeOffset = uint32_t(index + 1) << 24;  // above every vertex's purpose
    if (volumeRandom)
      volumeRandom.emplace(seed, uint32_t(x), uint32_t(y), sampleIndex, streamPurposeOffset);
  }
};

}  // namespace

CameraSample renderCameraSample(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                                int x, int y, uint32_t sampleIndex,
                                const IntegratorSettings& settings,
                                FirstHitSample* firstHitRecord) {
  PathState path(SampleStream(settings.seed, uint32_t(x), uint32_t(y), sampleIndex));
  // The loop below reads and writes the path through these names; a branch that waits its turn
  // (fewer than kMaxIndirectSamples · kWavelengthCopies) is copied into `path` when it begins.
  SampleStream& sampler = path.sampler;
  PathSpectrum& spectrum = path.spectrum;
  Ray& ray = path.ray;
  RayCone& cone = path.cone;
  Vec3f& throughput = path.throughput;
  ScatteringRecord& scattering = path.scattering;
  int &diffuseBounces = path.diffuseBounces, &glossyBounces = path.glossyBounces,
      &transmissionBounces = path.transmissionBounces, &volumeBounces = path.volumeBounces;
  RayKind& rayKind = path.rayKind;
  bool& lastVertex = path.lastVertex;
  float& minRayPdf = path.minRayPdf;
  std::optional<RandomStream>& volumeRandom = path.volumeRandom;
  // Where on the pixel and where on the lens are stratified jointly: with depth of field, each
  // pixel sees the scene through the whole lens. So are shutter time and wavelength.
  const Sample4D pixelAndLens = sampler.next4D();
  const Vec2f filterOffset = filter.sampleOffset({pixelAndLens.x, pixelAndLens.y});
  const Vec2f lensSample{pixelAndLens.z, pixelAndLens.w};
  const Vec2f timeAndWavelength = sampler.next2D();
  const float shutterTime = timeAndWavelength.x;
  if (scene.materials().spectral()) {
    spectrum.spectral = true;
    spectrum.wavelengths = sampleWavelengths(timeAndWavelength.y);
  }
  ray = camera.generateRay(float(x) + 0.5f + filterOffset.x, float(y) + 0.5f + filterOffset.y,
                           lensSample, shutterTime);

  CameraSample result;
  const CameraSampleView cameraSample{settings.lightImages, x, y, lensSample, shutterTime};
  if (settings.lightImages)
    result.radiance =
        lightsSeenDirectly(scene, camera, filter, *settings.lightImages, sampler, x, y, sampleIndex,
                           settings.seed, lensSample, shutterTime, spectrum, &result.rays);
  const bool training = settings.guidingRecorder != nullptr;
  // The trainer follows one path: the camera sample's own, or its first branch where it
  // branches (an unbranched path of its own random numbers).
  GuidingTrainer trainer;
  // Every light the sample gathers goes through here, so that training sees it too.
  const auto addLight = [&](const Vec3f& light) {
    result.radiance += light;
    if (training && path.pathIndex == 0) trainer.addLight(light);
  };
  cone = camera.pixelCone();
  const std::vector<Light>& lights = scene.lights().all();
  // Whether the path is one whose light from the lights taken the light tracer adds.
  const auto causticPath = [&] {
    return settings.caustics && path.castersSinceFirstSurface >= 1 &&
           path.castersSinceFirstSurface <= path.castersTaken;
  };
  const bool hasVolumes = !scene.volumes().empty();
  if (hasVolumes) volumeRandom.emplace(settings.seed, uint32_t(x), uint32_t(y), sampleIndex, 0);
  const MediumSpectrum mediumSpectrum{spectrum.spectral ? &spectrum.wavelengths : nullptr};
  // Branching at the first surface.
  const int branches = std::clamp(
      settings.regionBranches ? settings.regionBranches->at(x, y) : settings.indirectSamples, 1,
      kMaxIndirectSamples);
  std::vector<PathState> waitingBranches;  // empty unless the path branches: no allocation
  const int lightEstimates = std::clamp(settings.lightSamples, 1, kMaxLightSamples);
  // What a share of 1 for the constant domes at the first surface would have changed, where
  // their share is 0 (path space).
  const bool measuringDomes = settings.measureConstantDomeSampling && branches == 1 &&
                              settings.firstSurfaceConstantDomeShare == 0;
  Vec3f domeSamplingShift{0.0f};
  // What the sample found before it branched, and the sum of its branches' estimates (each with
  // that light), in RGB: a branch that meets a dispersive interface keeps only its hero
  // wavelength, so each branch is turned into RGB with its own wavelengths.
  std::optional<Vec3f> radianceBeforeBranching;
  Vec3f branchesRgb{0.0f};
  const auto toRgb = [&](const Vec3f& radiance) {
    return spectrum.spectral ? spectralToRgb(radiance, spectrum.wavelengths) : radiance;
  };
  // The paths that go on from the first surface are the branches, each as kWavelengthCopies
  // copies at a smooth dispersive solid (1 elsewhere): path p is copy p % copies of branch
  // p / copies. Each path's estimate, the light found before the split (in its copy's order)
  // plus `found` after it, goes into branchesRgb through here; with two branches, their
  // difference is kept too (CameraSample::branchDifference).
  int copies = 1;
  const auto endPath = [&](const Vec3f& found) {
    const int copy = path.pathIndex % copies;
    const Vec3f estimate = toRgb(heroFirst(*radianceBeforeBranching, copy) + found);
    branchesRgb += estimate;
    if (branches == 2)
      result.branchDifference +=
          (path.pathIndex / copies == 0 ? estimate : -estimate) / float(copies);
  };
  // The share of light that a shadow ray towards `tFar` carries through the volumes.
  // `linkSlot`: the light's (its shadow link may let the ray pass some volumes).
  const auto volumeTransmittance = [&](const Ray& shadow, float tFar, int linkSlot) {
    return hasVolumes ? estimateTransmittance(scene.volumes(), shadow, tFar, mediumSpectrum,
                                              *volumeRandom, scene.geometry().linking(), linkSlot)
                      : Vec3f(1.0f);
  };

  // Next-event estimation at a vertex (SurfaceVertex, MediumVertex) seen from `receiver`: every
  // infinite light (or one, when there are many) and one local light chosen by its estimated
  // contribution there, each sampled over its area or solid angle from a dimension of its own
  // (its choice's slot). The light it adds has `interactions` surface or medium interactions.
  // `linkingClass`: the vertex's placement's, or the scattering medium's (light linking).
  // `constantDomeShare`: the share of its MIS weight untextured domes keep (0: not sampled, and
  // only measured where measuringDomes).
  // `estimates`: how many such estimates to average (each from sample index
  // sampleIndex · estimates + k of the same dimensions, so that a pixel's are stratified together).
  // `firstSurface`: the camera ray's first surface, whose light samples evaluated and shadow
  // rays the sample keeps count of (CameraSample::firstSurfaceLightSamples, ...LightRays).
  const auto estimateDirectLight = [&](const auto& vertex, const Receiver& receiver,
                                       bool sampleLights, int interactions, uint32_t linkingClass,
                                       float constantDomeShare = 1, int estimates = 1,
                                       bool firstSurface = false) {
    const uint32_t choiceDimension = sampler.reserve(1);
    const uint32_t firstLightDimension = sampler.reserve(LightSampler::kMaxChoices);
    if (!sampleLights || settings.directLighting == DirectLighting::BsdfSamplingOnly) return;
    const LightSampler& lightSampler = scene.lights().lightSampler();
    const float share = 1.0f / float(estimates);  // 1 where there is one: exact
    SampleStream lightStream = sampler;
    int estimate = 0;
    Vec3f estimateDifference{0.0f};  // with two estimates, the first less the second
    const auto sampleLight = [&](const LightSampler::Choice& choice) {
      const Light& light = lights[choice.index];
      // A light whose light link excludes the vertex adds nothing: the estimate sums over the
      // linked lights alone, with the same choice probabilities (unbiased, as BSDF-sampled
      // hits on it add nothing either).
      if (scene.geometry().linking().lightExcluded(linkingClass, light.linkSlot())) return;
      // Past an AboveDiffuse caster, the path tracer keeps the diffuse layer's part of the
      // light the light tracer takes; past a Whole one, nothing.
      const bool taken =
          causticPath() && settings.caustics->takesLightPast(choice.index, path.pastAboveDiffuse);
      if (taken && !path.pastAboveDiffuse) return;
      const bool throughExcluded = passesExcludedShadows(scene, choice.index);
      const bool shared = constantDomeShare < 1 && light.isConstantDome() && !throughExcluded;
      const bool unsampled = shared && constantDomeShare == 0;
      if (unsampled && !measuringDomes) return;
      const Vec2f lightSample = lightStream.draw2D(firstLightDimension + choice.slot);
      const std::optional<LightSample> sample =
          light.sample(receiver.position, lightSample, receiver.normal, vertex.time);
      // Multiple importance sampling weighs the light's density against the vertex's: that is
      // found with f, with which it shares most of its work.
      const bool weighed = sample && !sample->isDelta && !throughExcluded &&
                           settings.directLighting != DirectLighting::LightSamplingOnly;
      Vec3f diffusePart;
      const BsdfEvaluation evaluated =
          !sample || !(sample->pdf > 0) ? BsdfEvaluation{Vec3f(0.0f), 0.0f}
          : weighed ? vertex.evaluateWithPdf(sample->direction, &diffusePart)
                    : BsdfEvaluation{vertex.evaluate(sample->direction, &diffusePart), 0.0f};
      const Vec3f& f = evaluated.value;
      if (isBlack(f)) return;
      const float tFar =
          std::isfinite(sample->distance) ? sample->distance * (1 - 1e-4f) : kInfinity;
      (unsampled ? result.domeSamplingShadowRays : result.rays) += light.castsShadows();
      if (firstSurface && !unsampled) {
        ++result.firstSurfaceLightSamples;
        result.firstSurfaceLightRays += light.castsShadows();
      }
      Vec3f transmittance{1.0f};
      if (light.castsShadows()) {
        Ray shadow = vertex.shadowRay(sample->direction, tFar);
        if (std::isfinite(sample->distance)) {
          // It leaves from a point moved off the surface, which brings the light's point nearer
          // along its way: it stops short of that point by the point's own rounding margin, not
          // past it, where the light's own mesh, or a ceiling a lamp hangs under, would block it
          // (far from the origin the move outgrew the relative margin above).
          const Vec3f lightPoint = receiver.position + sample->direction * sample->distance;
          shadow.tFar = std::min(shadow.tFar, dot(lightPoint - shadow.origin, sample->direction) -
                                                  scene.rayEpsilon(lightPoint));
        }
        if (settings.rayLog)
          settings.rayLog->add({shadow, RayKind::Secondary, true, light.linkSlot()});
        // A light's point within those margins is too near for anything to lie between (a
        // negative length would read as blocked).
        if (shadow.tFar > 0 && scene.geometry().occluded(shadow, light.linkSlot())) return;
        if (hasVolumes && shadow.tFar > 0) {
          transmittance = volumeTransmittance(shadow, shadow.tFar, light.linkSlot());
          if (isBlack(transmittance)) return;
        }
      }
      const float lightPdf = choice.probability * sample->pdf;
      const float weighingPdf = choice.probability * sample->pdfForWeights();
      const float weight = weighed ? powerHeuristic(float(estimates) * weighingPdf, evaluated.pdf) *
                                         (shared && !unsampled ? constantDomeShare : 1.0f)
                                   : 1.0f;
      const Vec3f response = taken ? diffusePart * light.diffuseMultiplier()
                                   : diffusePart * light.diffuseMultiplier() +
                                         (f - diffusePart) * light.specularMultiplier();
      const Vec3f contribution =
          clampIndirect(throughput * transmittance * response *
                            spectrum.emission(sample->radiance) * (weight / lightPdf),
                        interactions, settings.indirectClamp) *
          share;
      if (unsampled) {
        domeSamplingShift += contribution;
        return;
      }
      addLight(contribution);
      if (estimates == 2)
        estimateDifference += estimate == 0 ? contribution * 2 : contribution * -2;
    };
    for (; estimate < estimates; ++estimate) {
      if (estimates > 1)
        lightStream = sampler.atSample(sampleIndex * uint32_t(estimates) + uint32_t(estimate));
      // Drawn only where they choose something (one lamp, a sun and a sky are each sampled).
      const Sample4D lightChoices = lightSampler.choosesAtRandom()
                                        ? lightStream.draw4D(choiceDimension)
                                        : Sample4D{0, 0, 0, 0};
      lightSampler.forEachChoice(receiver, lightChoices, sampleLight);
    }
    if (estimates == 2) result.lightEstimateDifference = toRgb(estimateDifference);
  };

  // The camera sample's path, then each branch it left waiting at its first surface.
  for (int firstBounce = 0;; firstBounce = 1) {
    for (int bounce = firstBounce;; ++bounce) {
      if (settings.rayLog) settings.rayLog->add({ray, rayKind, false, -1});
      const std::optional<SurfaceHit> hit = intersectSurface(scene, ray, rayKind, cone);
      ++result.rays;
      // The volumes between the ray's origin and the surface: the ray may scatter or end there.
      FlightOutcome flight = FlightOutcome::Passed;
      MediumScattering mediumPoint;
      const Vec3f throughputBeforeFlight = throughput;
      if (hasVolumes) {
        Vec3f mediumEmission{0.0f};
        flight =
            sampleFreeFlight(scene.volumes(), ray, hit ? hit->distance : ray.tFar, mediumSpectrum,
                             *volumeRandom, &throughput, &mediumEmission, &mediumPoint);
        addLight(clampIndirect(mediumEmission, bounce, settings.indirectClamp));
      }
      const bool passed = flight == FlightOutcome::Passed;
      if (hit && passed) throughput *= glassTransmittance(*hit, ray.direction, spectrum);
      float nearestLight = kInfinity;
      bool sawLight = false;
      Vec3f escapedDomeShift{0.0f};
      // Light met by this ray has `bounce` interactions behind it, plus its emission. Lights in
      // front of a collision in a medium take the path's weight from before the flight (exact
      // for grey media, whose tracking leaves the weight as it is).
      const std::optional<LeftToLightTracing> leftToLightTracing =
          causticPath() ? std::optional<LeftToLightTracing>(
                              {*settings.caustics, path.pastAboveDiffuse, path.keptAboveDiffuse})
                        : std::nullopt;
      addLight(
          clampIndirect((passed ? throughput : throughputBeforeFlight) *
                            emittedAlongRay(scene, ray,
                                            !passed ? mediumPoint.distance
                                            : hit   ? hit->distance
                                                    : ray.tFar,
                                            !hit && passed, scattering, settings.directLighting,
                                            spectrum, cameraSample, &nearestLight, &sawLight,
                                            measuringDomes ? &escapedDomeShift : nullptr,
                                            leftToLightTracing ? &*leftToLightTracing : nullptr),
                        bounce, settings.indirectClamp));
      if (measuringDomes)
        domeSamplingShift += (passed ? throughput : throughputBeforeFlight) * escapedDomeShift;
      // What the ray stops at: the surface, or the medium where it collided.
      const SurfaceHit* surface = hit && passed ? &*hit : nullptr;
      if (bounce == 0) {
        const float stop = !passed ? mediumPoint.distance : hit ? hit->distance : kInfinity;
        const float firstHit = std::min(stop, nearestLight);
        if (firstHit < kInfinity) result.depth = camera.viewDepth(ray, firstHit);
        if (hit || sawLight || !passed) result.alpha = 1;
        if (firstHitRecord) {
          firstHitRecord->filterOffset = filterOffset;
          // A holdout sets the distances only: it is no surface of the image.
          recordFirstHit(camera, ray, surface && !surface->matte ? surface : nullptr, firstHit,
                         firstHitRecord);
        }
        // A holdout: what lies behind it is hidden, and only lights in front of it count.
        if (surface && surface->matte) {
          result.alpha = sawLight ? 1 : 0;
          break;
        }
      }
      if (flight == FlightOutcome::Absorbed) break;
      if (flight == FlightOutcome::Scattered) {
        // A scattering event in a medium: light is estimated there as at a surface, with the
        // phase function in the BSDF's place and no normal to face.
        if (bounce >= settings.maxPathDepth || lastVertex ||
            volumeBounces >= settings.maxVolumeDepth)
          break;
        ++result.vertices;
        path.castersSinceFirstSurface = -1;
        const HenyeyGreenstein phase(mediumPoint.anisotropy);
        const Receiver receiver{mediumPoint.position, Vec3f()};
        estimateDirectLight(MediumVertex{phase, ray.direction, mediumPoint.position, ray.time},
                            receiver, true, bounce + 1, mediumPoint.linkingClass);
        // Phase sampling continues the path; its weight f / pdf is 1.
        const Sample4D phaseSample = sampler.next4D();
        const Vec3f direction = phase.sample(ray.direction, {phaseSample.y, phaseSample.z});
        const float pdf = phase.evaluate(ray.direction, direction);
        minRayPdf = std::min(minRayPdf, pdf);
        scattering = {pdf, true, Vec3f(1.0f), receiver, mediumPoint.linkingClass};
        rayKind = RayKind::Diffuse;  // as the lights' diffuse multiplier takes it
        lastVertex = ++volumeBounces >= settings.maxVolumeDepth;
        if (bounce >= 3 && maxComponent(throughput) < 1) {
          const float survival = maxComponent(throughput);
          if (phaseSample.w >= survival) break;
          throughput *= 1 / survival;
        }
        if (isBlack(throughput)) break;
        cone.width = cone.radiusAt(mediumPoint.distance);
        ray.origin = mediumPoint.position;
        ray.direction = direction;
        ray.tNear = 0;
        ray.tFar = kInfinity;
        continue;
      }
      if (!hit) break;
      if (!isBlack(hit->emission)) {
        // A mesh light's surface: weigh against sampling that light, as for the other lights.
        float weight = 1;
        Vec3f lobes(1.0f);  // where the light's multipliers differ (else within `weight`)
        if (hit->lightIndex >= 0) {
          const size_t index = size_t(hit->lightIndex);
          weight = lightReaches(scene, scattering, index)
                       ? bsdfStrategyWeight(
                             scene, scattering, index,
                             lights[index].meshPdf(ray.origin, hit->position, hit->normal),
                             settings.directLighting)
                       : 0.0f;
          const Vec3f multiplier = lobeMultiplier(lights[index], scattering);
          if (multiplier.x == multiplier.y && multiplier.y == multiplier.z)
            weight *= multiplier.x;
          else
            lobes = multiplier;
        }
        Vec3f kept(1.0f);  // as emittedAlongRay leaves the light tracer's lights
        if (hit->lightIndex >= 0 && causticPath() &&
            settings.caustics->takesLightPast(size_t(hit->lightIndex), path.pastAboveDiffuse))
          kept = path.pastAboveDiffuse ? path.keptAboveDiffuse : Vec3f(0.0f);
        addLight(
            clampIndirect(throughput * spectrum.emission(hit->emission) * weight * kept * lobes,
                          bounce, settings.indirectClamp));
      }
      if (bounce >= settings.maxPathDepth || lastVertex) break;
      ++result.vertices;
      const Vec3f wo = -ray.direction;
      const MaterialParams& material = hit->material();
      if (settings.caustics) {
        int& casters = path.castersSinceFirstSurface;
        const CasterKind kind = settings.caustics->casterKindAt(hit->materialIndex, material);
        if (bounce == 0) {
          const bool throughCasters = kind == CasterKind::Whole && settings.causticPhotons;
          casters = kind != CasterKind::Whole && receivesCaustics(material) ? 0
                    : throughCasters                                        ? path.kThroughCasters
                                                                            : -1;
          path.castersTaken = settings.caustics->maxCasters();
          path.pastAboveDiffuse = false;
        } else if (casters == path.kThroughCasters) {
          if (kind != CasterKind::Whole) {
            // The casters after this surface, and the light past them, fit in what each depth
            // limit leaves (as maxCasters does at a first surface).
            path.castersTaken =
                std::min(settings.caustics->maxCasters(),
                         castersWithinDepthLimits(settings, diffuseBounces, glossyBounces,
                                                  transmissionBounces, bounce));
            casters = receivesCaustics(material) && path.castersTaken >= 1 ? 0 : -1;
          }
        } else if (casters >= 0) {
          // An AboveDiffuse caster ends the casters a path takes.
          const bool more = !path.pastAboveDiffuse && kind != CasterKind::None;
          casters = more ? casters + 1 : -1;
          path.pastAboveDiffuse = more && kind == CasterKind::AboveDiffuse;
        }
      }
      const bool dispersive = spectrum.disperses(material);
      const float ior = spectrum.ior(material);
      const Vec3f facingNormal =
          dot(wo, hit->shadingNormal) >= 0 ? hit->shadingNormal : -hit->shadingNormal;
      SurfaceBsdf surfaceBsdf = makeBsdf(*hit, scene.materials(), spectrum, ior,
                                         filteredAlpha(settings.glossyFilter, minRayPdf));
      std::optional<Vec3f> channelIors;  // each wavelength's index, where the BSDF disperses
      if (dispersive && !spectrum.wavelengths.heroOnly()) {
        // A dispersive interface sends each wavelength its own way when it refracts: there only
        // the hero's path goes on. Where the BSDF cannot tell refraction apart before sampling,
        // that holds from here on.
        const Vec3f iors = spectrum.channelIors(material);
        if (surfaceBsdf.disperse(wo, iors, material.ior)) {
          channelIors = iors;
        } else {
          spectrum.wavelengths.keepHeroOnly();
          throughput = {throughput.x, 0, 0};
        }
      }
      // A thin sheet lets every wavelength through alike: copies there would only repeat its
      // path. (The dome pilot's measurements keep one path.)
      if (bounce == 0)
        copies = channelIors && hit->closed && !measuringDomes ? kWavelengthCopies : 1;
      const bool guided = (settings.guidingField || training) && guidable(*hit, surfaceBsdf);
      const GuidedBsdf bsdf(surfaceBsdf,
                            guided && settings.guidingField
                                ? settings.guidingField->at(hit->position, facingNormal)
                                : nullptr);

      // Lights on the surface's front and back count for translucent surfaces.
      const Receiver receiver{hit->position,
                              surfaceBsdf.hasTransmission() ? Vec3f() : facingNormal};
      const float constantDomeShare =
          bounce == 0 && settings.directLighting == DirectLighting::MultipleImportance
              ? std::clamp(settings.firstSurfaceConstantDomeShare, 0.0f, 1.0f)
              : 1.0f;
      const int lightEstimatesHere = bounce == 0 ? lightEstimates : 1;
      estimateDirectLight(surfaceVertex(scene, *hit, bsdf, wo, ray.time), receiver,
                          !surfaceBsdf.isPurelySpecular(), bounce + 1, hit->linkingClass,
                          constantDomeShare, lightEstimatesHere, bounce == 0);
      if (bounce > 0 && path.castersSinceFirstSurface == 0) {
        // A receiver seen through casters: the light of the paths from here that the path
        // tracer leaves out, from the photons of this sample index around the hit.
        const float radius =
            settings.causticPhotons->radius(sampleIndex, cone.radiusAt(hit->distance));
        Vec3f gathered{0.0f};
        settings.causticPhotons->at(sampleIndex)
            .forEachWithin(hit->position, radius, [&](const Photon& photon) {
              // The same surface: not one beside it round an edge.
              if (photon.casters > path.castersTaken ||
                  std::abs(dot(photon.normal, hit->normal)) < 0.5f)
                return;
              gathered += surfaceBsdf.evaluate(wo, photon.towardsLight, nullptr) *
                          spectrum.emission(photon.power);
            });
        addLight(throughput * gathered * settings.causticPhotons->perPhoton(radius));
      }

      // BSDF sampling continues the path (false: it ends here). Inlined at both calls: called,
      // it reached the path's state through its captures and cost 1 % more per sample.
      const auto scatter = [&]() __attribute__((always_inline)) -> bool {
        // The lobe and the direction in it are stratified jointly.
        const Sample4D scatteringSample = sampler.next4D();
        const float lobeChoice = scatteringSample.x;
        const Vec2f directionSample{scatteringSample.y, scatteringSample.z};
        const float rouletteSample = scatteringSample.w;
        const std::optional<BsdfSample> scattered = bsdf.sample(wo, lobeChoice, directionSample);
        if (!scattered || isBlack(scattered->weight)) return false;
        // A direction on the other side of the geometric surface than the lobe intends (possible
        // with shading normals) would leak light through the surface.
        if ((dot(scattered->direction, hit->normal) * dot(wo, hit->normal) < 0) !=
            scattered->transmitted)
          return false;
        if (causticPath() && path.pastAboveDiffuse) {
          // The light tracer takes the rest of what lights the path finds along this ray.
          Vec3f diffusePart{0.0f};
          const Vec3f f = scattered->isDelta
                              ? Vec3f(0.0f)
                              : bsdf.evaluate(wo, scattered->direction, &diffusePart);
          path.keptAboveDiffuse = shareOf(diffusePart, f);
        }
        throughput *= scattered->weight;
        if (scattered->heroOnly) spectrum.wavelengths.keepHeroOnly();
        if (training && guided && !scattered->isDelta && path.pathIndex == 0)
          trainer.addVertex(hit->position, facingNormal, *scattered, throughput, bounce);
        // Where the path goes on from: here, or where a subsurface random walk left the solid.
        BsdfSample next = *scattered;
        Receiver nextReceiver = receiver;
        const auto walk = [&] {
          // The walk takes as many random numbers as it scatters: a stream of its own per vertex.
          RandomStream walkRandom(settings.seed, uint32_t(x), uint32_t(y), sampleIndex,
                                  path.streamPurposeOffset + 1 + uint32_t(bounce));
          return subsurfaceRandomWalk(scene, *hit, scattered->direction,
                                      subsurfaceMediumAt(*hit, spectrum), walkRandom, ray.time);
        };
        // Initialised as it is returned: an empty std::optional of this size that is assigned to
        // later is cleared first (some 460 bytes at every vertex).
        const std::optional<SubsurfaceExit> exit =
            scattered->lobe == BsdfLobe::Subsurface ? walk() : std::nullopt;
        if (scattered->lobe == BsdfLobe::Subsurface) {
          // A walk that met another object inside the solid ends there: the light it carried is
          // lost (a little dark where objects are embedded) rather than let into that object.
          if (!exit || !exit->sameObject) return false;
          throughput *= exit->weight;
          // Light leaves through a white Lambertian lobe facing out of the solid: lights are
          // sampled there, and the path goes on from it. Entry, walk and exit are one interaction
          // of the path (as the light they add is counted, for the indirect clamp).
          const Vec3f outward =
              dot(exit->direction, exit->hit.normal) >= 0 ? exit->hit.normal : -exit->hit.normal;
          const LambertianExit lambert(outward);
          nextReceiver = {exit->hit.position, outward};
          estimateDirectLight(surfaceVertex(scene, exit->hit, lambert, outward, ray.time),
                              nextReceiver, true, bounce + 1, exit->hit.linkingClass);
          const Sample4D exitSample = sampler.next4D();
          next = lambert.sample({exitSample.y, exitSample.z});
          if (!(next.pdf > 0)) return false;
        }
        if (!next.isDelta) minRayPdf = std::min(minRayPdf, next.pdf);
        scattering = {next.isDelta ? 0.0f : next.pdf,
                      true,
                      Vec3f(next.lobe == BsdfLobe::Diffuse ? 1.0f : 0.0f),
                      nextReceiver,
                      exit ? exit->hit.linkingClass : hit->linkingClass,
                      exit ? 1.0f : constantDomeShare,
                      exit ? 1.0f : float(lightEstimatesHere)};
        if (scene.lights().lobeMultipliersDiffer() && !next.isDelta && !exit) {
          // Some light's diffuse and specular multipliers differ: each scales its lobes' share
          // of the BSDF's value in this direction, as next-event estimation's do, not the whole
          // of it by the lobe this ray was drawn from.
          Vec3f diffusePart{0.0f};
          const Vec3f f = bsdf.evaluate(wo, next.direction, &diffusePart);
          scattering.diffuseShare = shareOf(diffusePart, f);
        }
        // A subsurface walk counts as one diffuse bounce.
        const bool diffuseLobe =
            scattered->lobe == BsdfLobe::Diffuse || scattered->lobe == BsdfLobe::Subsurface;
        int& lobeBounces = diffuseLobe                                 ? diffuseBounces
                           : scattered->lobe == BsdfLobe::Transmission ? transmissionBounces
                                                                       : glossyBounces;
        const int lobeLimit = diffuseLobe ? settings.maxDiffuseDepth
                              : scattered->lobe == BsdfLobe::Transmission
                                  ? settings.maxTransmissionDepth
                                  : settings.maxGlossyDepth;
        lastVertex = ++lobeBounces >= lobeLimit;
        // A subsurface walk leaves by its Lambertian exit: a diffuse ray.
        rayKind = diffuseLobe                                 ? RayKind::Diffuse
                  : scattered->lobe == BsdfLobe::Transmission ? RayKind::Transmission
                                                              : RayKind::Glossy;
        // Russian roulette once paths are long enough to be dim, in proportion to what they still
        // carry; paths as bright as a camera ray's (glass, mirrors) are never cut, since cutting
        // them saves little and adds the most variance. Survivors are reweighted.
        if (bounce >= 3 && maxComponent(throughput) < 1) {
          const float survival = maxComponent(throughput);
          if (rouletteSample >= survival) return false;
          throughput *= 1 / survival;
        }
        if (isBlack(throughput)) return false;
        // The footprint keeps widening at the camera's rate; surface curvature and roughness,
        // which would widen it further, are ignored.
        cone.width = cone.radiusAt(hit->distance);
        ray = spawnRay(scene, exit ? exit->hit : *hit, next.direction, kInfinity, ray.time);
        return true;
      };
      const int paths = bounce == 0 ? branches * copies : 1;
      if (paths > 1) {
        // Each path scatters from here on its own; the first goes on now, the others wait.
        const PathState atSurface = path;
        waitingBranches.reserve(size_t(paths - 1));
        radianceBeforeBranching = result.radiance;
        result.raysBeforeBranching = result.rays;
        result.verticesBeforeBranching = result.vertices;
        result.radiance = Vec3f(0.0f);
        // Path p as copy p % copies of its branch: the branch's random numbers, and the
        // wavelengths, throughput and BSDF with the copy's wavelength as the hero (copy 0's is
        // the BSDF set up above, kept while the others are set up in its place).
        const std::optional<SurfaceBsdf> heroBsdf =
            copies > 1 ? std::optional<SurfaceBsdf>(surfaceBsdf) : std::nullopt;
        const auto begin = [&](int p) {
          path = atSurface;
          path.branchOff(p / copies, branches, settings.seed, x, y, sampleIndex);
          path.pathIndex = p;
          const int copy = p % copies;
          if (copies == 1) return;
          SampledWavelengths& wavelengths = spectrum.wavelengths;
          wavelengths = {heroFirst(wavelengths.lambda, copy), heroFirst(wavelengths.pdf, copy)};
          throughput = heroFirst(throughput, copy);
          if (copy == 0) {
            surfaceBsdf = *heroBsdf;
            return;
          }
          const Vec3f iors = heroFirst(*channelIors, copy);
          surfaceBsdf = makeBsdf(*hit, scene.materials(), spectrum, iors.x,
                                 filteredAlpha(settings.glossyFilter, minRayPdf));
          surfaceBsdf.disperse(wo, iors, material.ior);
        };
        for (int p = paths - 1; p > 0; --p) {
          begin(p);
          const bool goesOn = scatter();
          // What it found as it left is its own, not the light of the path that goes on now.
          const Vec3f found = std::exchange(result.radiance, Vec3f(0.0f));
          if (goesOn) {
            path.radianceBeforeWaiting = found;
            waitingBranches.push_back(path);
          } else {  // it ends here
            endPath(found);
          }
        }
        begin(0);
      }
      if (!scatter()) break;
    }
    if (radianceBeforeBranching) {
      endPath(result.radiance);
      result.radiance = Vec3f(0.0f);
    }
    if (waitingBranches.empty()) break;
    path = waitingBranches.back();
    waitingBranches.pop_back();
    result.radiance = path.radianceBeforeWaiting;
  }
  if (training) trainer.record(*settings.guidingRecorder, x, y, sampleIndex);
  if (measuringDomes) result.domeSamplingShift = toRgb(domeSamplingShift);
  if (!radianceBeforeBranching) {
    result.raysBeforeBranching = result.rays;
    result.verticesBeforeBranching = result.vertices;
  }
  result.radiance = radianceBeforeBranching ? branchesRgb * (1.0f / float(branches * copies))
                                            : toRgb(result.radiance);
  return result;
}

}  // namespace penumbra
