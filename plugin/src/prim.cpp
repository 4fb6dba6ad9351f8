#include "penumbra/plugin/prim.h"

#include <stdexcept>

namespace penumbra::plugin {

void Prim::setTransform(const MotionTransform&) {
  throw std::invalid_argument(id_ + ": this prim has no transform");
}

void Prim::setVisible(bool) {
  throw std::invalid_argument(id_ + ": this prim has no visibility");
}

void Prim::setPassVisibility(PassVisibility) {
  throw std::invalid_argument(id_ + ": only meshes, points and instancers take pass visibility");
}

void Prim::setMaterialId(PrimId) {
  throw std::invalid_argument(id_ + ": only meshes and points are bound to materials");
}

}  // namespace penumbra::plugin
