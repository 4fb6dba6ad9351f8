#include "penumbra/subsurface.h"

#include <algorithm>
#include <cmath>

#include "penumbra/phase.h"

namespace penumbra {
namespace {

/// Scattering events before Russian roulette may end a walk.
constexpr int kRouletteStart = 8;

Vec3f transmittance(const Vec3f& extinction, float distance) {
  return {std::exp(-extinction.x * distance), std::exp(-extinction.y * distance),
          std::exp(-extinction.z * distance)};
}

}  // namespace

float subsurfaceSingleScatteringAlbedo(float multipleScatteringAlbedo) {
  const float a = std::clamp(multipleScatteringAlbedo, 0.0f, 1.0f);
  const float root = std::sqrt(9.59217f + 41.6808f * a + 17.7126f * a * a);
  const float difference = 4.09712f + 4.20863f * a - root;
  return std::clamp(1 - difference * difference, 0.0f, 1.0f);
}

SubsurfaceMedium subsurfaceMedium(const MaterialParams& material) {
  SubsurfaceMedium medium;
  const float g = std::isfinite(material.subsurfaceAnisotropy)
                      ? std::clamp(material.subsurfaceAnisotropy, -kMaxSubsurfaceAnisotropy,
                                   kMaxSubsurfaceAnisotropy)
                      : 0.0f;
  medium.anisotropy = g;
  const auto channel = [g](float color, float radius, float* extinction, float* albedo) {
    // The inversion gives the similarity-reduced albedo α' = α (1 − g) / (1 − α g) and radius
    // the reduced mean free path 1 / (σt (1 − α g)); both solved here for α and σt.
    const float reduced = subsurfaceSingleScatteringAlbedo(std::isfinite(color) ? color : 0.0f);
    *albedo = reduced / (1 - g + reduced * g);
    const float meanFreePath = std::isnan(radius)
                                   ? kMinSubsurfaceRadius
                                   : std::clamp(radius, kMinSubsurfaceRadius, kMaxSubsurfaceRadius);
    *extinction = 1 / (meanFreePath * (1 - *albedo * g));
  };
  const Vec3f& color = material.subsurfaceColor;
  const Vec3f& radius = material.subsurfaceRadius;
  channel(color.x, radius.x, &medium.extinction.x, &medium.albedo.x);
  channel(color.y, radius.y, &medium.extinction.y, &medium.albedo.y);
  channel(color.z, radius.z, &medium.extinction.z, &medium.albedo.z);
  return medium;
}

std::optional<SubsurfaceExit> subsurfaceRandomWalk(const Scene& scene, const SurfaceHit& entry,
                                                   const Vec3f& inwardDirection,
                                                   const SubsurfaceMedium& medium,
                                                   RandomStream& random, float time) {
  const Vec3f inwardNormal = dot(inwardDirection, entry.normal) < 0 ? -entry.normal : entry.normal;
  Ray ray;
  ray.origin = entry.position + inwardNormal * scene.rayEpsilon(entry.position);
  ray.direction = normalize(inwardDirection);
  ray.time = time;
  const Vec3f scattering = medium.albedo * medium.extinction;
  const HenyeyGreenstein phase(medium.anisotropy);
  Vec3f throughput{1.0f};
  for (int events = 0;; ++events) {
    const std::optional<GeometryHit> wall = scene.geometry().intersect(ray, RayKind::Secondary);
    const float boundary = wall ? wall->distance : kInfinity;
    // A channel in proportion to the throughput, and a free flight in its extinction.
    const float total = throughput.x + throughput.y + throughput.z;
    if (!(total > 0)) return std::nullopt;
    const Vec3f probability = throughput * (1 / total);
    const float uChannel = random.next();
    const int chosen = uChannel < probability.x                   ? 0
                       : uChannel < probability.x + probability.y ? 1
                                                                  : 2;
    const float flight = -std::log(1 - random.next()) / medium.extinction[chosen];
    if (flight >= boundary) {
      if (!wall) return std::nullopt;
      // Passing the whole segment: each channel's transmittance over the mixture's
      // probability of flying that far.
      const Vec3f survival = transmittance(medium.extinction, boundary);
      const float density = dot(probability, survival);
      if (!(density > 0)) return std::nullopt;  // underflow, for flights of e^−87 odds
      throughput *= survival * (1 / density);
      std::optional<SurfaceHit> exit = intersectSurface(scene, ray, RayKind::Secondary);
      if (!exit) return std::nullopt;  // cannot happen: the same ray met `wall`
      SubsurfaceExit result{std::move(*exit), ray.direction, throughput, true};
      result.sameObject =
          result.hit.meshId == entry.meshId && result.hit.instance == entry.instance;
      // Its own surface met from outside: rounding put a scattering event within float
      // precision of the surface on its far side and the walk leaked; it counts as absorbed.
      const bool outwards =
          (dot(ray.direction, result.hit.normal) > 0) == (dot(inwardDirection, entry.normal) < 0);
      if (result.sameObject && !outwards) return std::nullopt;
      return result;
    }
    if (events >= kMaxSubsurfaceSteps) return std::nullopt;
    // Scattering at `flight`: σs T over the mixture's density of stopping there.
    const Vec3f survival = transmittance(medium.extinction, flight);
    const float density = dot(probability, medium.extinction * survival);
    if (!(density > 0)) return std::nullopt;
    throughput *= scattering * survival * (1 / density);
    if (events >= kRouletteStart) {
      const float keep = maxComponent(throughput);
      if (keep < 1) {
        if (random.next() >= keep) return std::nullopt;
        throughput *= 1 / keep;
      }
    }
    ray.origin = ray.origin + ray.direction * flight;
    ray.direction = phase.sample(ray.direction, random.next2D());
  }
}

Vec3f transmissionAbsorption(const MaterialParams& material) {
  const float depth = material.transmissionDepth;
  if (!(depth > 0) || !std::isfinite(depth)) return Vec3f(0.0f);
  const auto absorption = [depth](float color) {
    return -std::log(std::clamp(std::isfinite(color) ? color : 1.0f, 1e-6f, 1.0f)) / depth;
  };
  const Vec3f& color = material.transmissionColor;
  return {absorption(color.x), absorption(color.y), absorption(color.z)};
}

}  // namespace penumbra
