#include "penumbra/embree.h"

#include <stdexcept>
#include <string>

namespace penumbra {

Device::Device() : device_(rtcNewDevice(nullptr)) {
  if (!device_) throw std::runtime_error("Embree could not create a device");
}

Device::~Device() {
  rtcReleaseDevice(device_);
}

void throwOnEmbreeError(RTCDevice device, const char* what) {
  const RTCError error = rtcGetDeviceError(device);
  if (error != RTC_ERROR_NONE)
    throw std::runtime_error(std::string("Embree failed to ") + what + " (error " +
                             std::to_string(int(error)) + ")");
}

RTCRay toEmbreeRay(const Ray& ray) {
  RTCRay r;
  r.org_x = ray.origin.x;
  r.org_y = ray.origin.y;
  r.org_z = ray.origin.z;
  r.dir_x = ray.direction.x;
  r.dir_y = ray.direction.y;
  r.dir_z = ray.direction.z;
  r.tnear = ray.tNear;
  r.tfar = ray.tFar;
  r.time = ray.time;
  r.mask = 0xffffffffu;
  r.id = 0;
  r.flags = 0;
  return r;
}

}  // namespace penumbra
