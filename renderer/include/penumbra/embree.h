// The Embree device, and what the modules that trace through Embree (geometry, lights) share.
#pragma once

#include <embree3/rtcore.h>

#include "penumbra/camera.h"

namespace penumbra {

/// Owns the Embree device: the one piece of process-wide state the renderer has.
class Device {
 public:
  Device();
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;
  RTCDevice get() const { return device_; }

 private:
  RTCDevice device_;
};

/// Throws std::runtime_error saying what Embree failed to do, if the device reports an error.
void throwOnEmbreeError(RTCDevice device, const char* what);

/// The ray as Embree takes it, every mask bit set.
RTCRay toEmbreeRay(const Ray& ray);

}  // namespace penumbra
