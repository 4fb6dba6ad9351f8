// Where an rprim's object stands in the scene (cf. what HdRprim keeps besides its geometry):
// its material id, transform, visibility and pass visibility, and how its sync places the
// object with them. Meshes and points hold one each.
#pragma once

#include <cstdint>

#include "penumbra/motion.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

struct Placement {
  /// The dirty bits on which a sync places the object again.
  static constexpr uint32_t kDirtyBits = DirtyMaterialId | DirtyTransform | DirtyVisibility;

  PrimId materialId;
  MotionTransform objectToWorld;
  bool visible = true;
  PassVisibility pass;

  /// What a sync of prim `id` does on `bits`: warns of a newly bound material missing from the
  /// render index, applies the pass visibility, and places object `handle` (on kDirtyBits).
  void sync(SyncContext& context, const PrimId& id, Geometry::MeshId handle, uint32_t bits) const;
  /// Places object `handle` with its transform, material and visibility (a material it is
  /// bound to changed or moved in the scene's list).
  void place(SyncContext& context, Geometry::MeshId handle) const;
};

}  // namespace penumbra::plugin
