#include "penumbra/curves_shape.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "penumbra/embree.h"
#include "penumbra/motion.h"
#include "same_bits.h"

namespace penumbra {
namespace {

/// Whether two sets of curves are the same tubes or ribbons (bit for bit) at every step.
bool sameSurface(const CurvesData& a, const CurvesData& b) {
  return a.type == b.type && a.basis == b.basis && a.wrap == b.wrap &&
         a.widthsInterpolation == b.widthsInterpolation &&
         a.normalsInterpolation == b.normalsInterpolation &&
         sameBits(a.curveVertexCounts, b.curveVertexCounts) && sameBits(a.positions, b.positions) &&
         sameBits(a.widths, b.widths) && sameBits(a.normals, b.normals) &&
         sameBits(a.positionMotion, b.positionMotion);
}

/// The cubic Bézier control values of the linear function from `a` to `b` (exact).
template <typename T>
void linearToBezier(const T& a, const T& b, T controls[4]) {
  controls[0] = a;
  controls[1] = a * (2.0f / 3) + b * (1.0f / 3);
  controls[2] = a * (1.0f / 3) + b * (2.0f / 3);
  controls[3] = b;
}

/// The cubic Bézier control values of a segment given by four control values in `basis` (the
/// same polynomial, exactly up to rounding).
template <typename T>
void toBezier(CurveBasis basis, const T native[4], T controls[4]) {
  switch (basis) {
    case CurveBasis::Bezier:
      std::copy(native, native + 4, controls);
      return;
    case CurveBasis::BSpline:
      controls[0] = (native[0] + native[1] * 4.0f + native[2]) * (1.0f / 6);
      controls[1] = native[1] * (2.0f / 3) + native[2] * (1.0f / 3);
      controls[2] = native[1] * (1.0f / 3) + native[2] * (2.0f / 3);
      controls[3] = (native[1] + native[2] * 4.0f + native[3]) * (1.0f / 6);
      return;
    case CurveBasis::CatmullRom:  // through native 1 and 2 with tangents (p2 - p0)/2, (p3 - p1)/2
      controls[0] = native[1];
      controls[1] = native[1] + (native[2] - native[0]) * (1.0f / 6);
      controls[2] = native[2] - (native[3] - native[1]) * (1.0f / 6);
      controls[3] = native[2];
      return;
  }
}

template <typename T>
T evaluateBezier(const T controls[4], float u) {
  const float s = 1 - u;
  return controls[0] * (s * s * s) + controls[1] * (3 * s * s * u) + controls[2] * (3 * s * u * u) +
         controls[3] * (u * u * u);
}

template <typename T>
T bezierDerivative(const T controls[4], float u) {
  const float s = 1 - u;
  return (controls[1] - controls[0]) * (3 * s * s) + (controls[2] - controls[1]) * (6 * s * u) +
         (controls[3] - controls[2]) * (3 * u * u);
}

/// The point of `shape` at Embree's (segment, u, v), on the centre line at `centre`: three equal
/// corners (no differentials across the fibre, whatever weights u and v make); primvars are read
/// at (segment, u).
SurfacePoint centreLinePoint(const Shape& shape, uint32_t segment, float u, float v,
                             const Vec3f& centre) {
  SurfacePoint point;
  point.shape = &shape;
  point.primitive = segment;
  point.u = u;
  point.v = v;
  for (Vec3f& corner : point.corners) corner = centre;
  return point;
}

}  // namespace

CurvesShape::CurvesShape(CurvesData curves) : curves_(std::move(curves)), rules_(curves_) {
  const size_t count = curves_.curveVertexCounts.size();
  curveFirstVertex_.resize(count + 1);
  curveFirstSegment_.resize(count + 1);
  curveFirstVarying_.resize(count + 1);
  for (size_t curve = 0; curve < count; ++curve) {
    const auto vertices = uint32_t(curves_.curveVertexCounts[curve]);
    curveFirstVertex_[curve + 1] = curveFirstVertex_[curve] + vertices;
    curveFirstSegment_[curve + 1] = curveFirstSegment_[curve] + rules_.segments(vertices);
    curveFirstVarying_[curve + 1] = curveFirstVarying_[curve] + rules_.varyingValues(vertices);
  }
  segmentCurve_.resize(curveFirstSegment_.back());
  for (size_t curve = 0; curve < count; ++curve)
    std::fill(segmentCurve_.begin() + curveFirstSegment_[curve],
              segmentCurve_.begin() + curveFirstSegment_[curve + 1], uint32_t(curve));
  requireRibbonsAcrossTheirNormals();
}

void CurvesShape::requireRibbonsAcrossTheirNormals() const {
  if (curves_.normals.empty()) return;
  for (uint32_t primitive = 0; primitive < segmentCurve_.size(); ++primitive) {
    const Segment segment = segmentAt(primitive);
    Vec3f normals[4];
    normalControls(segment, normals);
    for (size_t step = 0; step <= curves_.positionMotion.size(); ++step) {
      Vec3f centre[4];
      centreControlsAtStep(segment, step, centre);
      // A Bézier curve leaves its first control towards the second and reaches its last from
      // the third; its normal there is the first or last normal control.
      const Vec3f directions[2] = {centre[1] - centre[0], centre[3] - centre[2]};
      const Vec3f ends[2] = {normals[0], normals[3]};
      for (int end = 0; end < 2; ++end) {
        const float along = length(directions[end]), size = length(ends[end]);
        if (along > 0 && !(length(cross(ends[end], directions[end])) > 1e-6f * along * size))
          throw std::invalid_argument(
              "normals: a ribbon faces along its curve at the " +
              std::string(end == 0 ? "start" : "end") + " of segment " +
              std::to_string(segment.index) + " of curve " + std::to_string(segment.curve) +
              " (its normal there is zero or parallel to the curve), so it has no width "
              "direction");
      }
    }
  }
}

CurvesShape::Segment CurvesShape::segmentAt(uint32_t segment) const {
  const uint32_t curve = segmentCurve_[segment];
  return {curve,
          segment - curveFirstSegment_[curve],
          curveFirstVertex_[curve],
          curveFirstVertex_[curve + 1] - curveFirstVertex_[curve],
          curveFirstVarying_[curve],
          curveFirstVarying_[curve + 1] - curveFirstVarying_[curve]};
}

template <typename T, typename Value>
void CurvesShape::bezierControls(const Segment& segment, Interpolation interpolation,
                                 const Value& value, T controls[4]) const {
  switch (interpolation) {
    case Interpolation::Constant:
      std::fill(controls, controls + 4, T(value(0)));
      return;
    case Interpolation::Uniform:
      std::fill(controls, controls + 4, T(value(segment.curve)));
      return;
    case Interpolation::Varying:
    case Interpolation::FaceVarying:  // the schema's varying, on curves
      linearToBezier(T(value(segment.firstVarying + segment.index)),
                     T(value(segment.firstVarying + (segment.index + 1) % segment.varyingCount)),
                     controls);
      return;
    case Interpolation::Vertex:
      break;
  }
  const uint32_t first = segment.firstVertex, n = segment.vertexCount;
  if (!rules_.cubic) {
    linearToBezier(T(value(first + segment.index)), T(value(first + (segment.index + 1) % n)),
                   controls);
    return;
  }
  // Vertex j of the curve, wrapped around periodic curves; pinned curves have phantom vertices
  // at j = -1 and j = n, the schema's reflections 2 P[0] - P[1] and 2 P[n-1] - P[n-2].
  auto vertex = [&](int64_t j) -> T {
    if (j < 0) return T(value(first)) * 2.0f - T(value(first + 1));
    if (j >= int64_t(n)) {
      if (rules_.wrap == CurveWrap::Periodic) return T(value(first + uint32_t(j % n)));
      return T(value(first + n - 1)) * 2.0f - T(value(first + n - 2));
    }
    return T(value(first + uint32_t(j)));
  };
  const int64_t start =
      int64_t(segment.index) * rules_.vstep - (rules_.wrap == CurveWrap::Pinned ? 1 : 0);
  const T native[4] = {vertex(start), vertex(start + 1), vertex(start + 2), vertex(start + 3)};
  toBezier(rules_.basis, native, controls);
}

void CurvesShape::positionControls(const Segment& segment, float time, Vec3f controls[4]) const {
  bezierControls(
      segment, Interpolation::Vertex,
      [&](uint32_t i) { return pointAtTime(curves_.positions, curves_.positionMotion, i, time); },
      controls);
}

const std::vector<Vec3f>& CurvesShape::positionsAtStep(size_t step) const {
  return step == 0 ? curves_.positions : curves_.positionMotion[step - 1];
}

void CurvesShape::centreControlsAtStep(const Segment& segment, size_t step,
                                       Vec3f controls[4]) const {
  const std::vector<Vec3f>& positions = positionsAtStep(step);
  bezierControls(
      segment, Interpolation::Vertex, [&](uint32_t i) { return positions[i]; }, controls);
}

void CurvesShape::radiusControls(const Segment& segment, float controls[4]) const {
  bezierControls(
      segment, curves_.widthsInterpolation, [&](uint32_t i) { return curves_.widths[i]; },
      controls);
  for (int i = 0; i < 4; ++i) controls[i] = std::max(controls[i] / 2, 0.0f);
}

void CurvesShape::normalControls(const Segment& segment, Vec3f controls[4]) const {
  bezierControls(
      segment, curves_.normalsInterpolation, [&](uint32_t i) { return curves_.normals[i]; },
      controls);
}

RTCGeometry CurvesShape::newEmbreeGeometry(RTCDevice device) const {
  if (segmentCurve_.empty()) return nullptr;
  return roundLinear() ? newRoundLinearGeometry(device) : newBezierGeometry(device);
}

RTCGeometry CurvesShape::newRoundLinearGeometry(RTCDevice device) const {
  // Each curve's vertices in a row, a periodic one's framed by its last vertex before and its
  // first two after, so that every segment's neighbours are the vertices next to its own, as
  // Embree's neighbour flags assume.
  const bool periodic = rules_.wrap == CurveWrap::Periodic;
  const size_t curveCount = curves_.curveVertexCounts.size();
  const size_t segmentCount = segmentCurve_.size();
  const size_t vertexCount = curves_.positions.size() + (periodic ? 3 * curveCount : 0);
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
  const unsigned stepCount = unsigned(curves_.positionMotion.size() + 1);
  rtcSetGeometryTimeStepCount(geometry, stepCount);
  auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(uint32_t), segmentCount));
  auto* flags = static_cast<uint8_t*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_FLAGS, 0, RTC_FORMAT_UCHAR, sizeof(uint8_t), segmentCount));
  bool allocated = indices && flags;
  // Per vertex of a linear curve, varying and vertex data are the same: one value per vertex.
  auto radius = [&](uint32_t curve, uint32_t vertex) {
    switch (curves_.widthsInterpolation) {
      case Interpolation::Constant:
        return curves_.widths[0] / 2;
      case Interpolation::Uniform:
        return curves_.widths[curve] / 2;
      case Interpolation::Vertex:
        return curves_.widths[curveFirstVertex_[curve] + vertex] / 2;
      default:
        return curves_.widths[curveFirstVarying_[curve] + vertex] / 2;
    }
  };
  for (unsigned step = 0; step < stepCount; ++step) {
    const std::vector<Vec3f>& positions = positionsAtStep(step);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, step, RTC_FORMAT_FLOAT4, 4 * sizeof(float), vertexCount));
    if (!vertices) {
      allocated = false;
      continue;
    }
    size_t written = 0;
    for (uint32_t curve = 0; curve < curveCount; ++curve) {
      const uint32_t first = curveFirstVertex_[curve];
      const uint32_t n = curveFirstVertex_[curve + 1] - first;
      auto write = [&](uint32_t vertex) {
        const Vec3f& p = positions[first + vertex];
        float* out = vertices + 4 * written++;
        out[0] = p.x, out[1] = p.y, out[2] = p.z, out[3] = radius(curve, vertex);
      };
      if (periodic) write(n - 1);
      for (uint32_t vertex = 0; vertex < n; ++vertex) write(vertex);
      if (periodic) write(0), write(1);
    }
  }
  if (allocated) {
    size_t vertexOffset = 0;
    for (uint32_t curve = 0; curve < curveCount; ++curve) {
      const uint32_t first = curveFirstSegment_[curve];
      const uint32_t segments = curveFirstSegment_[curve + 1] - first;
      for (uint32_t k = 0; k < segments; ++k) {
        indices[first + k] = uint32_t(vertexOffset + (periodic ? 1 : 0) + k);
        flags[first + k] =
            uint8_t((periodic || k > 0 ? RTC_CURVE_FLAG_NEIGHBOR_LEFT : 0) |
                    (periodic || k + 1 < segments ? RTC_CURVE_FLAG_NEIGHBOR_RIGHT : 0));
      }
      vertexOffset += curveFirstVertex_[curve + 1] - curveFirstVertex_[curve] + (periodic ? 3 : 0);
    }
  }
  if (!allocated) {
    rtcReleaseGeometry(geometry);
    throwOnEmbreeError(device, "allocate curves buffers");
    throw std::runtime_error("Embree could not allocate curves buffers");
  }
  return geometry;
}

