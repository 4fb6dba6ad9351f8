// One kind of geometry (triangle meshes, points, curves; later volume bounds) behind the small
// interface that the geometry aggregate (geometry.h) and shading need of it: its Embree geometry,
// and the surface at a hit on it. Everything else (BVHs, placements, instancer copies, the
// overlay, hit filters) is the aggregate's and the same for every kind, so that a new kind is a
// new implementation of Shape rather than edits across the aggregate.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>
#include <optional>

#include "penumbra/math.h"
#include "penumbra/mesh.h"
#include "penumbra/shading.h"

namespace penumbra {

/// What a kind of geometry says of a point of its surface.
struct SurfaceGeometry {
  Vec3f normal;         // unit geometric normal on the authored front side, in world space
  Vec3f shadingNormal;  // unit, interpolated where the kind has normals, on the same side
  /// Primvar access at the point (shading.h), its corners in object space.
  SurfacePoint point;
  bool closed = false;  // the geometry bounds a solid
  /// For fibres (curves): the unit direction of the curve there, in world space, which fibre
  /// BSDFs need; zero for surfaces.
  Vec3f fibreDirection{0.0f};
  /// The point in object space, rebuilt from the primitive where the kind can (a triangle's
  /// corners weighed by the barycentrics; a sphere's or a tube's centre and radius along Ng),
  /// so that its rounding follows the point's coordinates and not the ray's length: a ray from
  /// far away would otherwise place it on either side of the surface by more than the spawn
  /// offset (shadow acne under a telephoto camera). Unset where the kind cannot: the hit is
  /// then the ray's origin plus its distance along it, moved onto objectPlanePoint's plane.
  std::optional<Vec3f> objectPosition;
  /// Where the kind knows a point of the plane tangent to the surface at the hit but not the
  /// hit itself (a disc's centre; a ribbon's centre line at u, which lies in the ribbon's
  /// tangent plane at every v): the ray's point is moved onto that plane along `normal`,
  /// which removes its error across the surface (the one that causes acne) and keeps the
  /// small one along it, in object space.
  std::optional<Vec3f> objectPlanePoint;
};

/// The geometry of one object, in object space, immutable once built.
class Shape {
 public:
  virtual ~Shape() = default;

  /// A new Embree geometry of it (every motion step), not yet committed, for a BVH of its own;
  /// null when it has nothing to trace. Throws std::runtime_error when Embree cannot allocate it.
  virtual RTCGeometry newEmbreeGeometry(RTCDevice device) const = 0;
  /// Whether `other` is traced exactly as this one is (same kind, same primitives at the same
  /// points, bit for bit), so that the BVH built from this one serves it: an edit of shading
  /// data alone.
  virtual bool tracesAs(const Shape& other) const = 0;
  /// Whether camera rays see its back faces (Embree's geometric normal facing away from them);
  /// the aggregate's hit filter culls them otherwise.
  virtual bool doubleSided() const = 0;

  /// Primvar access at the hit Embree reports on `primitive` at (u, v), at normalised shutter
  /// time `time`; corners in object space. Cheap enough for hit filters.
  virtual SurfacePoint pointAt(uint32_t primitive, float u, float v, float time) const = 0;
  /// The surface there, its normals placed in the world by `objectToWorld` (the placement's
  /// transform at `time`); `geometricNormal` is Embree's Ng there (object space, unnormalised).
  virtual SurfaceGeometry surfaceAt(uint32_t primitive, float u, float v, float time,
                                    const Vec3f& geometricNormal,
                                    const Transform& objectToWorld) const = 0;
  /// The widest value of primvar `name` it has (0: none).
  virtual int primvarWidth(const PrimvarName& name) const = 0;
  /// Its own primvar `name` (displayColor included) at `point` (one of its points): writes up
  /// to 4 floats and their count; false when it has none.
  virtual bool primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                         int* width) const = 0;
  /// The first two components of its primvar `name` (of width 2 or more: texture coordinates)
  /// at the corners of `point`'s primitive, which `point`'s weights interpolate; false when it
  /// has no such primvar.
  virtual bool cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                                 Vec2f st[3]) const = 0;
  /// The authored element (a mesh's face, a point) that `primitive` is part of; -1: none.
  virtual int elementOf(uint32_t primitive) const = 0;
};

}  // namespace penumbra
