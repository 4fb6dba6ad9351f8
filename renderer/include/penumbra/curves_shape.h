// Curves (UsdGeomBasisCurves) as a kind of geometry: round tubes, or ribbons facing their
// normals, and the schema's rules for splitting curves into segments.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/curves.h"
#include "penumbra/shape.h"

namespace penumbra {

/// Curves of radius width/2 along their centre lines: round tubes (solids), or, where normals
/// are authored, flat ribbons of that half-width facing the interpolated normals (thin).
///
/// Embree traces round linear curves natively (cones between spheres, each curve's vertices
/// shared by its segments and the neighbour flags set, so that joints are seamless); every
/// other segment, cubic of any basis or a linear ribbon, becomes one cubic Bézier of four
/// vertices of its own. The change of basis is exact, and so varying (linear) widths and normals
/// are exact too, which shared native-basis vertices could not carry. Embree's u is the
/// segment's own parameter in every case. Embree's cubic sweeps are open at their ends (linear
/// tubes end in spheres) and assume a radius below the curve's radius of curvature.
///
/// Its own memory is 4 bytes a segment (the curve it belongs to) and 12 a curve besides the
/// authored arrays; Embree's buffers add 64 bytes a cubic or ribbon segment per motion step
/// (48 more for ribbons' normals) and 4 for its index, or 16 a vertex and 5 a segment for round
/// linear curves. A million 4-vertex strands of vertex widths took 265 MB with the shape's copy
/// of their arrays and Embree's BVH (measured).
class CurvesShape final : public Shape {
 public:
  /// `curves` must be valid (validateCurves). Throws std::invalid_argument where a ribbon's
  /// normal lies along the curve at a segment's end (see requireRibbonsAcrossTheirNormals).
  explicit CurvesShape(CurvesData curves);

  RTCGeometry newEmbreeGeometry(RTCDevice device) const override;
  bool tracesAs(const Shape& other) const override;
  /// A ribbon shows both sides; a tube's inside is seen only from within.
  bool doubleSided() const override { return true; }
  /// Corners: three times the centre line's point at u (textures are point-sampled there).
  SurfacePoint pointAt(uint32_t segment, float u, float v, float time) const override;
  SurfaceGeometry surfaceAt(uint32_t segment, float u, float v, float time,
                            const Vec3f& geometricNormal,
                            const Transform& objectToWorld) const override;
  int primvarWidth(const PrimvarName& name) const override;
  bool primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4],
                 int* width) const override;
  bool cornerCoordinates(const SurfacePoint& point, const PrimvarName& name,
                         Vec2f st[3]) const override;
  /// The curve the segment belongs to.
  int elementOf(uint32_t segment) const override { return int(segmentCurve_[segment]); }

 private:
  /// Where a segment lies among the authored arrays.
  struct Segment {
    uint32_t curve;
    uint32_t index;  // within its curve
    uint32_t firstVertex, vertexCount;
    uint32_t firstVarying, varyingCount;
  };
  Segment segmentAt(uint32_t segment) const;
  /// The four Bézier control values over `segment` of data of this interpolation, `value(i)`
  /// being its authored element i.
  template <typename T, typename Value>
  void bezierControls(const Segment& segment, Interpolation interpolation, const Value& value,
                      T controls[4]) const;
  /// The centre line's Bézier control points over `segment` at normalised shutter time `time`.
  void positionControls(const Segment& segment, float time, Vec3f controls[4]) const;
  /// The authored positions at motion step `step` (0: `positions`).
  const std::vector<Vec3f>& positionsAtStep(size_t step) const;
  /// The centre line's Bézier control points over `segment` at motion step `step`, as Embree
  /// is given them.
  void centreControlsAtStep(const Segment& segment, size_t step, Vec3f controls[4]) const;
  /// The tube's radius Bézier controls over `segment`, as Embree is given them: half the
  /// widths' controls, at least 0 (Catmull-Rom's overshoot may reach below).
  void radiusControls(const Segment& segment, float controls[4]) const;
  /// The ribbon's normal Bézier controls over `segment`, as Embree is given them.
  void normalControls(const Segment& segment, Vec3f controls[4]) const;
  /// Throws std::invalid_argument naming the curve and segment where a ribbon's normal at one
  /// of a segment's ends lies along the curve there (at any motion step): Embree turns a ribbon
  /// across normal × direction, which is then no direction, and the segment would vanish
  /// without a word. Segments whose direction at an end is zero are left to Embree.
  void requireRibbonsAcrossTheirNormals() const;
  /// Primvar `primvar` at (segment, u): writes its width of floats.
  void primvarValue(const Primvar& primvar, const Segment& segment, float u, float* out) const;
  bool roundLinear() const { return !rules_.cubic && curves_.normals.empty(); }
  RTCGeometry newRoundLinearGeometry(RTCDevice device) const;
  RTCGeometry newBezierGeometry(RTCDevice device) const;

  CurvesData curves_;
  CurveSegmentRules rules_;
  std::vector<uint32_t> segmentCurve_;  // by Embree primID: the curve
  // By curve, one more at the end: its first vertex, segment and varying value.
  std::vector<uint32_t> curveFirstVertex_, curveFirstSegment_, curveFirstVarying_;
};

}  // namespace penumbra