RTCGeometry CurvesShape::newBezierGeometry(RTCDevice device) const {
  const bool ribbons = !curves_.normals.empty();
  const size_t segmentCount = segmentCurve_.size();
  RTCGeometry geometry =
      rtcNewGeometry(device, ribbons ? RTC_GEOMETRY_TYPE_NORMAL_ORIENTED_BEZIER_CURVE
                                     : RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE);
  const unsigned stepCount = unsigned(curves_.positionMotion.size() + 1);
  rtcSetGeometryTimeStepCount(geometry, stepCount);
  auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(uint32_t), segmentCount));
  bool allocated = indices != nullptr;
  if (indices)
    for (size_t segment = 0; segment < segmentCount; ++segment)
      indices[segment] = uint32_t(4 * segment);
  for (unsigned step = 0; step < stepCount; ++step) {
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, step, RTC_FORMAT_FLOAT4,
                                4 * sizeof(float), 4 * segmentCount));
    // Embree wants the ribbons' normals at every step; they do not move.
    auto* normals = ribbons ? static_cast<Vec3f*>(rtcSetNewGeometryBuffer(
                                  geometry, RTC_BUFFER_TYPE_NORMAL, step, RTC_FORMAT_FLOAT3,
                                  sizeof(Vec3f), 4 * segmentCount))
                            : nullptr;
    if (!vertices || (ribbons && !normals)) {
      allocated = false;
      continue;
    }
    for (uint32_t primitive = 0; primitive < segmentCount; ++primitive) {
      const Segment segment = segmentAt(primitive);
      Vec3f centre[4];
      centreControlsAtStep(segment, step, centre);
      float radii[4];
      radiusControls(segment, radii);
      float* out = vertices + 16 * size_t(primitive);
      for (int i = 0; i < 4; ++i) {
        out[4 * i] = centre[i].x, out[4 * i + 1] = centre[i].y, out[4 * i + 2] = centre[i].z;
        out[4 * i + 3] = radii[i];
      }
      if (ribbons) normalControls(segment, normals + 4 * size_t(primitive));
    }
  }
  if (!allocated) {
    rtcReleaseGeometry(geometry);
    throwOnEmbreeError(device, "allocate curves buffers");
    throw std::runtime_error("Embree could not allocate curves buffers");
  }
  return geometry;
}

