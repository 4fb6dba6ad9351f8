#include <algorithm>

#include "penumbra/geometry.h"

namespace penumbra {
namespace {

/// Whether the ray's segment [tnear, tfar] meets the box, slightly widened against rounding.
bool segmentMeetsBox(const RTCRay& ray, const Vec3f& lower, const Vec3f& upper) {
  const float pad = 1e-4f * std::max({maxAbsComponent(lower), maxAbsComponent(upper), 1.0f});
  const float origin[3] = {ray.org_x, ray.org_y, ray.org_z};
  const float direction[3] = {ray.dir_x, ray.dir_y, ray.dir_z};
  float tNear = ray.tnear, tFar = ray.tfar;
  for (int axis = 0; axis < 3; ++axis) {
    const float low = lower[axis] - pad, high = upper[axis] + pad;
    if (direction[axis] == 0) {
      if (origin[axis] < low || origin[axis] > high) return false;
      continue;
    }
    float t0 = (low - origin[axis]) / direction[axis], t1 = (high - origin[axis]) / direction[axis];
    if (t0 > t1) std::swap(t0, t1);
    tNear = std::max(tNear, t0);
    tFar = std::min(tFar, t1);
    if (tNear > tFar) return false;
  }
  return true;
}

}  // namespace

/// An intersect context that tells the hit filters whether the ray comes from the camera, where
/// the materials are, and, in the overlay, whose placements its instances are.
struct Geometry::TraceContext {
  RTCIntersectContext embree;  // first member: Embree passes a pointer to it to the filters
  bool cameraRay;
  const Geometry* geometry;
  const std::vector<uint32_t>* overlayIds = nullptr;  // while tracing the overlay
  int shadowLinkSlot = -1;  // a shadow ray's light, when its shadow link excludes something

  /// For a trace of `traced`'s top_ (skipping overlaid placements' stale instances there).
  TraceContext(const Geometry& traced, RayKind kind)
      : cameraRay(kind == RayKind::Camera), geometry(&traced) {
    rtcInitIntersectContext(&embree);
    if (traced.overlaid_) embree.filter = skipPlacements;
  }

  /// The top_ geomID of the placement of an instance met in the BVH being traced.
  uint32_t placementId(uint32_t instanceGeomId) const {
    return overlayIds ? (*overlayIds)[instanceGeomId] : instanceGeomId;
  }
};

void Geometry::filterHits(const RTCFilterFunctionNArguments* args) {
  const auto* context = reinterpret_cast<const TraceContext*>(args->context);
  const auto* mesh = static_cast<const MeshRecord*>(args->geometryUserPtr);
  const MaterialTable& materials = context->geometry->materials_;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    // Camera rays do not see the back faces of single-sided meshes. Embree's geometric normal
    // is (v1-v0)×(v2-v0) in object space, which faces the viewer for counter-clockwise (front)
    // triangles; the ray is in the same object space here, so the test holds under any
    // instance transform.
    if (context->cameraRay && !mesh->doubleSided) {
      const float facing =
          RTCRayN_dir_x(args->ray, args->N, i) * RTCHitN_Ng_x(args->hit, args->N, i) +
          RTCRayN_dir_y(args->ray, args->N, i) * RTCHitN_Ng_y(args->hit, args->N, i) +
          RTCRayN_dir_z(args->ray, args->N, i) * RTCHitN_Ng_z(args->hit, args->N, i);
      if (facing > 0) {
        args->valid[i] = 0;
        continue;
      }
    }
    if (!mesh->cutoutFilter) continue;
    const uint32_t primitive = RTCHitN_primID(args->hit, args->N, i);
    const Material* material = materials.find(materialOf(*mesh, faceSlotOf(*mesh, primitive)));
    if (!material || material->constants.opacityThreshold <= 0) continue;
    SurfacePoint point =
        mesh->shape->pointAt(primitive, RTCHitN_u(args->hit, args->N, i),
                             RTCHitN_v(args->hit, args->N, i), RTCRayN_time(args->ray, args->N, i));
    const Placement& placement =
        *context->geometry
             ->placements_[context->placementId(RTCHitN_instID(args->hit, args->N, i, 0))];
    attachCopyPrimvars(point, copyPrimvars(placement), placement.copy);
    if (evaluateOpacity(*material, materials.textures(), point) <
        material->constants.opacityThreshold)
      args->valid[i] = 0;
  }
}

