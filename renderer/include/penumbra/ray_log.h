// The rays a render's paths trace through the scene's BVH (IntegratorSettings::rayLog), kept so
// that Embree alone can be timed on exactly those rays (measureRawThroughput): the path tracer's
// cost per ray against Embree's on the same rays, not on rays made up to resemble them.
#pragma once

#include <tbb/enumerable_thread_specific.h>

#include <vector>

#include "penumbra/camera.h"
#include "penumbra/geometry.h"

namespace penumbra {

struct LoggedRay {
  Ray ray;
  RayKind kind = RayKind::Camera;  // of an intersection ray
  bool shadow = false;             // a shadow ray (occlusion query), else an intersection ray
  int shadowLinkSlot = -1;         // a shadow ray's light's (Geometry::occluded)
};

/// Appended to from any number of threads (IntegratorSettings::rayLog).
class RayLog {
 public:
  void add(const LoggedRay& ray) { perThread_.local().push_back(ray); }
  /// Every ray logged, each thread's in the order it traced them.
  std::vector<LoggedRay> rays() const {
    std::vector<LoggedRay> all;
    for (const std::vector<LoggedRay>& own : perThread_)
      all.insert(all.end(), own.begin(), own.end());
    return all;
  }

 private:
  tbb::enumerable_thread_specific<std::vector<LoggedRay>> perThread_;
};

}  // namespace penumbra
