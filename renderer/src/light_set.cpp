#include "penumbra/light_set.h"

#include <optional>
#include <stdexcept>
#include <string>

namespace penumbra {
namespace {

/// What an intersect call on the light BVH carries: the ray's limit and where hits go.
struct LightTraceContext {
  RTCIntersectContext embree;  // first member: Embree passes a pointer to it to the callbacks
  float tMax;
  LightSet::LightHitCallback callback;
  const void* visitor;
};

}  // namespace

LightSet::LightSet(const Device& device) : device_(device.get()) {
  rtcRetainDevice(device_);
}

LightSet::~LightSet() {
  if (lightScene_) rtcReleaseScene(lightScene_);
  rtcReleaseDevice(device_);
}

void LightSet::setLight(size_t index, Light light) {
  if (index >= lights_.size())
    throw std::out_of_range("light index " + std::to_string(index) + " past the " +
                            std::to_string(lights_.size()) + " lights");
  lights_[index] = std::move(light);
  changed_ = true;
}

void LightSet::setMeshLight(uint32_t mesh, int lightIndex) {
  if (mesh >= meshLights_.size()) meshLights_.resize(size_t(mesh) + 1, -1);
  meshLights_[mesh] = lightIndex;
}

void LightSet::commit() {
  if (!changed_) return;
  lightSampler_ = LightSampler(lights_);
  infiniteLights_.clear();
  lobeMultipliersDiffer_ = false;
  for (size_t i = 0; i < lights_.size(); ++i) {
    if (lights_[i].isInfinite()) infiniteLights_.push_back(uint32_t(i));
    if (lights_[i].diffuseMultiplier() != lights_[i].specularMultiplier())
      lobeMultipliersDiffer_ = true;
  }
  buildLightScene();
  changed_ = false;
}

void LightSet::boundLight(const RTCBoundsFunctionArguments* args) {
  const auto* set = static_cast<const LightSet*>(args->geometryUserPtr);
  const LightBounds bounds = set->lights_[set->areaLights_[args->primID]].bounds();
  *args->bounds_o = {bounds.lower.x, bounds.lower.y, bounds.lower.z, 0,
                     bounds.upper.x, bounds.upper.y, bounds.upper.z, 0};
}

void LightSet::intersectLight(const RTCIntersectFunctionNArguments* args) {
  // Every light met is reported and no hit is accepted, so that traversal goes on to the lights
  // behind it: overlapping emitters all contribute.
  if (args->valid[0] != -1) return;
  const auto* set = static_cast<const LightSet*>(args->geometryUserPtr);
  const auto* context = reinterpret_cast<const LightTraceContext*>(args->context);
  const uint32_t index = set->areaLights_[args->primID];
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
  const Vec3f origin{RTCRayN_org_x(ray, args->N, 0), RTCRayN_org_y(ray, args->N, 0),
                     RTCRayN_org_z(ray, args->N, 0)};
  const Vec3f direction{RTCRayN_dir_x(ray, args->N, 0), RTCRayN_dir_y(ray, args->N, 0),
                        RTCRayN_dir_z(ray, args->N, 0)};
  if (const std::optional<LightHit> hit =
          set->lights_[index].intersect(origin, direction, context->tMax))
    context->callback(context->visitor, index, *hit);
}

void LightSet::buildLightScene() {
  if (lightScene_) rtcReleaseScene(lightScene_);
  lightScene_ = nullptr;
  areaLights_.clear();
  for (size_t i = 0; i < lights_.size(); ++i) {
    const Light& light = lights_[i];
    if (light.isAreaLight()) areaLights_.push_back(uint32_t(i));
  }
  if (areaLights_.size() < 2) return;  // one light is met without a BVH (forEachLightHit)
  lightScene_ = rtcNewScene(device_);
  RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(geometry, unsigned(areaLights_.size()));
  rtcSetGeometryUserData(geometry, this);
  rtcSetGeometryBoundsFunction(geometry, boundLight, nullptr);
  rtcSetGeometryIntersectFunction(geometry, intersectLight);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(lightScene_, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(lightScene_);
  throwOnEmbreeError(device_, "build the light BVH");
}

void LightSet::visitLightHits(const Ray& ray, float tMax, LightHitCallback callback,
                              const void* visitor) const {
  if (!lightScene_) return;
  LightTraceContext context;
  rtcInitIntersectContext(&context.embree);
  context.tMax = tMax;
  context.callback = callback;
  context.visitor = visitor;
  RTCRayHit rayHit;
  rayHit.ray = toEmbreeRay(ray);
  rayHit.ray.tnear = 0;
  rayHit.ray.tfar = tMax;
  rayHit.ray.time = 0;  // lights keep their transform at the frame
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(lightScene_, &context.embree, &rayHit);
}

}  // namespace penumbra
