// The scene the tracer sees: triangle meshes as Embree instances (one BVH per mesh, one instance
// each, so that a transform edit does not rebuild geometry), materials and lights. Plain data
// only; no USD.
#pragma once

#include <embree3/rtcore.h>

#include <memory>
#include <optional>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/light.h"
#include "penumbra/material.h"
#include "penumbra/mesh.h"
#include "penumbra/motion.h"

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

/// A ray's first intersection with a mesh.
struct SurfaceHit {
  float distance = 0;
  Vec3f position;
  Vec3f normal;         // unit geometric normal on the authored front side
  Vec3f shadingNormal;  // unit, interpolated where the mesh has normals, on the same side
  Vec3f albedo;         // diffuseColor, or displayColor without a material
  Vec3f emission;       // emitted radiance
  const MaterialParams* material = nullptr;  // null: displayColor, Lambertian
  bool closed = false;                       // the mesh bounds a solid
};

/// Camera rays do not see the back faces of single-sided meshes (doubleSided = 0), as in
/// Storm; other rays see both sides, so that a single-sided wall still blocks light.
enum class RayKind { Camera, Secondary };

class Scene {
 public:
  using MeshId = uint32_t;
  /// Material index meaning "none bound": displayColor is the albedo.
  static constexpr int kNoMaterial = -1;

  explicit Scene(const Device& device);
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  MeshId addMesh();
  void removeMesh(MeshId id);
  /// Replaces the mesh's geometry and rebuilds its BVH.
  void setMeshGeometry(MeshId id, TriangleMesh mesh);
  /// Drops the mesh's geometry (it stays registered but renders nothing).
  void clearMeshGeometry(MeshId id);
  /// Places the mesh; an animated transform gives Embree multi-segment instance motion.
  void setMeshInstance(MeshId id, const MotionTransform& objectToWorld, int materialIndex,
                       bool visible);

  /// Materials are referenced by index; a material whose opacity is below a non-zero
  /// opacityThreshold cuts its meshes out entirely (opacity has no texture yet).
  void setMaterials(std::vector<MaterialParams> materials) { materials_ = std::move(materials); }
  void setLights(std::vector<Light> lights) { lights_ = std::move(lights); }
  const std::vector<Light>& lights() const { return lights_; }
  /// Lights are chosen for next-event estimation in proportion to their power (set by commit()).
  const Distribution1D& lightSelection() const { return lightSelection_; }

  /// Rebuilds the top-level BVH; call after edits and before tracing.
  void commit();

  std::optional<SurfaceHit> intersect(const Ray& ray, RayKind kind) const;
  /// True if anything blocks the segment [tNear, tFar] of the ray.
  bool occluded(const Ray& ray) const;
  /// Offset for spawning rays from `point` so that they do not re-hit its surface.
  float rayEpsilon(const Vec3f& point) const;

 private:
  struct MeshRecord {
    RTCScene bvh = nullptr;
    RTCGeometry instance = nullptr;
    std::shared_ptr<const TriangleMesh> data;
    MotionTransform objectToWorld;
    int materialIndex = kNoMaterial;
    bool visible = true;
  };
  void updateInstance(MeshRecord& record);
  void releaseGeometry(MeshRecord& record);

  RTCDevice device_;
  RTCScene top_;
  MeshRecord& record(MeshId id);

  std::vector<std::unique_ptr<MeshRecord>> meshes_;  // indexed by the instance's Embree geomID
  std::vector<MaterialParams> materials_;
  std::vector<Light> lights_;
  Distribution1D lightSelection_{{}};
  float sceneExtent_ = 1;
};

}  // namespace penumbra
