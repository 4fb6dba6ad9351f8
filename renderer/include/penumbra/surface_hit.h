// Shading a hit: the geometry's raw first hit (geometry.h) made a surface the integrator can
// scatter from, with the bound material evaluated there (textures, primvar readers, normal
// map), or displayColor and displayOpacity where none is bound, and a mesh light's emission.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/material.h"
#include "penumbra/mesh.h"
#include "penumbra/scene.h"

namespace penumbra {

/// A ray's first intersection with a surface, shaded.
struct SurfaceHit {
  /// With parameters of its own, MaterialParams' defaults until set (setMaterial()).
  SurfaceHit() : evaluated_(std::in_place) {}
  /// With a material that does not vary: its parameters are read where they lie, in the scene's
  /// material table (`constants` must outlive the hit), not copied (some 300 bytes, at every hit).
  explicit SurfaceHit(const MaterialParams& constants) : constants_(&constants) {}

  /// The bound material's parameters evaluated here (textures, primvar readers, normal map), or
  /// fallbackSurface() with displayColor and displayOpacity for meshes without one.
  const MaterialParams& material() const { return evaluated_ ? *evaluated_ : *constants_; }
  /// Gives the hit parameters of its own (evaluated here), in place of the material's
  /// constants; returns them, to adjust.
  MaterialParams& setMaterial(MaterialParams params) {
    return evaluated_.emplace(std::move(params));
  }

  float distance = 0;
  Vec3f position;
  Vec3f normal;         // unit geometric normal on the authored front side
  Vec3f shadingNormal;  // unit, interpolated where the shape has normals, on the same side
  Vec3f emission;       // emitted radiance
  /// Where the material may be anisotropic: the surface's tangent (surfaceTangent); else zero.
  Vec3f tangent{0.0f};
  /// On a fibre (a curve): its unit direction (SurfaceGeometry::fibreDirection); else zero.
  Vec3f fibreDirection{0.0f};
  int materialIndex = MaterialTable::kNoMaterial;  // the bound material's, in scene.materials()
  uint32_t faceSlot = 0;  // the per-face binding the face takes (GeometryHit::faceSlot)
  int lightIndex = -1;    // the mesh light (UsdLuxMeshLightAPI) whose emitting front this is
  bool closed = false;    // a solid: the mesh bounds one, or its material is not thin-walled
  bool matte = false;     // a holdout (PassVisibility::matte): only distance and position are set
  // Which surface this is, for AOVs and primvar lookups (as in SurfacePoint).
  uint32_t meshId = 0;
  int instance = -1;  // the instancer copy hit, -1: the object's own placement
  const Shape* shape = nullptr;
  uint32_t primitive = 0;
  float u = 0, v = 0;
  const std::vector<Primvar>* instancePrimvars = nullptr;
  uint32_t linkingClass = 0;  // its placement's (GeometryHit::linkingClass)

 private:
  const MaterialParams* constants_ = nullptr;  // read where the hit has none of its own
  std::optional<MaterialParams> evaluated_;
};

/// The first hit of the ray in `scene`, shaded: textures are filtered over `cone`'s
/// cross-section there.
std::optional<SurfaceHit> intersectSurface(const Scene& scene, const Ray& ray, RayKind kind,
                                           const RayCone& cone = {});

/// Spawns a ray from a surface point towards `direction`, offset off the surface on that side.
/// A fibre scattering by the hair BSDF into itself is passed through: that BSDF accounts for the
/// whole passage through the fibre (Chiang et al.'s TT and TRT lobes), so the ray starts where
/// it leaves the fibre's far wall (the object's first hit from inside), instead of scattering
/// there a second time (or, for a shadow ray, being blocked by it).
inline Ray spawnRay(const Scene& scene, const SurfaceHit& hit, const Vec3f& direction, float tFar,
                    float time) {
  const float side = dot(direction, hit.normal) >= 0 ? 1.0f : -1.0f;
  Ray ray;
  ray.origin = hit.position + hit.normal * (side * scene.rayEpsilon(hit.position));
  ray.direction = direction;
  ray.tNear = 0;
  ray.tFar = tFar;
  ray.time = time;
  const bool intoFibre =
      side < 0 && hit.material().hair && hit.closed && length(hit.fibreDirection) > 0;
  if (!intoFibre) return ray;
  const std::optional<GeometryHit> wall = scene.geometry().intersect(ray, RayKind::Secondary);
  if (!wall || wall->meshId != hit.meshId || wall->instance != hit.instance) return ray;
  const Vec3f outward =
      normalize(wall->objectToWorld->at(time).applyToNormal(wall->geometricNormal));
  if (dot(outward, direction) <= 0) return ray;  // not the wall from inside
  const Vec3f exit = ray.origin + direction * wall->distance;
  ray.origin = exit + outward * scene.rayEpsilon(exit);
  ray.tFar = tFar - wall->distance;
  return ray;
}

}  // namespace penumbra
