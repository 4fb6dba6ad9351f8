// Embree's raw speed on a scene: single rays through its BVH with no shading, sampling or
// lights, the ceiling against which the path tracer's rays per second are compared.
#pragma once

#include <cstdint>

#include "penumbra/camera.h"
#include "penumbra/integrator.h"
#include "penumbra/scene.h"

namespace penumbra {

struct RawRayThroughput {
  double primary = 0;          // camera rays (one per pixel), rtcIntersect1, rays per second
  double bounceIntersect = 0;  // cosine-distributed rays from the camera rays' hits
  double bounceOccluded = 0;   // the same rays, rtcOccluded1
  uint64_t bounceRays = 0;     // how many camera rays hit something
  /// The path tracer's own rays: those sample 0 of each pixel traces (its paths' rays and their
  /// shadow rays, RayLog), each as it was traced (intersect or occluded, its kind's mask).
  double pathRays = 0;
  uint64_t pathRayCount = 0;
};

/// Images of more pixels log the rays of every k-th pixel each way (k the smallest stride that
/// leaves at most this many).
constexpr int kMaxLoggedPixels = 1 << 16;

/// Times each kind of ray over the image (best of `repeats`) on `threads` threads (0: all).
/// With `pathSettings`, also the rays that sample 0 of each pixel (up to kMaxLoggedPixels)
/// traces with those settings.
RawRayThroughput measureRawThroughput(const Scene& scene, const Camera& camera, int width,
                                      int height, int threads, int repeats = 3,
                                      const IntegratorSettings* pathSettings = nullptr);

}  // namespace penumbra
