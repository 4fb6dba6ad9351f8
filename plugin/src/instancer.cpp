#include "penumbra/plugin/instancer.h"

#include <stdexcept>

#include "penumbra/plugin/mesh.h"

namespace penumbra::plugin {

void Instancer::sync(SyncContext& context, Mesh* prototype) {
  Scene& scene = context.scene;
  if (!prototype) {
    scene.removeInstancer(handle_);
    handle_ = scene.addInstancer();
  } else {
    // As in Hydra, the prototype knows its instancer (its removal drops the copies).
    prototype->addInstancer(id());
    scene.setInstancerPassVisibility(handle_, pass_);
    scene.setInstances(handle_, prototype->handle(), transforms_, visible_);
    try {
      scene.setInstancePrimvars(handle_, primvars_);
    } catch (const std::invalid_argument& error) {
      context.warn(id() + ": " + error.what() + "; the per-instance primvars are ignored");
      scene.setInstancePrimvars(handle_, {});
    }
  }
  markClean();
}

}  // namespace penumbra::plugin