bool CurvesShape::tracesAs(const Shape& other) const {
  const auto* curves = dynamic_cast<const CurvesShape*>(&other);
  return curves && sameSurface(curves_, curves->curves_);
}

SurfacePoint CurvesShape::pointAt(uint32_t segment, float u, float v, float time) const {
  Vec3f controls[4];
  positionControls(segmentAt(segment), time, controls);
  return centreLinePoint(*this, segment, u, v, evaluateBezier(controls, u));
}

SurfaceGeometry CurvesShape::surfaceAt(uint32_t segment, float u, float v, float time,
                                       const Vec3f& geometricNormal,
                                       const Transform& objectToWorld) const {
  Vec3f controls[4];
  positionControls(segmentAt(segment), time, controls);
  SurfaceGeometry surface;
  surface.point = centreLinePoint(*this, segment, u, v, evaluateBezier(controls, u));
  // Embree's Ng: outwards on a tube (from inside it too), and on a ribbon to the side its
  // interpolated normal faces (its front, whichever way the curve runs).
  surface.normal = normalize(objectToWorld.applyToNormal(geometricNormal));
  surface.shadingNormal = surface.normal;
  surface.closed = curves_.normals.empty();
  surface.fibreDirection = normalize(objectToWorld.applyToVector(bezierDerivative(controls, u)));
  if (surface.closed && length(geometricNormal) > 0) {
    // On a tube Embree's Ng points from the centre line at u to the hit.
    float radii[4];
    radiusControls(segmentAt(segment), radii);
    surface.objectPosition =
        surface.point.corners[0] + normalize(geometricNormal) * evaluateBezier(radii, u);
  } else if (!surface.closed && length(geometricNormal) > 0) {
    // Embree's ribbon runs across from one edge curve to the other, which lie either side of
    // the centre line by the same offset; its Ng is across both directions at (u, v), so the
    // centre line at u lies in the tangent plane there.
    surface.objectPlanePoint = surface.point.corners[0];
  }
  return surface;
}

