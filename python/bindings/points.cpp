// Points rprims (UsdGeomPoints): set_points. Their transform, visibility, pass visibility and
// material binding go through the per-prim setters of scene_bindings.cpp.
#include <string>
#include <utility>

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
        auto [first, motion] = toPointSamples(id, positions);
        points.setPositions(std::move(first), std::move(motion));
        points.setWidths(toFloatVector(widths, "widths"));
        points.setNormals(toVec3Array(normals, "normals"));
        points.setDisplayColor(toVec3Array(displayColor, "display colour"),
                               toInterpolation(displayColorInterpolation));
        points.setPrimvars(toPrimvars(id, primvars));
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
