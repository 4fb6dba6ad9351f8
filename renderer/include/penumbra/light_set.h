// The scene's lights: their list in sampling order, the light sampler chosen from it, the
// infinite lights that escaping rays meet, the Embree BVH through which rays meet the area
// lights, and which meshes are the emitting surfaces of mesh lights.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include "penumbra/embree.h"
#include "penumbra/light.h"
#include "penumbra/light_sampler.h"

namespace penumbra {

class LightSet {
 public:
  explicit LightSet(const Device& device);
  ~LightSet();
  LightSet(const LightSet&) = delete;
  LightSet& operator=(const LightSet&) = delete;

  /// The lights, in the order they are sampled in (their order decides which sample numbers
  /// each light draws: keep it stable). The light sampler is rebuilt at commit().
  void setLights(std::vector<Light> lights) {
    lights_ = std::move(lights);
    changed_ = true;
  }
  /// Replaces light `index` alone (a parameter edit), the others kept as they are. Throws
  /// std::out_of_range for an index past the end.
  void setLight(size_t index, Light light);
  /// Moves the lights out (to be put back, reordered, by setLights before the next render).
  std::vector<Light> releaseLights() {
    changed_ = true;
    return std::exchange(lights_, {});
  }
  const std::vector<Light>& all() const { return lights_; }
  /// Chooses lights for next-event estimation (set by commit()).
  const LightSampler& lightSampler() const { return lightSampler_; }
  /// Indices of the dome and distant lights, which rays that escape the scene meet.
  const std::vector<uint32_t>& infiniteLights() const { return infiniteLights_; }
  /// Whether some light's diffuse and specular multipliers differ (as of commit()).
  bool lobeMultipliersDiffer() const { return lobeMultipliersDiffer_; }

  /// Makes mesh `mesh` (Geometry::MeshId) the emitting surface of light `lightIndex` (a
  /// LightType::Mesh light), or not (-1): its front side then shows the light's radiance.
  void setMeshLight(uint32_t mesh, int lightIndex);
  /// The light whose emitting surface mesh `mesh` is, -1: none (or none of that index now).
  int meshLight(uint32_t mesh) const {
    const int index = mesh < meshLights_.size() ? meshLights_[mesh] : -1;
    return index >= 0 && size_t(index) < lights_.size() ? index : -1;
  }

  /// How forEachLightHit reaches its visitor through Embree's callbacks.
  using LightHitCallback = void (*)(const void* visitor, uint32_t index, const LightHit& hit);
  /// Calls visit(lightIndex, LightHit) for each area light (rect, disk, sphere, cylinder) whose
  /// emitting surface the ray meets before `tMax`, found through an Embree BVH of the lights
  /// (when there are several).
  /// Mesh lights are met as geometry instead (meshLight).
  template <class Visit>
  void forEachLightHit(const Ray& ray, float tMax, Visit&& visit) const {
    if (areaLights_.size() == 1) {
      // Embree's BVH of one primitive is a leaf, whose bounds it does not test: it would call
      // intersectLight for every ray, with these very values. Calling the light directly meets
      // it alike without the traversal's cost (every ray of the scene asks).
      const uint32_t index = areaLights_.front();
      if (const std::optional<LightHit> hit =
              lights_[index].intersect(ray.origin, ray.direction, tMax))
        visit(index, *hit);
      return;
    }
    visitLightHits(
        ray, tMax,
        [](const void* visitor, uint32_t index, const LightHit& hit) {
          (*static_cast<const std::remove_reference_t<Visit>*>(visitor))(index, hit);
        },
        &visit);
  }

  /// Rebuilds the light sampler and the lights' BVH if the lights changed since the last one.
  void commit();

 private:
  void visitLightHits(const Ray& ray, float tMax, LightHitCallback callback,
                      const void* visitor) const;
  /// Rebuilds the BVH of the area lights (lightScene_) from lights_, if there are two or more.
  void buildLightScene();
  /// Embree callbacks of the light BVH's user geometry (user data: the light set).
  static void boundLight(const RTCBoundsFunctionArguments* args);
  static void intersectLight(const RTCIntersectFunctionNArguments* args);

  RTCDevice device_;
  std::vector<Light> lights_;
  LightSampler lightSampler_;
  std::vector<uint32_t> infiniteLights_;
  bool lobeMultipliersDiffer_ = false;
  RTCScene lightScene_ = nullptr;
  std::vector<uint32_t> areaLights_;  // light index of each primitive of lightScene_ (or of the
                                      // one area light, which has no lightScene_)
  std::vector<int> meshLights_;       // by mesh: the light it emits for, -1: none
  bool changed_ = true;               // since the last commit()
};

}  // namespace penumbra