const std::vector<Primvar>* Geometry::copyPrimvars(const Placement& placement) {
  return placement.instancer && !placement.instancer->primvars.empty()
             ? &placement.instancer->primvars
             : nullptr;
}

RTCRayHit Geometry::trace(const Ray& ray, RayKind kind) const {
  TraceContext context(*this, kind);
  RTCRayHit rayHit;
  rayHit.ray = toEmbreeRay(ray);
  rayHit.ray.mask = ray_mask::ofRay(kind);
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayHit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(top_, &context.embree, &rayHit);
  if (overlaid_) traceOverlay(context, rayHit);
  return rayHit;
}

bool Geometry::mayHitOverlay(const RTCRay& ray) const {
  return segmentMeetsBox(ray, overlayBounds_.lower, overlayBounds_.upper);
}

void Geometry::traceOverlay(TraceContext& context, RTCRayHit& rayHit) const {
  if (!mayHitOverlay(rayHit.ray)) return;
  context.embree.filter = nullptr;
  context.overlayIds = &overlayIds_;
  // tfar is the nearest hit so far: Embree writes a hit only for a nearer one.
  const RTCHit nearest = rayHit.hit;
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(overlay_, &context.embree, &rayHit);
  if (rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID)
    rayHit.hit = nearest;
  else
    rayHit.hit.instID[0] = overlayIds_[rayHit.hit.instID[0]];
}

void Geometry::skipPlacements(const RTCFilterFunctionNArguments* args) {
  const auto* context = reinterpret_cast<const TraceContext*>(args->context);
  const Geometry& geometry = *context->geometry;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const uint32_t placementId = context->placementId(RTCHitN_instID(args->hit, args->N, i, 0));
    if ((!context->overlayIds && geometry.staleInTop_[placementId]) ||
        (context->shadowLinkSlot >= 0 &&
         geometry.linking_.shadowExcluded(geometry.placements_[placementId]->linkingClass,
                                          context->shadowLinkSlot)))
      args->valid[i] = 0;
  }
}

float Geometry::hitDistance(const Ray& ray, RayKind kind) const {
  const RTCRayHit rayHit = trace(ray, kind);
  return rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID ? kInfinity : rayHit.ray.tfar;
}

std::optional<GeometryHit> Geometry::intersect(const Ray& ray, RayKind kind) const {
  const RTCRayHit rayHit = trace(ray, kind);
  if (rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  const Placement& placement = *placements_[rayHit.hit.instID[0]];
  const MeshRecord& mesh = *meshes_[placement.mesh];
  GeometryHit hit;
  hit.distance = rayHit.ray.tfar;
  hit.meshId = placement.mesh;
  hit.instance = placement.instancer ? int(placement.copy) : -1;
  hit.primitive = rayHit.hit.primID;
  hit.u = rayHit.hit.u;
  hit.v = rayHit.hit.v;
  hit.geometricNormal = {rayHit.hit.Ng_x, rayHit.hit.Ng_y, rayHit.hit.Ng_z};
  hit.shape = mesh.shape.get();
  hit.objectToWorld = &placement.objectToWorld;
  hit.faceSlot = faceSlotOf(mesh, rayHit.hit.primID);
  hit.materialIndex = materialOf(mesh, hit.faceSlot);
  hit.pass = passOf(placement);
  hit.instancePrimvars = copyPrimvars(placement);
  hit.linkingClass = placement.linkingClass;
  return hit;
}

bool Geometry::occluded(const Ray& ray, int linkSlot) const {
  TraceContext context(*this, RayKind::Secondary);
  // Only the shadow rays of a light whose shadow link excludes something are filtered.
  const bool shadowLinked = linking_.shadowLinked(linkSlot);
  if (shadowLinked) {
    context.shadowLinkSlot = linkSlot;
    context.embree.filter = skipPlacements;
  }
  RTCRay r = toEmbreeRay(ray);
  r.mask = ray_mask::kShadow;
  rtcOccluded1(top_, &context.embree, &r);
  if (r.tfar >= 0 && overlaid_ && mayHitOverlay(r)) {
    context.embree.filter = shadowLinked ? skipPlacements : nullptr;
    context.overlayIds = &overlayIds_;
    rtcOccluded1(overlay_, &context.embree, &r);
  }
  return r.tfar < 0;  // Embree sets tfar to -inf when occluded
}

}  // namespace penumbra
