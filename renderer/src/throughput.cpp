#include "penumbra/throughput.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "on_threads.h"
#include "penumbra/filter.h"
#include "penumbra/ray_log.h"
#include "penumbra/sampler.h"
#include "penumbra/warp.h"

namespace penumbra {
namespace {

/// Rays per second of `trace` over `rays`, best of `repeats` runs.
template <class RayType, class Trace>
double raysPerSecond(const std::vector<RayType>& rays, int threads, int repeats, Trace trace) {
  double best = 0;
  for (int run = 0; run < repeats; ++run) {
    const auto started = std::chrono::steady_clock::now();
    onThreads(threads, [&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 256),
                        [&](const tbb::blocked_range<size_t>& range) {
                          for (size_t i = range.begin(); i < range.end(); ++i) trace(rays[i]);
                        });
    });
    const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - started;
    best = std::max(best, double(rays.size()) / elapsed.count());
  }
  return best;
}

}  // namespace

RawRayThroughput measureRawThroughput(const Scene& scene, const Camera& camera, int width,
                                      int height, int threads, int repeats,
                                      const IntegratorSettings* pathSettings) {
  std::vector<Ray> primary;
  primary.reserve(size_t(width) * size_t(height));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      primary.push_back(
          camera.generateRay(float(x) + 0.5f, float(y) + 0.5f, Vec2f{0.5f, 0.5f}, 0.5f));
  RawRayThroughput result;
  result.primary = raysPerSecond(primary, threads, repeats, [&](const Ray& ray) {
    return scene.geometry().hitDistance(ray, RayKind::Camera);
  });
  // Bounce rays leave each hit towards the side the camera ray came from, cosine-distributed.
  std::vector<Ray> bounces;
  for (size_t i = 0; i < primary.size(); ++i) {
    const float distance = scene.geometry().hitDistance(primary[i], RayKind::Camera);
    if (!std::isfinite(distance)) continue;
    Ray bounce;
    const Vec3f back = -primary[i].direction;
    bounce.origin = primary[i].origin + primary[i].direction * distance;
    bounce.origin = bounce.origin + back * scene.rayEpsilon(bounce.origin);
    bounce.direction = normalize(
        Frame(back).toWorld(sampleCosineHemisphere(SampleStream(0, uint32_t(i), 0, 0).next2D())));
    bounce.tNear = 0;
    bounce.tFar = kInfinity;
    bounce.time = 0.5f;
    bounces.push_back(bounce);
  }
  result.bounceRays = bounces.size();
  if (!bounces.empty()) {
    result.bounceIntersect = raysPerSecond(bounces, threads, repeats, [&](const Ray& ray) {
      return scene.geometry().hitDistance(ray, RayKind::Secondary);
    });
    result.bounceOccluded = raysPerSecond(
        bounces, threads, repeats, [&](const Ray& ray) { return scene.geometry().occluded(ray); });
  }
  if (pathSettings) {
    // Every pixel's sample 0, or every stride-th pixel's each way in larger images: the log
    // (about 50 bytes a ray) stays within some tens of megabytes.
    const int stride = std::max(
        1, int(std::ceil(std::sqrt(double(width) * double(height) / double(kMaxLoggedPixels)))));
    const int columns = (width + stride - 1) / stride, rows = (height + stride - 1) / stride;
    RayLog log;
    IntegratorSettings logging = *pathSettings;
    logging.rayLog = &log;
    const PixelFilter filter;
    onThreads(threads, [&] {
      tbb::parallel_for(0, rows, [&](int row) {
        for (int column = 0; column < columns; ++column)
          renderCameraSample(scene, camera, filter, column * stride, row * stride, 0, logging);
      });
    });
    const std::vector<LoggedRay> pathRays = log.rays();
    result.pathRayCount = pathRays.size();
    if (!pathRays.empty())
      result.pathRays = raysPerSecond(pathRays, threads, repeats, [&](const LoggedRay& logged) {
        return logged.shadow ? scene.geometry().occluded(logged.ray, logged.shadowLinkSlot)
                             : scene.geometry().hitDistance(logged.ray, logged.kind) < kInfinity;
      });
  }
  return result;
}

}  // namespace penumbra
