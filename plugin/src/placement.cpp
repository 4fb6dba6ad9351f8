#include "penumbra/plugin/placement.h"

namespace penumbra::plugin {

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
  if (!(bits & kPlacementDirtyBits)) return;
  if (!materialId_.empty() && !context.materials.find(materialId_) && (bits & DirtyMaterialId))
    context.warn(id() + ": bound material " + materialId_ +
                 " is not in the render index; displayColor is used");
  if (bits & DirtyVisibility) context.scene.geometry().setMeshPassVisibility(handle_, pass_);
  place(context);
}

void PlacedRprim::place(SyncContext& context) const {
  int materialIndex = MaterialTable::kNoMaterial;
  if (!materialId_.empty())
    materialIndex = context.materials.find(materialId_).value_or(materialIndex);
  context.scene.geometry().setMeshInstance(handle_, objectToWorld_, materialIndex, visible_);
}

}  // namespace penumbra::plugin
