#include "penumbra/mesh_shape.h"

#include <algorithm>
#include <stdexcept>

#include "penumbra/embree.h"
#include "same_bits.h"

namespace penumbra {
namespace {

/// Whether two meshes have the same triangles at the same points (bit for bit) at every step.
bool sameSurface(const TriangleMesh& a, const TriangleMesh& b) {
  return sameBits(a.triangles, b.triangles) && sameBits(a.points, b.points) &&
         sameBits(a.pointMotion, b.pointMotion);
}

}  // namespace

RTCGeometry MeshShape::newEmbreeGeometry(RTCDevice device) const {
  if (mesh_.triangles.empty()) return nullptr;
  RTCGeometry triangles = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  const unsigned stepCount = unsigned(mesh_.pointMotion.size() + 1);
  rtcSetGeometryTimeStepCount(triangles, stepCount);
  bool allocated = true;
  for (unsigned step = 0; step < stepCount; ++step) {
    const std::vector<Vec3f>& points = step == 0 ? mesh_.points : mesh_.pointMotion[step - 1];
    auto* vertices = static_cast<Vec3f*>(rtcSetNewGeometryBuffer(
        triangles, RTC_BUFFER_TYPE_VERTEX, step, RTC_FORMAT_FLOAT3, sizeof(Vec3f), points.size()));
    if (vertices)
      std::copy(points.begin(), points.end(), vertices);
    else
      allocated = false;
  }
  auto* indices = static_cast<uint32_t*>(
      rtcSetNewGeometryBuffer(triangles, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(uint32_t), mesh_.triangles.size() / 3));
  if (!allocated || !indices) {
    rtcReleaseGeometry(triangles);
    throwOnEmbreeError(device, "allocate mesh buffers");
    throw std::runtime_error("Embree could not allocate mesh buffers");
  }
  std::copy(mesh_.triangles.begin(), mesh_.triangles.end(), indices);
  return triangles;
}

bool MeshShape::tracesAs(const Shape& other) const {
  const auto* mesh = dynamic_cast<const MeshShape*>(&other);
  return mesh && sameSurface(mesh_, mesh->mesh_);
}

SurfacePoint MeshShape::pointAt(uint32_t triangle, float u, float v, float time) const {
  SurfacePoint point;
  point.shape = this;
  point.primitive = triangle;
  point.u = u;
  point.v = v;
  for (int corner = 0; corner < 3; ++corner)
    point.corners[corner] = mesh_.cornerAt(triangle, corner, time);
  return point;
}

SurfaceGeometry MeshShape::surfaceAt(uint32_t triangle, float u, float v, float time,
                                     const Vec3f& /*geometricNormal: from the corners, exactly*/,
                                     const Transform& objectToWorld) const {
  SurfaceGeometry surface;
  surface.point = pointAt(triangle, u, v, time);
  const Vec3f* corners = surface.point.corners;
  const Transform::NormalMatrix normalToWorld = objectToWorld.normalMatrix();
  surface.normal =
      normalize(normalToWorld.apply(cross(corners[1] - corners[0], corners[2] - corners[0])));
  surface.shadingNormal = surface.normal;
  surface.objectPosition = corners[0] * (1 - u - v) + corners[1] * u + corners[2] * v;
  if (!mesh_.normals.empty()) {
    const Vec3f interpolated = normalToWorld.apply(
        mesh_.interpolate(mesh_.normals, mesh_.normalsInterpolation, triangle, u, v));
    // A shading normal on the other side than the surface would turn shading inside out.
    if (length(interpolated) > 0 && dot(interpolated, surface.normal) > 0)
      surface.shadingNormal = normalize(interpolated);
  }
  surface.closed = mesh_.closed;
  return surface;
}

int MeshShape::primvarWidth(const PrimvarName& name) const {
  if (const Primvar* primvar = mesh_.findPrimvar(name)) return primvar->width;
  if (name == displayColorName() && !mesh_.displayColor.empty()) return 3;
  return 0;
}

bool MeshShape::primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                          int* width) const {
  if (const Primvar* primvar = mesh_.findPrimvar(name)) {
    mesh_.interpolate(*primvar, point.primitive, point.u, point.v, value);
    *width = primvar->width;
    return true;
  }
  if (name == displayColorName() && !mesh_.displayColor.empty()) {
    const Vec3f color = mesh_.interpolate(mesh_.displayColor, mesh_.displayColorInterpolation,
                                          point.primitive, point.u, point.v);
    value[0] = color.x, value[1] = color.y, value[2] = color.z;
    *width = 3;
    return true;
  }
  return false;
}

bool MeshShape::cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                                  Vec2f st[3]) const {
  const Primvar* primvar = mesh_.findPrimvar(name);
  if (!primvar || primvar->width < 2) return false;
  for (int corner = 0; corner < 3; ++corner) {
    const size_t element = mesh_.cornerElement(primvar->interpolation, point.primitive, corner);
    const float* value = &primvar->values[element * size_t(primvar->width)];
    st[corner] = {value[0], value[1]};
  }
  return true;
}

int MeshShape::elementOf(uint32_t triangle) const {
  return triangle < mesh_.sourceFace.size() ? int(mesh_.sourceFace[triangle]) : -1;
}

}  // namespace penumbra
