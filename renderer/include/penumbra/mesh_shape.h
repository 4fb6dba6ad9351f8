// Triangle meshes (polygon meshes triangulated, and subdivision surfaces diced to triangles) as
// a kind of geometry.
#pragma once

#include "penumbra/mesh.h"
#include "penumbra/shape.h"

namespace penumbra {

class MeshShape final : public Shape {
 public:
  explicit MeshShape(TriangleMesh mesh) : mesh_(std::move(mesh)) {}

  RTCGeometry newEmbreeGeometry(RTCDevice device) const override;
  bool tracesAs(const Shape& other) const override;
  bool doubleSided() const override { return mesh_.doubleSided; }
  const TriangleMesh& triangles() const { return mesh_; }
  SurfacePoint pointAt(uint32_t triangle, float u, float v, float time) const override;
  SurfaceGeometry surfaceAt(uint32_t triangle, float u, float v, float time,
                            const Vec3f& geometricNormal,
                            const Transform& objectToWorld) const override;
  int primvarWidth(const PrimvarName& name) const override;
  bool primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                 int* width) const override;
  bool cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                         Vec2f st[3]) const override;
  int elementOf(uint32_t triangle) const override;

 private:
  TriangleMesh mesh_;
};

}  // namespace penumbra
