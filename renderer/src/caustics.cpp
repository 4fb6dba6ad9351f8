#include "penumbra/caustics.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "on_threads.h"
#include "path_spectrum.h"
#include "penumbra/bsdf.h"
#include "penumbra/film.h"
#include "penumbra/random_stream.h"
#include "penumbra/surface_hit.h"
#include "penumbra/warp.h"

namespace penumbra {
namespace {

/// The light tracer's random streams: RandomStream's "pixel" is the path's index within its
/// sample index and this tag, which no image's row reaches.
constexpr uint32_t kLightPathTag = 0xCA057105u;
/// Light paths traced (and their splats kept) at once, per thread's share of a sample index.
constexpr uint32_t kPathsPerBlock = 4096;

/// Scale of radiance across a refraction from the side of `from` to that of `to` (unit
/// directions away from the surface) at a solid of index `ior` whose front is outside: the
/// factor by which a radiance BSDF sampled from `from` differs from the adjoint one the light
/// tracer needs, (η_to / η_from)².
float adjointRefractionScale(const Vec3f& from, const Vec3f& normal, float ior) {
  const float ratio = dot(from, normal) > 0 ? ior : 1 / ior;
  return ratio * ratio;
}

/// The BSDF at a hit at the path's wavelengths, as the path tracer sets it up. `wo`: the
/// direction the BSDF is sampled from or evaluated towards, as the path tracer's would be. Where
/// the material disperses and cannot give each wavelength its own index for that direction
/// (PreviewSurfaceBsdf::disperse), the path keeps its hero wavelength alone (and `beta` its
/// hero's channel), as the path tracer's does.
PreviewSurfaceBsdf bsdfAt(const SurfaceHit& hit, const Vec3f& wo, PathSpectrum& spectrum,
                          Vec3f& beta) {
  const MaterialParams& material = hit.material();
  PreviewSurfaceBsdf bsdf(
      spectrum.surfaceColours(material), hit.shadingNormal, spectrum.ior(material),
      hit.closed ? DielectricKind::Solid : DielectricKind::ThinSheet, hit.tangent);
  if (spectrum.disperses(material) && !spectrum.wavelengths.heroOnly() &&
      !bsdf.disperse(wo, spectrum.channelIors(material), material.ior)) {
    spectrum.wavelengths.keepHeroOnly();
    beta = {beta.x, 0, 0};
  }
  return bsdf;
}

}  // namespace

bool castsCaustics(const MaterialParams& material) {
  if (material.hair || material.subsurface > 0 || material.sheen > 0) return false;
  const auto smooth = [](float roughness) { return roughness <= kCausticMaxRoughness; };
  if (material.clearcoat > 0 && !smooth(material.clearcoatRoughness)) return false;
  if (!smooth(material.roughness)) return false;
  const bool metal = !material.useSpecularWorkflow && material.metallic >= 1;
  const float transmissionRoughness =
      material.transmissionRoughness >= 0 ? material.transmissionRoughness : material.roughness;
  const bool clearGlass =
      material.opacity <= 0 && !(material.transmissionDepth > 0) && smooth(transmissionRoughness);
  return metal || clearGlass;
}

CasterKind casterKind(const MaterialParams& material) {
  if (castsCaustics(material)) return CasterKind::Whole;
  const auto smooth = [](float roughness) { return roughness <= kCausticMaxRoughness; };
  const bool smoothAboveDiffuse = smooth(material.roughness) &&
                                  !(material.clearcoat > 0 && !smooth(material.clearcoatRoughness));
  return smoothAboveDiffuse && splitsAboveDiffuse(material) ? CasterKind::AboveDiffuse
                                                            : CasterKind::None;
}

bool splitsAboveDiffuse(const MaterialParams& atHit) {
  return !atHit.hair && !(atHit.subsurface > 0) && !(atHit.sheen > 0) && atHit.opacity >= 1;
}

int castersWithinDepthLimits(const IntegratorSettings& settings, int diffuseBounces,
                             int glossyBounces, int transmissionBounces, int bounce) {
  return std::min({settings.maxPathDepth - bounce, settings.maxDiffuseDepth - diffuseBounces,
                   settings.maxGlossyDepth - glossyBounces,
                   settings.maxTransmissionDepth - transmissionBounces}) -
         1;
}

bool receivesCaustics(const MaterialParams& material) {
  return !castsCaustics(material) && !material.hair && !(material.subsurface > 0);
}

CausticTracer::CausticTracer(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                             const IntegratorSettings& settings)
    : scene_(scene), camera_(camera), filter_(filter), seed_(settings.seed) {
  // No depth limit may cut a path taken from a first surface.
  const int maxCasters = castersWithinDepthLimits(settings, 0, 0, 0, 0);
  // Its rays see what Secondary rays see: every shown object.
  const bool matched = scene.volumes().empty() && !scene.geometry().hidesFromRays() &&
                       camera.params().projection == Projection::Perspective &&
                       !(settings.indirectClamp > 0) && !(settings.glossyFilter > 0) &&
                       settings.directLighting == DirectLighting::MultipleImportance &&
                       maxCasters >= 1;
  if (!matched) return;
  const MaterialTable& materials = scene.materials();
  std::vector<CasterKind> casters(materials.materialCount(), CasterKind::None);
  for (size_t index = 0; index < casters.size(); ++index)
    casters[index] = casterKind(materials.shadedConstants(int(index)));
  // Light paths aim at a sphere around each caster, or around each kind's where there are many.
  struct Object {
    CasterKind kind;
    Vec3f lower, upper;
  };
  std::vector<Object> objects;
  scene.geometry().forEachObjectBounds([&](int index, const Vec3f& lower, const Vec3f& upper) {
    const CasterKind kind = index >= 0 ? casters[size_t(index)] : CasterKind::None;
    if (kind != CasterKind::None) objects.push_back({kind, lower, upper});
  });
  if (objects.size() > kMaxTargets) {
    std::vector<Object> kinds;
    for (const CasterKind kind : {CasterKind::Whole, CasterKind::AboveDiffuse}) {
      Object all{kind, Vec3f(kInfinity), Vec3f(-kInfinity)};
      for (const Object& object : objects) {
        if (object.kind != kind) continue;
        all.lower = componentMin(all.lower, object.lower);
        all.upper = componentMax(all.upper, object.upper);
      }
      if (all.lower.x <= all.upper.x) kinds.push_back(all);
    }
    objects = std::move(kinds);
  }
  for (const Object& object : objects) {
    const float radius =
        0.5f * length(object.upper - object.lower) * 1.001f + scene.rayEpsilon(object.upper);
    if (std::isfinite(radius))
      targets_.push_back({(object.lower + object.upper) * 0.5f, radius, object.kind});
  }
  if (targets_.empty()) return;  // no caster shows

  const std::vector<Light>& all = scene.lights().all();
  std::vector<CausticTakeover::LightTaken> taken(all.size(), CausticTakeover::LightTaken::No);
  std::vector<float> powers;  // by start
  float total = 0;
  for (size_t index = 0; index < all.size(); ++index) {
    const Light& light = all[index];
    // Linked lights would need each caster's links; lights that cast no shadows, a shadow ray
    // the light tracer does not trace; moving mesh lights, a start where they are at the path's
    // time, drawn after its start.
    const bool distant = light.type() == LightType::Distant;
    if (!(light.emitsFromSurface() || distant) || light.linkSlot() >= 0 || !light.castsShadows() ||
        light.moves())
      continue;
    // AboveDiffuse casters take the light of those whose lobes' multipliers agree (LightTaken).
    const bool pastEveryCaster = light.diffuseMultiplier() == light.specularMultiplier();
    const size_t first = starts_.size();
    for (size_t target = 0; target < targets_.size(); ++target) {
      const Target& aim = targets_[target];
      if (aim.kind == CasterKind::AboveDiffuse && !pastEveryCaster) continue;
      // Chosen by about what reaches the target: a distant light's irradiance over its
      // cross-section, a local one's power times the solid angle the target subtends there.
      const float radius2 = aim.radius * aim.radius;
      float power = 0;
      if (distant) {
        power = light.irradiance() * kPi * radius2;
      } else {
        const LightBounds bounds = light.bounds();
        const Vec3f toTarget = aim.centre - bounds.centroid();
        const float distance2 = dot(toTarget, toTarget);
        const float solidAngle =
            distance2 > radius2 ? 2 * kPi * (1 - std::sqrt(1 - radius2 / distance2)) : 4 * kPi;
        power = bounds.power * std::max(solidAngle, 1e-6f);
      }
      if (aim.kind == CasterKind::AboveDiffuse) power *= kAboveDiffuseShare;
      if (!(power > 0) || !std::isfinite(power)) continue;
      starts_.push_back({uint32_t(index), uint32_t(target), 0, 0});
      powers.push_back(power);
      total += power;
      startCdf_.push_back(total);
    }
    if (starts_.size() == first) continue;
    for (size_t start = first; start < starts_.size(); ++start) {
      starts_[start].lightsFirst = uint32_t(first);
      starts_[start].lightsEnd = uint32_t(starts_.size());
    }
    taken[index] = pastEveryCaster ? CausticTakeover::LightTaken::PastEveryCaster
                                   : CausticTakeover::LightTaken::PastWholeCasters;
  }
  leaveDimLampsToThePathTracer(powers, total, taken);
  if (starts_.empty()) return;
  for (float& step : startCdf_) step /= total;
  startCdf_.back() = 1;
  takeover_ = CausticTakeover(std::move(casters), std::move(taken), maxCasters);
  const double pixels = double(camera.imageWidth()) * double(camera.imageHeight());
  pathsPerSample_ = uint32_t(std::clamp(std::ceil(pixels * kPathsPerPixel), 1.0, 1e9));
}

void CausticTracer::leaveDimLampsToThePathTracer(const std::vector<float>& powers, float& total,
                                                 std::vector<CausticTakeover::LightTaken>& taken) {
  // A start is chosen by a float in [0, 1): one whose share is near its resolution (2^-24)
  // would be chosen with a probability off the one its paths are weighed by, or never, while
  // the path tracer left its lamp's caustics out. Such lamps stay with the path tracer.
  const auto dim = [&](const Start& start) {
    float lamp = 0;
    for (uint32_t k = start.lightsFirst; k < start.lightsEnd; ++k) lamp += powers[k];
    return lamp < kMinLampShare * total;
  };
  if (std::none_of(starts_.begin(), starts_.end(), dim)) return;  // as built, bit for bit
  std::vector<Start> kept;
  std::vector<float> keptCdf;
  float keptTotal = 0;
  for (size_t start = 0; start < starts_.size(); ++start) {
    if (dim(starts_[start])) {
      taken[starts_[start].light] = CausticTakeover::LightTaken::No;
      continue;
    }
    kept.push_back(starts_[start]);
    keptTotal += powers[start];
    keptCdf.push_back(keptTotal);
  }
  for (size_t start = 0; start < kept.size(); ++start) {  // each lamp's range, renumbered
    size_t end = start;
    while (end < kept.size() && kept[end].light == kept[start].light) ++end;
    for (size_t k = start; k < end; ++k) {
      kept[k].lightsFirst = uint32_t(start);
      kept[k].lightsEnd = uint32_t(end);
    }
    start = end - 1;
  }
  starts_ = std::move(kept);
  startCdf_ = std::move(keptCdf);
  total = keptTotal;
}

bool CausticTracer::trace(uint32_t firstSample, uint32_t sampleCount, Film& film, int threads,
                          const std::atomic<bool>* cancel, CausticPhotons* photons) const {
  if (!active()) return true;
  const uint32_t blocks = (pathsPerSample_ + kPathsPerBlock - 1) / kPathsPerBlock;
  std::vector<std::vector<Splat>> splats(blocks);
  std::vector<uint32_t> rays(pathsPerSample_);  // by path
  std::vector<std::vector<Photon>> arrivals(photons ? blocks : 0);
  std::vector<CausticPhotons::Arrivals> held;
  // Where camera rays start (for the photons' footprints).
  const Vec3f cameraCentre =
      camera_
          .generateRay(0.5f * float(camera_.imageWidth()), 0.5f * float(camera_.imageHeight()),
                       {0.5f, 0.5f}, 0.5f)
          .origin;
  for (uint32_t sample = firstSample; sample < firstSample + sampleCount; ++sample) {
    if (cancel && cancel->load(std::memory_order_relaxed)) return false;
    onThreads(threads, [&] {
      tbb::parallel_for(uint32_t(0), blocks, [&](uint32_t block) {
        std::vector<Splat>& out = splats[block];
        out.clear();
        std::vector<Photon>* kept = photons ? &arrivals[block] : nullptr;
        if (kept) kept->clear();
        const uint32_t end = std::min(pathsPerSample_, (block + 1) * kPathsPerBlock);
        for (uint32_t path = block * kPathsPerBlock; path < end; ++path)
          rays[path] = tracePath(sample, path, out, kept);
      });
    });
    // In path order, whatever thread traced them.
    for (const std::vector<Splat>& block : splats)
      for (const Splat& splat : block) film.addSplat(splat.x, splat.y, sample, splat.light);
    film.addLightPaths(pathsPerSample_, sample);
    // Each path's rays are counted at a pixel of its own, so that the image's regions (farm
    // bands) share them out exactly.
    const uint64_t pixels = uint64_t(camera_.imageWidth()) * uint64_t(camera_.imageHeight());
    for (uint32_t path = 0; path < pathsPerSample_; ++path) {
      const uint64_t pixel = uint64_t(path) * pixels / pathsPerSample_;
      film.addRays(int(pixel % uint64_t(camera_.imageWidth())),
                   int(pixel / uint64_t(camera_.imageWidth())), rays[path]);
    }
    if (!photons) continue;
    CausticPhotons::Arrivals inOrder;
    for (const std::vector<Photon>& block : arrivals)
      inOrder.photons.insert(inOrder.photons.end(), block.begin(), block.end());
    inOrder.footprint = meanFootprint(inOrder.photons, cameraCentre);
    held.push_back(std::move(inOrder));
  }
  if (photons) photons->hold(firstSample, std::move(held));
  return true;
}

float CausticTracer::meanFootprint(const std::vector<Photon>& photons, const Vec3f& centre) const {
  // A camera ray's footprint grows with its distance: at the photons' mean distance.
  double distance = 0;
  for (const Photon& photon : photons) distance += double(length(photon.position - centre));
  const float meanDistance = photons.empty() ? 1.0f : float(distance / double(photons.size()));
  return camera_.pixelCone().radiusAt(meanDistance);
}

std::optional<CausticTracer::LightPathStart> CausticTracer::startOnSurface(
    const Light& light, size_t startIndex, RandomStream& random) const {
  // A point on the light (by area, or by its texture) and a direction towards the target's sphere.
  const std::optional<Light::SurfacePoint> point = light.sampleSurface(random.next2D());
  if (!point) return std::nullopt;
  const Light::SurfacePoint& start = *point;
  const Target& aim = targets_[starts_[startIndex].target];
  const Vec2f directionSample = random.next2D();
  Vec3f direction;
  float directionPdf = 0;
  if (const std::optional<float> oneMinusCos = coneTowards(aim, start.position)) {
    const Vec3f toTarget = aim.centre - start.position;
    direction = Frame(toTarget / std::sqrt(dot(toTarget, toTarget)))
                    .toWorld(sampleUniformCone(directionSample, *oneMinusCos));
    directionPdf = uniformConePdf(*oneMinusCos);
  } else {  // within the target: it may lie every way
    const Vec3f local = sampleCosineHemisphere(directionSample);
    direction = Frame(start.normal).toWorld(local);
    directionPdf = cosineHemispherePdf(local.z);
  }
  const float cosLight = dot(direction, start.normal);
  if (!(cosLight > 0) || !(directionPdf > 0)) return std::nullopt;
  // The density with which the light's other targets give the same direction too, each
  // relative to this one's choice.
  const float chosen = startProbability(startIndex);
  float density = 0;
  for (size_t other = starts_[startIndex].lightsFirst; other < starts_[startIndex].lightsEnd;
       ++other) {
    const float share = startProbability(other) / chosen;
    if (other == startIndex) {
      density += share * directionPdf;
      continue;
    }
    const Target& also = targets_[starts_[other].target];
    if (const std::optional<float> oneMinusCos = coneTowards(also, start.position)) {
      const Vec3f toCentre = normalize(also.centre - start.position);
      if (1 - dot(direction, toCentre) <= *oneMinusCos)
        density += share * uniformConePdf(*oneMinusCos);
    } else {
      density += share * cosineHemispherePdf(cosLight);
    }
  }
  Ray ray;
  ray.origin = start.position + start.normal * scene_.rayEpsilon(start.position);
  ray.direction = direction;
  return LightPathStart{ray, light.radianceLeaving(start.texture, direction),
                        cosLight * start.areaOverDensity / density};
}

std::optional<CausticTracer::LightPathStart> CausticTracer::startFromAfar(
    const Light& light, size_t startIndex, RandomStream& random) const {
  // A direction as next-event estimation draws it, then a point of the disk across the
  // target's sphere perpendicular to it; the ray starts beyond everything, so that what shades
  // the casters from the light still does.
  const Target& aim = targets_[starts_[startIndex].target];
  const std::optional<LightSample> sample = light.sample(aim.centre, random.next2D());
  if (!sample || !(sample->pdf > 0)) return std::nullopt;
  const Vec2f onDisk = concentricSampleDisk(random.next2D());
  const Frame frame(-sample->direction);
  const Vec3f across = aim.centre + frame.toWorld({onDisk.x, onDisk.y, 0}) * aim.radius;
  // The density of that line across the light's other targets' disks too, each relative to
  // this one's (its choice over its disk's area).
  const float chosen = startProbability(startIndex);
  float density = 0;
  for (size_t other = starts_[startIndex].lightsFirst; other < starts_[startIndex].lightsEnd;
       ++other) {
    const Target& also = targets_[starts_[other].target];
    const Vec3f fromLine = also.centre - across;
    const Vec3f offLine = fromLine - sample->direction * dot(fromLine, sample->direction);
    if (other == startIndex || dot(offLine, offLine) <= also.radius * also.radius) {
      const float areas = (aim.radius * aim.radius) / (also.radius * also.radius);
      density += startProbability(other) / chosen * areas;
    }
  }
  const float away = length(aim.centre) + 2 * scene_.geometry().extent() + aim.radius;
  Ray ray;
  ray.origin = across + sample->direction * away;
  ray.direction = -sample->direction;
  const float diskArea = kPi * aim.radius * aim.radius;
  return LightPathStart{ray, sample->radiance, diskArea / density / sample->pdf};
}

std::optional<float> CausticTracer::coneTowards(const Target& target, const Vec3f& from) {
  const Vec3f toCentre = target.centre - from;
  const float distance2 = dot(toCentre, toCentre);
  const float radius2 = target.radius * target.radius;
  if (!(distance2 > radius2)) return std::nullopt;
  // 1 − cos of the cone's half angle, sin² / (1 + cos) for precision with small cones.
  const float sin2 = radius2 / distance2;
  return sin2 / (1 + std::sqrt(std::max(0.0f, 1 - sin2)));
}

float CausticTracer::startProbability(size_t index) const {
  return startCdf_[index] - (index > 0 ? startCdf_[index - 1] : 0.0f);
}

uint32_t CausticTracer::tracePath(uint32_t sample, uint32_t path, std::vector<Splat>& splats,
                                  std::vector<Photon>* photons) const {
  uint32_t rays = 0;
  RandomStream random(seed_, path, kLightPathTag, sample, 0);
  const float choice = random.next();
  const size_t slot =
      size_t(std::lower_bound(startCdf_.begin(), startCdf_.end(), choice) - startCdf_.begin());
  const size_t startIndex = std::min(slot, startCdf_.size() - 1);
  const float choiceProbability = startProbability(startIndex);
  const uint32_t lightIndex = starts_[startIndex].light;
  const Light& light = scene_.lights().all()[lightIndex];
  const std::optional<LightPathStart> start = light.type() == LightType::Distant
                                                  ? startFromAfar(light, startIndex, random)
                                                  : startOnSurface(light, startIndex, random);
  if (!start) return rays;
  Ray ray = start->ray;
  ray.time = random.next();
  const float time = ray.time;
  PathSpectrum spectrum;
  if (scene_.materials().spectral()) {
    spectrum.spectral = true;
    spectrum.wavelengths = sampleWavelengths(random.next());
  }
  // β: the light's radiance times the geometry so far, over the densities (area measure at the
  // path's last vertex).
  Vec3f beta = spectrum.emission(start->radiance) * start->weight *
               (light.specularMultiplier() / choiceProbability);
  for (int casters = 0;; ++casters) {
    ++rays;
    const std::optional<SurfaceHit> hit = intersectSurface(scene_, ray, RayKind::Secondary);
    if (!hit) return rays;
    const Vec3f towardsLight = -ray.direction;
    // An AboveDiffuse caster only as the light's first: further on, it receives.
    const CasterKind kind = takeover_.casterKindAt(hit->materialIndex, hit->material());
    const bool aboveDiffuse = kind == CasterKind::AboveDiffuse && casters == 0;
    if (kind == CasterKind::Whole || aboveDiffuse) {
      if (casters == takeover_.maxCasters()) return rays;
      if (aboveDiffuse && !takeover_.takesLightAboveDiffuse(lightIndex)) return rays;
      const PreviewSurfaceBsdf bsdf = bsdfAt(*hit, towardsLight, spectrum, beta);
      const float lobeChoice = random.next();
      const std::optional<BsdfSample> scattered =
          aboveDiffuse ? bsdf.sampleAboveDiffuse(towardsLight, lobeChoice, random.next2D())
                       : bsdf.sample(towardsLight, lobeChoice, random.next2D());
      if (!scattered || isBlack(scattered->weight)) return rays;
      const Vec3f& next = scattered->direction;
      if ((dot(next, hit->normal) * dot(towardsLight, hit->normal) < 0) != scattered->transmitted)
        return rays;
      // The radiance BSDF sampled from the light's side is the adjoint of the one the path
      // tracer evaluates from the camera's; with shading normals, each cosine is the
      // geometric one the measure has (Veach 1997, §5.3).
      const float shadingFactor =
          std::abs(dot(towardsLight, hit->shadingNormal)) * std::abs(dot(next, hit->normal)) /
          (std::abs(dot(towardsLight, hit->normal)) * std::abs(dot(next, hit->shadingNormal)));
      if (!std::isfinite(shadingFactor)) return rays;
      beta *= scattered->weight * shadingFactor;
      if (scattered->heroOnly) spectrum.wavelengths.keepHeroOnly();
      if (scattered->transmitted && hit->closed)
        beta *= adjointRefractionScale(towardsLight, hit->normal, spectrum.ior(hit->material()));
      ray = spawnRay(scene_, *hit, next, kInfinity, time);
      continue;
    }
    if (casters == 0) return rays;
    if (photons && receivesCaustics(hit->material())) {
      const Vec3f power = beta * (1 / std::abs(dot(towardsLight, hit->normal)));
      const Vec3f rgb = spectrum.spectral ? spectralToRgb(power, spectrum.wavelengths) : power;
      if (std::isfinite(rgb.x + rgb.y + rgb.z))
        photons->push_back({hit->position, hit->normal, towardsLight, rgb, casters});
    }
    // The receiving surface, joined to a point of the lens.
    const Camera::Moment moment = camera_.momentAt(time);
    const std::optional<PointImage> image = camera_.pointImage(hit->position, moment);
    if (!image) return rays;
    const Vec2f lensSample = random.next2D();
    const Vec2f lensPoint = concentricSampleDisk(lensSample);
    const Vec2f at{image->position.x + image->perLensUnit.x * lensPoint.x,
                   image->position.y + image->perLensUnit.y * lensPoint.y};
    const float reach = filter_.radius();
    const int width = camera_.imageWidth(), height = camera_.imageHeight();
    if (!(at.x > -reach && at.x < float(width) + reach && at.y > -reach &&
          at.y < float(height) + reach))
      return rays;
    // The camera ray through that image position and lens point must see this very point first,
    // and it is shaded as that camera ray shades it (textures filtered over its footprint).
    const Ray cameraRay = camera_.generateRay(at.x, at.y, lensSample, time);
    const float pointDistance = length(hit->position - cameraRay.origin);
    ++rays;
    const std::optional<SurfaceHit> seen =
        intersectSurface(scene_, cameraRay, RayKind::Camera, camera_.pixelCone());
    if (!seen || seen->matte || seen->meshId != hit->meshId || seen->instance != hit->instance ||
        std::abs(seen->distance - pointDistance) > 1e-3f * pointDistance + 1e-4f ||
        takeover_.isCaster(seen->materialIndex) || !receivesCaustics(seen->material()))
      return rays;
    const Vec3f towardsCamera = -cameraRay.direction;
    // The path tracer's estimate there: f(towards camera, towards light) |n_s · towards light|.
    const Vec3f f =
        bsdfAt(*seen, towardsCamera, spectrum, beta).evaluate(towardsCamera, towardsLight);
    const float cosArrival = std::abs(dot(towardsLight, seen->normal));
    if (isBlack(f) || !(cosArrival > 0)) return rays;
    // Image area (pixels) per solid angle at the lens point: 1 / (s² cos³θ), s² the solid angle
    // of a pixel on the axis (the film at unit distance).
    const float cosAxis = -camera_.toCameraSpace(cameraRay.direction, time).z;
    const float pixelWidth = camera_.filmWidth() / (moment.focalLength * float(width));
    const float pixelHeight = camera_.filmHeight() / (moment.focalLength * float(height));
    const float imagePerSolidAngle = 1 / (pixelWidth * pixelHeight * cosAxis * cosAxis * cosAxis);
    const Vec3f carried = beta * f *
                          (std::abs(dot(towardsCamera, seen->normal)) /
                           (cosArrival * pointDistance * pointDistance) * imagePerSolidAngle);
    const Vec3f arriving =
        spectrum.spectral ? spectralToRgb(carried, spectrum.wavelengths) : carried;
    if (!std::isfinite(arriving.x + arriving.y + arriving.z) || !(cosAxis > 0)) return rays;
    // Shared among the pixels whose filter reaches it, as camera samples draw their offsets.
    const int left = std::max(0, int(std::floor(at.x - reach)));
    const int right = std::min(width - 1, int(std::floor(at.x + reach)));
    const int top = std::max(0, int(std::floor(at.y - reach)));
    const int bottom = std::min(height - 1, int(std::floor(at.y + reach)));
    for (int y = top; y <= bottom; ++y) {
      const float weightY = filter_.density1D(at.y - (float(y) + 0.5f));
      if (!(weightY > 0)) continue;
      for (int x = left; x <= right; ++x) {
        const float weight = weightY * filter_.density1D(at.x - (float(x) + 0.5f));
        if (weight > 0) splats.push_back({x, y, arriving * weight});
      }
    }
    return rays;
  }
}

}  // namespace penumbra
