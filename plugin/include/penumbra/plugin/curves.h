// Curves rprim (cf. HdBasisCurves): UsdGeomBasisCurves (and NurbsCurves and HermiteCurves,
// which the scene delegate converts to them) as round tubes of their widths, or ribbons facing
// their normals, with display colour, primvars, material binding, transform and visibility.
#pragma once

#include <cstddef>
#include <vector>

#include "penumbra/curves.h"
#include "penumbra/plugin/placement.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

class Curves : public PlacedRprim {
 public:
  using PlacedRprim::PlacedRprim;

  /// The curves' type, basis (cubic curves), wrap and vertex count per curve.
  void setTopology(CurveType type, CurveBasis basis, CurveWrap wrap,
                   std::vector<int> curveVertexCounts);
  /// `positionMotion`: the positions at later, uniformly spaced shutter times (see CurvesData).
  void setPositions(std::vector<Vec3f> positions,
                    std::vector<std::vector<Vec3f>> positionMotion = {});
  /// Diameters (tubes) or ribbon widths, with the interpolation their count follows.
  void setWidths(std::vector<float> widths, Interpolation interpolation);
  /// Empty: round tubes; else ribbons facing them.
  void setNormals(std::vector<Vec3f> normals, Interpolation interpolation);
  void setDisplayColor(std::vector<Vec3f> colors, Interpolation interpolation);
  /// The primvars materials may read, replacing those set before.
  void setPrimvars(std::vector<Primvar> primvars);

  /// Syncs what its dirty bits say changed into the scene (cf. HdBasisCurves::Sync): its
  /// geometry (invalid data: one warning naming the prim, and it renders nothing until it
  /// changes), then its placement.
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Removes it from the scene.
  void finalize(SyncContext& context) override;
  /// Bytes its next sync will allocate (estimatedCurvesBytes).
  size_t estimatedSyncBytes() const;
  const CurvesData& data() const { return data_; }

 private:
  CurvesData data_;
};

/// Bytes that building `curves` for rendering allocates at its peak (Embree's vertex buffers
/// per motion step, the segment indices and the BVH over the segments), estimated from its
/// counts before anything is built, for memory budgets.
size_t estimatedCurvesBytes(const CurvesData& curves);

}  // namespace penumbra::plugin