void CurvesShape::primvarValue(const Primvar& primvar, const Segment& segment, float u,
                               float* out) const {
  const auto width = size_t(primvar.width);
  for (size_t component = 0; component < width; ++component) {
    float controls[4];
    bezierControls(
        segment, primvar.interpolation,
        [&](uint32_t i) { return primvar.values[i * width + component]; }, controls);
    out[component] = evaluateBezier(controls, u);
  }
}

int CurvesShape::primvarWidth(const PrimvarName& name) const {
  if (const Primvar* primvar = findPrimvar(curves_.primvars, name)) return primvar->width;
  if (name == displayColorName() && !curves_.displayColor.empty()) return 3;
  return 0;
}

bool CurvesShape::primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                            int* width) const {
  if (const Primvar* primvar = findPrimvar(curves_.primvars, name)) {
    primvarValue(*primvar, segmentAt(point.primitive), point.u, value);
    *width = primvar->width;
    return true;
  }
  if (name == displayColorName() && !curves_.displayColor.empty()) {
    Vec3f controls[4];
    bezierControls(
        segmentAt(point.primitive), curves_.displayColorInterpolation,
        [&](uint32_t i) { return curves_.displayColor[i]; }, controls);
    const Vec3f color = evaluateBezier(controls, point.u);
    value[0] = color.x, value[1] = color.y, value[2] = color.z;
    *width = 3;
    return true;
  }
  return false;
}

bool CurvesShape::cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                                    Vec2f st[3]) const {
  const Primvar* primvar = findPrimvar(curves_.primvars, name);
  if (!primvar || primvar->width < 2) return false;
  float value[4];
  primvarValue(*primvar, segmentAt(point.primitive), point.u, value);
  for (int corner = 0; corner < 3; ++corner) st[corner] = {value[0], value[1]};
  return true;
}

}  // namespace penumbra
