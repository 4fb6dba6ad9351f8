// UsdGeomPoints as the renderer receives them (plain arrays, USD conventions), and their
// validation.
#pragma once

#include <vector>

#include "penumbra/math.h"
#include "penumbra/mesh.h"

namespace penumbra {

/// UsdGeomPoints as the renderer takes them (object space): spheres of diameter `widths`, or,
/// with `normals`, discs of that diameter facing them.
struct PointsData {
  std::vector<Vec3f> positions;  // motion step 0
  /// Later uniformly spaced steps, as MeshData::pointMotion (empty: static).
  std::vector<std::vector<Vec3f>> positionMotion;
  std::vector<float> widths;        // one per point (diameters), finite and > 0
  std::vector<Vec3f> normals;       // empty: spheres; else one per point: discs
  std::vector<Vec3f> displayColor;  // empty: none authored
  /// Constant or Vertex (one per point).
  Interpolation displayColorInterpolation = Interpolation::Constant;
  std::vector<Primvar> primvars;  // Constant or Vertex/Varying (one value per point)
};

/// Throws std::invalid_argument whose message names the array and what is wrong (counts that
/// do not match the positions, a width <= 0 or not finite, non-finite positions, normals of
/// zero length), so that the plugin can warn "<prim id>: <message>; skipped".
void validatePoints(const PointsData& points);

}  // namespace penumbra
