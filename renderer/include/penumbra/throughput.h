// Embree's raw speed on a scene: single rays through its BVH with no shading, sampling or
// lights, the ceiling against which the path tracer's rays per second are compared.
#pragma once

#include <cstdint>

#include "penumbra/camera.h"
#include "penumbra/scene.h"

namespace penumbra {

struct RawRayThroughput {
  double primary = 0;          // camera rays (one per pixel), rtcIntersect1, rays per second
  double bounceIntersect = 0;  // cosine-distributed rays from the camera rays' hits
  double bounceOccluded = 0;   // the same rays, rtcOccluded1
  uint64_t bounceRays = 0;     // how many camera rays hit something
};

/// Times each kind of ray over the image (best of `repeats`) on `threads` threads (0: all).
RawRayThroughput measureRawThroughput(const Scene& scene, const Camera& camera, int width,
                                      int height, int threads, int repeats = 3);

}  // namespace penumbra
