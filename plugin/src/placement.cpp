#include "penumbra/plugin/placement.h"

#include <cmath>

namespace penumbra::plugin {

static_assert(Geometry::kMaxCoordinate == 1e18f, "kBeyondReach states it");
const char* const kBeyondReach =
    "its world bounds reach beyond 1e18 units from the origin (or are not finite), where "
    "single-precision ray tracing cannot place it";

namespace {

/// Whether the scene delegate already reported the transform itself: it warns of one that is not
/// finite or translates beyond Geometry::kMaxCoordinate for every kind of prim (python/penumbra/
/// usd/core_batch.py), so a second warning, of the bounds, would be one too many.
bool transformReported(const MotionTransform& objectToWorld) {
  for (const Transform& step : objectToWorld.steps())
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 4; ++col) {
        const double value = step.at(row, col);
        const bool translation = row == 3 && col < 3;
        if (!std::isfinite(value) || (translation && std::abs(value) > Geometry::kMaxCoordinate))
          return true;
      }
  return false;
}

}  // namespace

void PlacedRprim::setMaterialId(PrimId materialId) {
  materialId_ = std::move(materialId);
  markDirty(DirtyMaterialId);
}

void PlacedRprim::setTransform(const MotionTransform& objectToWorld) {
  objectToWorld_ = objectToWorld;
  markDirty(DirtyTransform);
}

void PlacedRprim::setVisible(bool visible) {
  visible_ = visible;
  markDirty(DirtyVisibility);
}

void PlacedRprim::setPassVisibility(PassVisibility pass) {
  pass_ = pass;
  markDirty(DirtyVisibility);
}

void PlacedRprim::setLinkingClass(uint32_t linkingClass) {
  linkingClass_ = linkingClass;
  markDirty(DirtyVisibility);
}

void PlacedRprim::syncPlacement(SyncContext& context, uint32_t bits) const {
  if (bits & kPlacementDirtyBits) {
    if (!materialId_.empty() && !context.materials.find(materialId_) && (bits & DirtyMaterialId))
      context.warn(id() + ": bound material " + materialId_ +
                   " is not in the render index; displayColor is used");
    if (bits & DirtyVisibility) {
      context.scene.geometry().setMeshPassVisibility(handle_, pass_);
      context.scene.geometry().setMeshLinkingClass(handle_, linkingClass_);
    }
    place(context);
  }
  // Moved or reshaped (the geometry placed it again as it changed) out of reach.
  if ((bits & (kPlacementDirtyBits | DirtyTopology | DirtyPoints)) &&
      context.scene.geometry().beyondReach(handle_) && !transformReported(objectToWorld_))
    context.warn(id() + ": " + kBeyondReach + "; the prim is not rendered");
}

void PlacedRprim::place(SyncContext& context) const {
  int materialIndex = MaterialTable::kNoMaterial;
  if (!materialId_.empty())
    materialIndex = context.materials.find(materialId_).value_or(materialIndex);
  context.scene.geometry().setMeshInstance(handle_, objectToWorld_, materialIndex, visible_);
}

}  // namespace penumbra::plugin
