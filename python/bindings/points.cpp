// Points rprims (UsdGeomPoints): set_points. Their transform, visibility, pass visibility and
// material binding go through the per-prim setters of scene_bindings.cpp.
#include <string>
#include <utility>
#include <vector>

#include "bindings.h"
#include "conversions.h"

namespace penumbra::bindings {

void bindPoints(py::module_&, DelegateClass& delegate) {
  delegate.def(
      "set_points",
      [](plugin::RenderDelegate& self, const std::string& id, const FloatArray& positions,
         const FloatArray& widths, const FloatArray& normals, const FloatArray& displayColor,
         const std::string& displayColorInterpolation, const py::dict& primvars) {
        plugin::Points& points = self.points(id);
        // Everything is converted first: a bad array or token changes nothing.
        auto [first, motion] = toPointSamples(id, positions);
        std::vector<float> widthValues = toFloatVector(widths, "widths");
        std::vector<Vec3f> normalValues = toVec3Array(normals, "normals");
        std::vector<Vec3f> colors = toVec3Array(displayColor, "display colour");
        const Interpolation colorsBy = toInterpolation(displayColorInterpolation);
        std::vector<Primvar> primvarValues = toPrimvars(id, primvars);
        points.setPositions(std::move(first), std::move(motion));
        points.setWidths(std::move(widthValues));
        points.setNormals(std::move(normalValues));
        points.setDisplayColor(std::move(colors), colorsBy);
        points.setPrimvars(std::move(primvarValues));
      },
      py::arg("id"), py::arg("positions"), py::arg("widths"),
      py::arg("normals") = FloatArray(py::array::ShapeContainer{0, 3}),
      py::arg("display_color") = FloatArray(py::array::ShapeContainer{0, 3}),
      py::arg("display_color_interpolation") = "constant", py::arg("primvars") = py::dict(),
      "A points prim's data: positions float32 (N, 3), or (K, N, 3) for K samples over the "
      "shutter; widths (N,) (diameters); normals (N, 3) or empty (spheres: none, discs: one "
      "per point); display_color (1, 3) constant or (N, 3) per point; primvars {name: (values, "
      "interpolation)}.");
}

}  // namespace penumbra::bindings
