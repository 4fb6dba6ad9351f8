#include "penumbra/integrator.h"

#include "penumbra/sampler.h"

namespace penumbra {
namespace {

/// Emission from the lights a ray meets before `tMax` (area lights) or, if it escapes, from the
/// infinite ones, weighted against the BSDF sampling that produced it (`bsdfPdf` <= 0: the ray
/// was not BSDF-sampled, so it takes the full emission).
Vec3f emittedAlongRay(const Scene& scene, const Ray& ray, float tMax, bool escaped, float bsdfPdf,
                      float* nearestLight) {
  const std::vector<Light>& lights = scene.lights();
  Vec3f total{0.0f};
  float nearest = kInfinity;
  for (size_t i = 0; i < lights.size(); ++i) {
    const Light& light = lights[i];
    std::optional<LightHit> hit;
    if (light.isInfinite()) {
      if (escaped) hit = light.escaped(ray.direction);
    } else {
      hit = light.intersect(ray.origin, ray.direction, tMax);
    }
    if (!hit) continue;
    // Light surfaces may overlap; each contributes, and the nearest defines depth and alpha.
    nearest = std::min(nearest, hit->distance);
    const float lightPdf = scene.lightSelection().probability(i) * hit->pdf;
    const float weight = bsdfPdf > 0 ? powerHeuristic(bsdfPdf, lightPdf) : 1.0f;
    // Camera rays see lights as they are; reflected light is scaled by the lobe multiplier.
    const float multiplier = bsdfPdf > 0 ? light.diffuseMultiplier() : 1.0f;
    total += hit->radiance * (weight * multiplier);
  }
  if (nearestLight) *nearestLight = nearest;
  return total;
}

/// Spawns a ray from a surface point towards `direction`, offset off the surface on that side.
Ray spawnRay(const Scene& scene, const SurfaceHit& hit, const Vec3f& direction, float tFar,
             float time) {
  const float side = dot(direction, hit.normal) >= 0 ? 1.0f : -1.0f;
  Ray ray;
  ray.origin = hit.position + hit.normal * (side * scene.rayEpsilon(hit.position));
  ray.direction = direction;
  ray.tNear = 0;
  ray.tFar = tFar;
  ray.time = time;
  return ray;
}

}  // namespace

CameraSample renderCameraSample(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                                int x, int y, uint32_t sampleIndex,
                                const IntegratorSettings& settings) {
  SampleStream sampler(settings.seed, uint32_t(x), uint32_t(y), sampleIndex);
  const Vec2f filterOffset = filter.sampleOffset(sampler.next2D());
  const Vec2f lensSample = sampler.next2D();
  const float shutterTime = sampler.next1D();
  Ray ray = camera.generateRay(float(x) + 0.5f + filterOffset.x, float(y) + 0.5f + filterOffset.y,
                               lensSample, shutterTime);

  CameraSample result;
  Vec3f throughput{1.0f};
  float bsdfPdf = 0;  // density of the direction that produced `ray`; 0 for the camera ray
  const std::vector<Light>& lights = scene.lights();

  for (int bounce = 0;; ++bounce) {
    const std::optional<SurfaceHit> hit =
        scene.intersect(ray, bounce == 0 ? RayKind::Camera : RayKind::Secondary);
    float nearestLight = kInfinity;
    result.radiance += throughput * emittedAlongRay(scene, ray, hit ? hit->distance : ray.tFar,
                                                    !hit, bsdfPdf, &nearestLight);
    if (bounce == 0) {
      const float firstHit = std::min(hit ? hit->distance : kInfinity, nearestLight);
      if (firstHit < kInfinity) {
        result.alpha = 1;
        result.depth = camera.viewDepth(ray, firstHit);
      }
    }
    if (!hit) break;
    // Surfaces shade on the side the ray arrives from.
    const Vec3f wo = -ray.direction;
    const Vec3f normal = dot(wo, hit->normal) >= 0 ? hit->normal : -hit->normal;
    result.radiance += throughput * hit->emission;
    if (bounce >= settings.maxPathDepth) break;
    const Vec3f bsdf = hit->albedo * kInvPi;  // Lambertian

    // Next-event estimation: one light, chosen by power, sampled over its area/solid angle.
    const float lightChoice = sampler.next1D();
    const Vec2f lightSample = sampler.next2D();
    if (!lights.empty()) {
      const size_t index = scene.lightSelection().sampleIndex(lightChoice);
      const Light& light = lights[index];
      const std::optional<LightSample> sample = light.sample(hit->position, lightSample);
      const float cosine = sample ? dot(sample->direction, normal) : 0.0f;
      if (sample && sample->pdf > 0 && cosine > 0) {
        const float tFar =
            std::isfinite(sample->distance) ? sample->distance * (1 - 1e-4f) : kInfinity;
        if (!light.castsShadows() ||
            !scene.occluded(spawnRay(scene, *hit, sample->direction, tFar, ray.time))) {
          const float lightPdf = scene.lightSelection().probability(index) * sample->pdf;
          const float weight = sample->isDelta ? 1.0f : powerHeuristic(lightPdf, cosine * kInvPi);
          result.radiance += throughput * bsdf * sample->radiance *
                             (cosine * weight * light.diffuseMultiplier() / lightPdf);
        }
      }
    }

    // BSDF sampling: cosine-weighted, so f·cos/pdf is the albedo.
    const Vec3f local = sampleCosineHemisphere(sampler.next2D());
    const Vec3f direction = normalize(Frame(normal).toWorld(local));
    bsdfPdf = local.z * kInvPi;
    if (!(bsdfPdf > 0)) break;
    throughput *= hit->albedo;
    // Russian roulette once paths are long enough to be dim; survivors are reweighted.
    const float rouletteSample = sampler.next1D();
    if (bounce >= 3) {
      const float survival = std::min(0.95f, maxComponent(throughput));
      if (rouletteSample >= survival) break;
      throughput *= 1 / survival;
    }
    if (isBlack(throughput)) break;
    ray = spawnRay(scene, *hit, direction, kInfinity, ray.time);
  }
  return result;
}

}  // namespace penumbra
