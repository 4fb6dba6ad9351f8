// UsdGeomBasisCurves as the renderer receives them (plain arrays, USD conventions), and their
// validation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/math.h"
#include "penumbra/mesh.h"

namespace penumbra {

enum class CurveType : uint8_t { Linear, Cubic };
/// The cubic bases UsdGeomBasisCurves defines (HermiteCurves and NURBS reach the renderer
/// converted to one of these).
enum class CurveBasis : uint8_t { Bezier, BSpline, CatmullRom };
enum class CurveWrap : uint8_t { Nonperiodic, Periodic, Pinned };

/// UsdGeomBasisCurves as the renderer takes them (object space): round tubes of diameter
/// `widths`, or, with `normals`, ribbons of that width facing them.
///
/// Element counts follow the schema: per curve of n vertices, `vertex` data has n values,
/// `uniform` one, `constant` one for the whole prim, and `varying` one per segment end
/// (segments + 1 for nonperiodic and pinned curves, segments for periodic ones), where a linear
/// curve has n − 1 segments (n periodic), a cubic Bézier (n − 4)/3 + 1 (n/3 periodic) and a
/// B-spline or Catmull-Rom n − 3 (n periodic; pinned ones n − 1). `faceVarying` means `varying`
/// on curves, as the schema says. Vertex data is interpolated by the curve's basis, varying
/// data linearly along each segment.
///
/// A curve has at least 2 vertices (linear), 3 (linear periodic), 4 (cubic nonperiodic: 4, 7,
/// 10, ... for Bézier), 3 (cubic periodic: a multiple of 3 for Bézier) or 2 (pinned B-spline and
/// Catmull-Rom, whose phantom end vertices are the schema's 2 P[0] - P[1] and
/// 2 P[n-1] - P[n-2], applied to their vertex data alike). Pinned linear and Bézier curves are
/// nonperiodic ones.
struct CurvesData {
  CurveType type = CurveType::Cubic;
  CurveBasis basis = CurveBasis::Bezier;  // cubic curves only
  CurveWrap wrap = CurveWrap::Nonperiodic;
  std::vector<int> curveVertexCounts;
  std::vector<Vec3f> positions;  // motion step 0
  /// Later uniformly spaced steps, as MeshData::pointMotion (empty: static).
  std::vector<std::vector<Vec3f>> positionMotion;
  std::vector<float> widths;  // diameters, finite and > 0; required (at least one, constant)
  Interpolation widthsInterpolation = Interpolation::Vertex;
  std::vector<Vec3f> normals;  // empty: round tubes; else ribbons facing them (any length > 0)
  Interpolation normalsInterpolation = Interpolation::Vertex;
  std::vector<Vec3f> displayColor;  // empty: none authored
  Interpolation displayColorInterpolation = Interpolation::Constant;
  std::vector<Primvar> primvars;
};

/// How the schema splits the curves of one prim (all of one type, basis and wrap) into
/// segments, and how many values their varying data has.
struct CurveSegmentRules {
  explicit CurveSegmentRules(const CurvesData& curves);

  /// Whether a curve of `vertices` vertices is well formed; else `*expected` says what is.
  bool fits(uint32_t vertices, std::string* expected) const;
  /// Segments of a well-formed curve of `vertices` vertices.
  uint32_t segments(uint32_t vertices) const;
  /// Values varying data has on such a curve: one per segment end.
  uint32_t varyingValues(uint32_t vertices) const;

  bool cubic;
  CurveBasis basis;
  /// Pinned only where the schema gives it a meaning (cubic B-spline and Catmull-Rom curves),
  /// nonperiodic for the others.
  CurveWrap wrap;
  uint32_t vstep;  // vertices from one cubic segment's first to the next one's: 3 Bézier, else 1
};

/// Throws std::invalid_argument whose message names the array and what is wrong (counts that
/// do not match the vertices or the schema's rule for their interpolation, a cubic curve with
/// too few vertices for its basis and wrap, a negative or non-finite width, non-finite
/// positions or normals, normals of zero length), so that the plugin can warn "<prim id>:
/// <message>; skipped". A width of 0 is a point (a strand tapering to its tip).
void validateCurves(const CurvesData& curves);
/// Removes from `curves` the displayColor and the primvars whose counts (or widths) do not fit
/// its curves, as a mesh's are dropped: the curves still render, with their fallbacks. Returns
/// a message for each, naming it and what is used instead. Curves whose topology or positions
/// validateCurves refuses are left as they are.
std::vector<std::string> dropMismatchedCurveData(CurvesData& curves);

}  // namespace penumbra
