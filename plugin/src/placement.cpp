#include "penumbra/plugin/placement.h"

namespace penumbra::plugin {

void Placement::sync(SyncContext& context, const PrimId& id, Geometry::MeshId handle,
                     uint32_t bits) const {
  if (!(bits & kDirtyBits)) return;
  if (!materialId.empty() && !context.materials.find(materialId) && (bits & DirtyMaterialId))
    context.warn(id + ": bound material " + materialId +
                 " is not in the render index; displayColor is used");
  if (bits & DirtyVisibility) context.scene.geometry().setMeshPassVisibility(handle, pass);
  place(context, handle);
}

void Placement::place(SyncContext& context, Geometry::MeshId handle) const {
  int materialIndex = MaterialTable::kNoMaterial;
  if (!materialId.empty())
    materialIndex = context.materials.find(materialId).value_or(materialIndex);
  context.scene.geometry().setMeshInstance(handle, objectToWorld, materialIndex, visible);
}

}  // namespace penumbra::plugin
