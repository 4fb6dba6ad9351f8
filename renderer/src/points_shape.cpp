#include "penumbra/points_shape.h"

#include <stdexcept>

#include "penumbra/embree.h"
#include "penumbra/motion.h"
#include "same_bits.h"

namespace penumbra {
namespace {

/// Whether two sets of points are the same spheres or discs (bit for bit) at every step.
bool sameSurface(const PointsData& a, const PointsData& b) {
  return sameBits(a.positions, b.positions) && sameBits(a.widths, b.widths) &&
         sameBits(a.normals, b.normals) && sameBits(a.positionMotion, b.positionMotion);
}

}  // namespace

RTCGeometry PointsShape::newEmbreeGeometry(RTCDevice device) const {
  if (points_.positions.empty()) return nullptr;
  const bool discs = !points_.normals.empty();
  RTCGeometry geometry = rtcNewGeometry(
      device, discs ? RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT : RTC_GEOMETRY_TYPE_SPHERE_POINT);
  const unsigned stepCount = unsigned(points_.positionMotion.size() + 1);
  rtcSetGeometryTimeStepCount(geometry, stepCount);
  const size_t count = points_.positions.size();
  bool allocated = true;
  for (unsigned step = 0; step < stepCount; ++step) {
    const std::vector<Vec3f>& positions =
        step == 0 ? points_.positions : points_.positionMotion[step - 1];
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, step, RTC_FORMAT_FLOAT4, 4 * sizeof(float), count));
    if (vertices) {
      for (size_t i = 0; i < count; ++i) {
        vertices[4 * i] = positions[i].x;
        vertices[4 * i + 1] = positions[i].y;
        vertices[4 * i + 2] = positions[i].z;
        vertices[4 * i + 3] = points_.widths[i] / 2;
      }
    } else {
      allocated = false;
    }
    if (!discs) continue;
    // Embree wants the discs' normals at every step; they do not move.
    auto* normals = static_cast<Vec3f*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_NORMAL, step, RTC_FORMAT_FLOAT3, sizeof(Vec3f), count));
    if (normals)
      std::copy(points_.normals.begin(), points_.normals.end(), normals);
    else
      allocated = false;
  }
  if (!allocated) {
    rtcReleaseGeometry(geometry);
    throwOnEmbreeError(device, "allocate points buffers");
    throw std::runtime_error("Embree could not allocate points buffers");
  }
  return geometry;
}

bool PointsShape::tracesAs(const Shape& other) const {
  const auto* points = dynamic_cast<const PointsShape*>(&other);
  return points && sameSurface(points_, points->points_);
}

SurfacePoint PointsShape::pointAt(uint32_t point, float, float, float time) const {
  // Weights (1, 0, 0) on three equal corners: values constant over the point, no differentials.
  SurfacePoint result;
  result.shape = this;
  result.primitive = point;
  const Vec3f centre = pointAtTime(points_.positions, points_.positionMotion, point, time);
  for (Vec3f& corner : result.corners) corner = centre;
  return result;
}

SurfaceGeometry PointsShape::surfaceAt(uint32_t point, float u, float v, float time,
                                       const Vec3f& geometricNormal,
                                       const Transform& objectToWorld) const {
  SurfaceGeometry surface;
  surface.point = pointAt(point, u, v, time);
  // Embree's Ng: a sphere's hit minus its centre, a disc's authored normal.
  surface.normal = normalize(objectToWorld.applyToNormal(geometricNormal));
  surface.shadingNormal = surface.normal;
  surface.closed = points_.normals.empty();
  if (length(geometricNormal) > 0) {
    if (surface.closed)
      surface.objectPosition =
          surface.point.corners[0] + normalize(geometricNormal) * (points_.widths[point] / 2);
    else
      surface.objectPlanePoint = surface.point.corners[0];  // a disc lies in its centre's plane
  }
  return surface;
}

const float* PointsShape::valueAt(const Primvar& primvar, uint32_t index) const {
  const size_t element = primvar.interpolation == Interpolation::Constant ? 0 : index;
  return &primvar.values[element * size_t(primvar.width)];
}

int PointsShape::primvarWidth(const PrimvarName& name) const {
  if (const Primvar* primvar = findPrimvar(points_.primvars, name)) return primvar->width;
  if (name == displayColorName() && !points_.displayColor.empty()) return 3;
  return 0;
}

bool PointsShape::primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                            int* width) const {
  if (const Primvar* primvar = findPrimvar(points_.primvars, name)) {
    const float* own = valueAt(*primvar, point.primitive);
    std::copy(own, own + primvar->width, value);
    *width = primvar->width;
    return true;
  }
  if (name == displayColorName() && !points_.displayColor.empty()) {
    const Vec3f& color =
        points_.displayColor[points_.displayColorInterpolation == Interpolation::Constant
                                 ? 0
                                 : point.primitive];
    value[0] = color.x, value[1] = color.y, value[2] = color.z;
    *width = 3;
    return true;
  }
  return false;
}

bool PointsShape::cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                                    Vec2f st[3]) const {
  const Primvar* primvar = findPrimvar(points_.primvars, name);
  if (!primvar || primvar->width < 2) return false;
  const float* value = valueAt(*primvar, point.primitive);
  for (int corner = 0; corner < 3; ++corner) st[corner] = {value[0], value[1]};
  return true;
}

}  // namespace penumbra
