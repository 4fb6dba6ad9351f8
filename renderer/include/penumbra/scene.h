// The scene the tracer sees: triangle meshes as Embree instances (one BVH per mesh, placed by
// one instance of its own, so that a transform edit does not rebuild geometry, and by any number
// of instancer copies sharing that BVH), materials and lights. Plain data only; no USD.
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
  int lightIndex = -1;                       // the mesh light this surface is (UsdLuxMeshLightAPI)
  bool closed = false;                       // the mesh bounds a solid
};

/// Camera rays do not see the back faces of single-sided meshes (doubleSided = 0), as in
/// Storm; other rays see both sides, so that a single-sided wall still blocks light.
enum class RayKind { Camera, Secondary };

class Scene {
 public:
  using MeshId = uint32_t;
  using InstancerId = uint32_t;
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

  /// Makes the mesh the emitting surface of light `lightIndex` (a LightType::Mesh light), or
  /// not (-1): its front side then shows the light's radiance.
  void setMeshLight(MeshId id, int lightIndex);

  /// Copies of a mesh (its geometry and material), one per transform, sharing its BVH: memory
  /// grows with the number of copies, not with their triangles. The mesh itself need not be
  /// visible (a prototype). Replaces the instancer's previous copies.
  InstancerId addInstancer();
  void setInstances(InstancerId id, MeshId prototype, std::vector<MotionTransform> transforms,
                    bool visible);
  void removeInstancer(InstancerId id);

  /// Materials are referenced by index; a material whose opacity is below a non-zero
  /// opacityThreshold cuts its meshes out entirely (opacity has no texture yet).
  void setMaterials(std::vector<MaterialParams> materials) { materials_ = std::move(materials); }
  void setLights(std::vector<Light> lights) { lights_ = std::move(lights); }
  const std::vector<Light>& lights() const { return lights_; }
  /// Lights are chosen for next-event estimation in proportion to their power (set by commit()).
  const Distribution1D& lightSelection() const { return lightSelection_; }

  /// Rebuilds the top-level BVH; call after edits and before tracing.
  void commit();
  /// True when a material disperses light (abbeNumber > 0 on a translucent material): paths
  /// are then traced spectrally (set by commit()).
  bool spectral() const { return spectral_; }

  std::optional<SurfaceHit> intersect(const Ray& ray, RayKind kind) const;
  /// True if anything blocks the segment [tNear, tFar] of the ray.
  bool occluded(const Ray& ray) const;
  /// Offset for spawning rays from `point` so that they do not re-hit its surface.
  float rayEpsilon(const Vec3f& point) const;

 private:
  /// One Embree instance geometry: a placement of a mesh's BVH.
  struct Placement {
    RTCGeometry geometry = nullptr;
    unsigned geomId = 0;
    MeshId mesh = 0;
    MotionTransform objectToWorld;
  };
  struct MeshRecord {
    RTCScene bvh = nullptr;
    std::shared_ptr<const TriangleMesh> data;
    int materialIndex = kNoMaterial;
    int lightIndex = -1;
    bool visible = true;
    std::unique_ptr<Placement> own;
    std::vector<InstancerId> instancers;  // those placing copies of this mesh
  };
  struct InstancerRecord {
    MeshId prototype = 0;
    bool visible = true;
    std::vector<std::unique_ptr<Placement>> copies;
  };

  MeshRecord& record(MeshId id);
  InstancerRecord& instancer(InstancerId id);
  std::unique_ptr<Placement> newPlacement(MeshId mesh);
  void releasePlacement(std::unique_ptr<Placement>& placement);
  /// Pushes a placement's BVH, transform and enabled state to Embree.
  void updatePlacement(Placement& placement, bool enabled);
  /// Whether copies of a mesh render: it has geometry and its material does not cut it out.
  bool renderable(const MeshRecord& mesh) const;
  void updateAllPlacements(MeshId id);

  RTCDevice device_;
  RTCScene top_;
  std::vector<std::unique_ptr<MeshRecord>> meshes_;           // by MeshId
  std::vector<std::unique_ptr<InstancerRecord>> instancers_;  // by InstancerId
  std::vector<const Placement*> placements_;                  // by Embree geomID
  std::vector<MaterialParams> materials_;
  std::vector<Light> lights_;
  Distribution1D lightSelection_{{}};
  float sceneExtent_ = 1;
  bool spectral_ = false;
};

}  // namespace penumbra
