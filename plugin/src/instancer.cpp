#include "penumbra/plugin/instancer.h"

#include <stdexcept>

#include "penumbra/plugin/mesh.h"

namespace penumbra::plugin {

void Instancer::sync(SyncContext& context, Mesh* prototype) {
  Scene& scene = context.scene;
  if (!prototype) {
    scene.geometry().removeInstancer(handle_);
    handle_ = scene.geometry().addInstancer();
  } else {
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
  markClean();
}

}  // namespace penumbra::plugin
