#include "penumbra/plugin/placement.h"

namespace penumbra::plugin {

static_assert(Geometry::kMaxCoordinate == 1e18f, "kBeyondReach states it");
const char* const kBeyondReach =
    "its world bounds reach beyond 1e18 units from the origin (or are not finite), where "
    "single-precision ray tracing cannot place it";

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

void PlacedRprim::syncPlacement(SyncContext& context, uint32_t bits) const {
  if (bits & kPlacementDirtyBits) {
    if (!materialId_.empty() && !context.materials.find(materialId_) && (bits & DirtyMaterialId))
      context.warn(id() + ": bound material " + materialId_ +
                   " is not in the render index; displayColor is used");
    if (bits & DirtyVisibility) context.scene.geometry().setMeshPassVisibility(handle_, pass_);
    place(context);
  }
  // Moved or reshaped (the geometry placed it again as it changed) out of reach.
  if ((bits & (kPlacementDirtyBits | DirtyTopology | DirtyPoints)) &&
      context.scene.geometry().beyondReach(handle_))
    context.warn(id() + ": " + kBeyondReach + "; the prim is not rendered");
}

void PlacedRprim::place(SyncContext& context) const {
  int materialIndex = MaterialTable::kNoMaterial;
  if (!materialId_.empty())
    materialIndex = context.materials.find(materialId_).value_or(materialIndex);
  context.scene.geometry().setMeshInstance(handle_, objectToWorld_, materialIndex, visible_);
}

}  // namespace penumbra::plugin
