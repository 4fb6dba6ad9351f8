#include "penumbra/plugin/instancer.h"

#include <stdexcept>
#include <string>

#include "penumbra/plugin/curves.h"
#include "penumbra/plugin/mesh.h"
#include "penumbra/plugin/points.h"

namespace penumbra::plugin {

namespace {

/// The rprim named `id` that copies can share: a mesh, points or curves (null: none).
const PlacedRprim* findPrototype(const SyncContext& context, const PrimId& id) {
  if (const Mesh* mesh = context.meshes.find(id)) return mesh;
  if (const Points* points = context.points.find(id)) return points;
  return context.curves.find(id);
}

/// Takes `instancer` out of the instancers of `prototype` in the context's list.
void unlist(SyncContext& context, const PrimId& prototype, const PrimId& instancer) {
  const auto listed = context.instancersByPrototype.find(prototype);
  if (listed == context.instancersByPrototype.end()) return;
  listed->second.erase(instancer);
  if (listed->second.empty()) context.instancersByPrototype.erase(listed);
}

}  // namespace

void Instancer::sync(SyncContext& context, uint32_t) {
  context.sceneChanged = true;
  Scene& scene = context.scene;
  if (listedUnder_ != prototype_) {
    unlist(context, listedUnder_, id());
    context.instancersByPrototype[prototype_].insert(id());
    listedUnder_ = prototype_;
  }
  const PlacedRprim* prototype = findPrototype(context, prototype_);
  if (!prototype) {
    context.warn(id() + ": prototype " + prototype_ +
                 " is not a mesh, points or curves in the render index; the instances are "
                 "skipped");
    scene.geometry().removeInstancer(handle_);
    handle_ = scene.geometry().addInstancer();
    return;
  }
  // As in Hydra, a prototype mesh knows its instancer (its removal drops the copies); the
  // render delegate drops those of points and curves (SyncContext::instancersByPrototype).
  if (Mesh* mesh = context.meshes.find(prototype_)) mesh->addInstancer(id());
  scene.geometry().setInstancerPassVisibility(handle_, pass_);
  scene.geometry().setInstances(handle_, prototype->handle(), transforms_, visible_);
  if (const size_t beyond = scene.geometry().copiesBeyondReach(handle_))
    context.warn(id() + ": " + std::to_string(beyond) + " of " +
                 std::to_string(transforms_.size()) + " copies: " + kBeyondReach +
                 "; those copies are not rendered");
  try {
    scene.geometry().setInstancePrimvars(handle_, primvars_);
  } catch (const std::invalid_argument& error) {
    context.warn(id() + ": " + error.what() + "; the per-instance primvars are ignored");
    scene.geometry().setInstancePrimvars(handle_, {});
  }
  try {
    scene.geometry().setInstanceLinkingClasses(handle_, linkingClasses_);
  } catch (const std::invalid_argument& error) {
    context.warn(id() + ": " + error.what() + "; the copies are linked to every light");
    scene.geometry().setInstanceLinkingClasses(handle_, {});
  }
}

void Instancer::finalize(SyncContext& context) {
  context.sceneChanged = true;
  unlist(context, listedUnder_, id());
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
