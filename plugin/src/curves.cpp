#include "penumbra/plugin/curves.h"

#include <stdexcept>
#include <string>

namespace penumbra::plugin {

namespace {

// Per vertex and motion step: Embree's (x, y, z, radius) buffer and the renderer's copy of the
// positions and widths. Per segment: its index, Embree's primitive reference during the build
// and its share of the BVH's nodes and oriented-bounds leaves. 309 MiB were measured for a
// million static cubic strands of 4 vertices (336 MiB estimated).
constexpr size_t kBytesPerCurveVertexStep = 48;
constexpr size_t kBytesPerCurveSegment = 160;

}  // namespace

size_t estimatedCurvesBytes(const CurvesData& curves) {
  const CurveSegmentRules rules(curves);
  std::string expected;
  size_t segments = 0;
  for (const int vertices : curves.curveVertexCounts)  // malformed curves: validation rejects
    if (vertices > 0 && rules.fits(uint32_t(vertices), &expected))
      segments += rules.segments(uint32_t(vertices));
  const size_t steps = 1 + curves.positionMotion.size();
  return curves.positions.size() * steps * kBytesPerCurveVertexStep +
         segments * kBytesPerCurveSegment;
}

void Curves::setTopology(CurveType type, CurveBasis basis, CurveWrap wrap,
                         std::vector<int> curveVertexCounts) {
  data_.type = type;
  data_.basis = basis;
  data_.wrap = wrap;
  data_.curveVertexCounts = std::move(curveVertexCounts);
  markDirty(DirtyTopology);
}

void Curves::setPositions(std::vector<Vec3f> positions,
                          std::vector<std::vector<Vec3f>> positionMotion) {
  data_.positions = std::move(positions);
  data_.positionMotion = std::move(positionMotion);
  markDirty(DirtyPoints);
}

void Curves::setWidths(std::vector<float> widths, Interpolation interpolation) {
  data_.widths = std::move(widths);
  data_.widthsInterpolation = interpolation;
  markDirty(DirtyPoints);
}

void Curves::setNormals(std::vector<Vec3f> normals, Interpolation interpolation) {
  data_.normals = std::move(normals);
  data_.normalsInterpolation = interpolation;
  markDirty(DirtyPoints);  // tubes or ribbons: another shape
}

void Curves::setDisplayColor(std::vector<Vec3f> colors, Interpolation interpolation) {
  data_.displayColor = std::move(colors);
  data_.displayColorInterpolation = interpolation;
  markDirty(DirtyPrimvar);
}

void Curves::setPrimvars(std::vector<Primvar> primvars) {
  data_.primvars = std::move(primvars);
  markDirty(DirtyPrimvar);
}

void Curves::sync(SyncContext& context, uint32_t bits) {
  context.sceneChanged = true;
  if (bits & (DirtyTopology | DirtyPoints | DirtyPrimvar)) {
    for (const std::string& problem : dropMismatchedCurveData(data_))
      context.warn(id() + ": " + problem);
    try {
      context.scene.geometry().setCurvesGeometry(handle(), data_);
    } catch (const std::invalid_argument& error) {
      context.warn(id() + ": " + error.what() + "; skipped");
      context.scene.geometry().clearMeshGeometry(handle());
    }
  }
  syncPlacement(context, bits);
}

void Curves::finalize(SyncContext& context) {
  context.sceneChanged = true;
  context.scene.geometry().removeMesh(handle());
}

size_t Curves::estimatedSyncBytes() const {
  return visible() ? estimatedCurvesBytes(data_) : 0;
}

}  // namespace penumbra::plugin
