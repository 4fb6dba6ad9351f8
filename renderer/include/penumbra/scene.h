// The scene the tracer sees, composed of four parts: the geometry rays meet (geometry.h), the
// lights (light_set.h), the materials with their textures (material_table.h) and the volumes
// (volume_set.h). The scene holds them together, and does what involves more than one of them.
// Plain data only; no USD.
#pragma once

#include <string>

#include "penumbra/embree.h"
#include "penumbra/geometry.h"
#include "penumbra/light_set.h"
#include "penumbra/material_table.h"
#include "penumbra/volume_set.h"

namespace penumbra {

class Scene {
 public:
  /// `colorConfig`: the OCIO config that linearises textures (empty: $OCIO).
  explicit Scene(const Device& device, const std::string& colorConfig = {});
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  Geometry& geometry() { return geometry_; }
  const Geometry& geometry() const { return geometry_; }
  LightSet& lights() { return lights_; }
  const LightSet& lights() const { return lights_; }
  MaterialTable& materials() { return materials_; }
  const MaterialTable& materials() const { return materials_; }
  VolumeSet& volumes() { return volumes_; }
  const VolumeSet& volumes() const { return volumes_; }

  /// Sets the material at `index` (MaterialTable::replace); the meshes using it follow its
  /// cut-outs (Geometry::followMaterial). An index no mesh uses any longer is given a default
  /// Material, which disperses no light.
  void setMaterial(size_t index, Material material);

  /// Builds what edits left to build: the top-level BVH, the light sampler and the lights' BVH
  /// if lights changed, the spectral switch. Call after edits and before tracing.
  void commit();
  /// Seconds spent building acceleration structures so far: meshes' BVHs, the top-level BVH,
  /// the light tree and the lights' BVH.
  double bvhBuildSeconds() const { return geometry_.meshBvhBuildSeconds() + commitSeconds_; }

  /// Offset for spawning rays from `point` so that they do not re-hit its surface.
  float rayEpsilon(const Vec3f& point) const {
    // Relative to the coordinates' magnitude (float rounding of the hit point and of the
    // instance transform), with a floor tied to the scene's size so that it works in any unit.
    return 2e-5f * std::max(maxAbsComponent(point), 1e-2f * geometry_.extent());
  }

 private:
  MaterialTable materials_;  // before geometry_, which refers to it
  Geometry geometry_;
  LightSet lights_;
  VolumeSet volumes_;
  double commitSeconds_ = 0;  // in commit(), building the BVHs and the light sampler
};

}  // namespace penumbra
