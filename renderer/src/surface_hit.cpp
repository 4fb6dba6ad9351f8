#include "penumbra/surface_hit.h"

#include "penumbra/shading.h"

namespace penumbra {

namespace {

/// The surface of `found`, the hit of `ray`. Every return returns `shaded`, so the compiler
/// builds it in the caller's storage, which intersectSurface hands on as it is: a SurfaceHit is
/// some 400 bytes, copied at every hit otherwise.
std::optional<SurfaceHit> shadeHit(const Scene& scene, const Ray& ray, RayKind kind,
                                   const RayCone& cone, const GeometryHit& found) {
  const MaterialTable& materials = scene.materials();
  const Material* material = materials.find(found.materialIndex);
  // A material that does not vary is read from the table, not copied into the hit.
  std::optional<SurfaceHit> shaded =
      material && !material->varies()
          ? std::optional<SurfaceHit>(std::in_place, materials.shadedConstants(found.materialIndex))
          : std::optional<SurfaceHit>(std::in_place);
  SurfaceHit& hit = *shaded;
  hit.distance = found.distance;
  hit.position = ray.origin + ray.direction * hit.distance;
  if (kind == RayKind::Camera && found.pass.matte) {
    hit.matte = true;
    return shaded;
  }
  const Transform objectToWorld = found.objectToWorld->at(ray.time);
  SurfaceGeometry surface = found.shape->surfaceAt(found.primitive, found.u, found.v, ray.time,
                                                   found.geometricNormal, objectToWorld);
  SurfacePoint& point = surface.point;
  if (surface.objectPosition) {
    hit.position = objectToWorld.applyToPoint(*surface.objectPosition);
  } else if (surface.objectPlanePoint) {
    const Vec3f onPlane = objectToWorld.applyToPoint(*surface.objectPlanePoint);
    hit.position = hit.position - surface.normal * dot(hit.position - onPlane, surface.normal);
  }
  hit.normal = surface.normal;
  hit.shadingNormal = surface.shadingNormal;
  hit.closed = surface.closed;
  hit.fibreDirection = surface.fibreDirection;
  attachCopyPrimvars(point, found.instancePrimvars, uint32_t(found.instance));
  hit.meshId = found.meshId;
  hit.instance = found.instance;
  hit.linkingClass = found.linkingClass;
  hit.shape = point.shape;
  hit.primitive = point.primitive;
  hit.u = point.u;
  hit.v = point.v;
  hit.instancePrimvars = point.instancePrimvars;
  hit.materialIndex = found.materialIndex;
  hit.faceSlot = found.faceSlot;
  if (material) {
    const bool anisotropic = material->mayBeAnisotropic();
    if (material->varies() || anisotropic) {
      // Texture footprints and tangent frames need the primitive in world space.
      for (Vec3f& corner : point.corners) corner = objectToWorld.applyToPoint(corner);
    }
    if (material->varies()) {
      point.normal = hit.normal;
      point.shadingNormal = hit.shadingNormal;
      footprintOnSurface(ray.direction, hit.normal, cone.radiusAt(hit.distance), &point.dpdx,
                         &point.dpdy);
      // The table's constants have the opacity threshold applied; evaluated ones need it.
      applyOpacityThreshold(hit.setMaterial(
          evaluateMaterial(*material, materials.textures(), point, &hit.shadingNormal)));
    }
    // A fibre's tangent is its direction (its corners, all one point, span no surface).
    if (anisotropic)
      hit.tangent = length(surface.fibreDirection) > 0 ? surface.fibreDirection
                                                       : surfaceTangent(point, objectToWorld);
    if (hit.material().thinWalled) hit.closed = !*hit.material().thinWalled;
  } else {
    MaterialParams& fallback = hit.setMaterial(fallbackSurface());
    float value[4];
    int width = 0;
    // Built once: looked up on every hit of a mesh without a material.
    static const PrimvarName displayOpacity("displayOpacity");
    if (primvarAt(point, displayColorName(), value, &width) && width >= 3)
      fallback.diffuseColor = {value[0], value[1], value[2]};
    if (primvarAt(point, displayOpacity, value, &width)) fallback.opacity = value[0];
  }
  hit.emission = hit.material().emissiveColor;
  // A network's value (a texture scaled by NaN, a primvar holding one) is read as the BSDF
  // reads its inputs: NaN as nothing, rather than a NaN pixel.
  if (!isFinite(hit.emission)) hit.emission = Vec3f(0.0f);
  const LightSet& lights = scene.lights();
  // A mesh light emits from its front alone; its back glows (or not) by its material, as any
  // surface: no light's multipliers, weights or takeover apply there.
  if (const int lightIndex = lights.meshLight(found.meshId);
      lightIndex >= 0 && dot(ray.direction, hit.normal) < 0) {
    hit.lightIndex = lightIndex;
    // Shaped as next-event estimation sees it.
    hit.emission = lights.all()[size_t(lightIndex)].radianceLeaving(Vec3f(1.0f), -ray.direction);
  }
  return shaded;
}

}  // namespace

std::optional<SurfaceHit> intersectSurface(const Scene& scene, const Ray& ray, RayKind kind,
                                           const RayCone& cone) {
  const std::optional<GeometryHit> found = scene.geometry().intersect(ray, kind);
  if (!found) return std::nullopt;
  return shadeHit(scene, ray, kind, cone, *found);
}

}  // namespace penumbra
