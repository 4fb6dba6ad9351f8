// Points (UsdGeomPoints) as a kind of geometry: spheres, or discs where normals are authored.
#pragma once

#include "penumbra/points.h"
#include "penumbra/shape.h"

namespace penumbra {

/// Spheres of radius width/2 (solids), or discs of that radius facing their normals (thin). A
/// point has no surface parametrisation: textures are point-sampled at its primvars' values,
/// which are constant over it.
class PointsShape final : public Shape {
 public:
  /// `points` must be valid (validatePoints).
  explicit PointsShape(PointsData points) : points_(std::move(points)) {}

  RTCGeometry newEmbreeGeometry(RTCDevice device) const override;
  bool tracesAs(const Shape& other) const override;
  /// Both sides of a disc show; a sphere's back is seen only from inside.
  bool doubleSided() const override { return true; }
  SurfacePoint pointAt(uint32_t point, float u, float v, float time) const override;
  SurfaceGeometry surfaceAt(uint32_t point, float u, float v, float time,
                            const Vec3f& geometricNormal,
                            const Transform& objectToWorld) const override;
  int primvarWidth(const PrimvarName& name) const override;
  bool primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                 int* width) const override;
  bool cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                         Vec2f st[3]) const override;
  int elementOf(uint32_t point) const override { return int(point); }

 private:
  /// The value of `primvar` (constant, or one per point) at point `index`.
  const float* valueAt(const Primvar& primvar, uint32_t index) const;

  PointsData points_;
};

}  // namespace penumbra
