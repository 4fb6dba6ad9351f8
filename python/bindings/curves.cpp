// Curves rprims (UsdGeomBasisCurves): set_curves. Their transform, visibility, pass visibility
// and material binding go through the per-prim setters of scene_bindings.cpp.
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "bindings.h"
#include "conversions.h"

namespace penumbra::bindings {

namespace {

CurveType toCurveType(const std::string& token) {
  if (token == "linear") return CurveType::Linear;
  if (token == "cubic") return CurveType::Cubic;
  throw std::invalid_argument("unknown curve type '" + token + "'");
}

CurveBasis toCurveBasis(const std::string& token) {
  if (token == "bezier") return CurveBasis::Bezier;
  if (token == "bspline") return CurveBasis::BSpline;
  if (token == "catmullRom") return CurveBasis::CatmullRom;
  throw std::invalid_argument("unknown curve basis '" + token + "'");
}

CurveWrap toCurveWrap(const std::string& token) {
  if (token == "nonperiodic") return CurveWrap::Nonperiodic;
  if (token == "periodic") return CurveWrap::Periodic;
  if (token == "pinned") return CurveWrap::Pinned;
  throw std::invalid_argument("unknown curve wrap '" + token + "'");
}

}  // namespace

void bindCurves(py::module_&, DelegateClass& delegate) {
  delegate.def(
      "set_curves",
      [](plugin::RenderDelegate& self, const std::string& id, const std::string& type,
         const std::string& basis, const std::string& wrap, const IntArray& curveVertexCounts,
         const FloatArray& positions, const FloatArray& widths,
         const std::string& widthsInterpolation, const FloatArray& normals,
         const std::string& normalsInterpolation, const FloatArray& displayColor,
         const std::string& displayColorInterpolation, const py::dict& primvars) {
        plugin::Curves& curves = self.curves(id);
        // Everything is converted first: a bad token or array changes nothing.
        const CurveType curveType = toCurveType(type);
        const CurveBasis curveBasis = toCurveBasis(basis);
        const CurveWrap curveWrap = toCurveWrap(wrap);
        std::vector<int> counts = toIntVector(curveVertexCounts, "curve vertex counts");
        auto [first, motion] = toPointSamples(id, positions);
        std::vector<float> widthValues = toFloatVector(widths, "widths");
        const Interpolation widthsBy = toInterpolation(widthsInterpolation);
        std::vector<Vec3f> normalValues = toVec3Array(normals, "normals");
        const Interpolation normalsBy = toInterpolation(normalsInterpolation);
        std::vector<Vec3f> colors = toVec3Array(displayColor, "display colour");
        const Interpolation colorsBy = toInterpolation(displayColorInterpolation);
        std::vector<Primvar> primvarValues = toPrimvars(id, primvars);
        curves.setTopology(curveType, curveBasis, curveWrap, std::move(counts));
        curves.setPositions(std::move(first), std::move(motion));
        curves.setWidths(std::move(widthValues), widthsBy);
        curves.setNormals(std::move(normalValues), normalsBy);
        curves.setDisplayColor(std::move(colors), colorsBy);
        curves.setPrimvars(std::move(primvarValues));
      },
      py::arg("id"), py::arg("type"), py::arg("basis"), py::arg("wrap"),
      py::arg("curve_vertex_counts"), py::arg("positions"), py::arg("widths"),
      py::arg("widths_interpolation") = "vertex",
      py::arg("normals") = FloatArray(py::array::ShapeContainer{0, 3}),
      py::arg("normals_interpolation") = "vertex",
      py::arg("display_color") = FloatArray(py::array::ShapeContainer{0, 3}),
      py::arg("display_color_interpolation") = "constant", py::arg("primvars") = py::dict(),
      "A curves prim's data (UsdGeomBasisCurves' conventions): type 'linear' or 'cubic'; basis "
      "'bezier', 'bspline' or 'catmullRom'; wrap 'nonperiodic', 'periodic' or 'pinned'; "
      "curve_vertex_counts int32 (C,); positions float32 (N, 3), or (K, N, 3) for K samples "
      "over the shutter; widths (diameters of tubes, or ribbon widths) with their "
      "interpolation; normals (M, 3) with theirs, or empty (round tubes; else ribbons facing "
      "them); display_color (M, 3) with its interpolation; primvars {name: (values, "
      "interpolation)}.");
}

}  // namespace penumbra::bindings
