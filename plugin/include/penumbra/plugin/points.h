// Points rprim (cf. HdPoints): UsdGeomPoints as spheres of their widths, or discs facing their
// normals, with display colour, primvars, material binding, transform and visibility.
#pragma once

#include <vector>

#include "penumbra/plugin/placement.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/points.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

class Points : public PlacedRprim {
 public:
  using PlacedRprim::PlacedRprim;

  /// `positionMotion`: the positions at later, uniformly spaced shutter times (see PointsData).
  void setPositions(std::vector<Vec3f> positions,
                    std::vector<std::vector<Vec3f>> positionMotion = {});
  /// Diameters, one per point.
  void setWidths(std::vector<float> widths);
  /// Empty: spheres; else one per point: discs facing them.
  void setNormals(std::vector<Vec3f> normals);
  void setDisplayColor(std::vector<Vec3f> colors, Interpolation interpolation);
  /// The primvars materials may read, replacing those set before.
  void setPrimvars(std::vector<Primvar> primvars);

  /// Syncs what its dirty bits say changed into the scene (cf. HdPoints::Sync): its geometry
  /// (invalid data: one warning naming the prim, and it renders nothing until it changes), then
  /// its placement.
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Removes it from the scene.
  void finalize(SyncContext& context) override;
  const PointsData& data() const { return data_; }

 private:
  PointsData data_;
};

}  // namespace penumbra::plugin
