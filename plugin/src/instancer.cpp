#include "penumbra/plugin/instancer.h"

#include <stdexcept>

#include "penumbra/plugin/mesh.h"

namespace penumbra::plugin {

void Instancer::sync(SyncContext& context, uint32_t) {
  context.sceneChanged = true;
  Scene& scene = context.scene;
  Mesh* prototype = context.meshes.find(prototype_);
  if (!prototype) {
    context.warn(id() + ": prototype " + prototype_ +
                 " is not a mesh in the render index; the instances are skipped");
    scene.geometry().removeInstancer(handle_);
    handle_ = scene.geometry().addInstancer();
    return;
  }
  // As in Hydra, the prototype knows its instancer (its removal drops the copies).
  prototype->addInstancer(id());
  scene.geometry().setInstancerPassVisibility(handle_, pass_);
  scene.geometry().setInstances(handle_, prototype->handle(), transforms_, visible_);
  try {
    scene.geometry().setInstancePrimvars(handle_, primvars_);
  } catch (const std::invalid_argument& error) {
    context.warn(id() + ": " + error.what() + "; the per-instance primvars are ignored");
    scene.geometry().setInstancePrimvars(handle_, {});
  }
}

void Instancer::finalize(SyncContext& context) {
  context.sceneChanged = true;
  context.scene.geometry().removeInstancer(handle_);
  if (Mesh* prototype = context.meshes.find(prototype_)) prototype->removeInstancer(id());
}

void Instancer::dropCopies(SyncContext& context) {
  context.scene.geometry().removeInstancer(handle_);
  handle_ = context.scene.geometry().addInstancer();
  markDirty(DirtyTransform);
}

size_t Instancer::estimatedSyncBytes() const {
  if (!visible_) return 0;
  return estimatedInstanceBytes(transforms_.size(),
                                transforms_.empty() ? 1 : transforms_[0].steps().size());
}

}  // namespace penumbra::plugin
