#include "penumbra/plugin/points.h"

#include <stdexcept>

namespace penumbra::plugin {

void Points::setPositions(std::vector<Vec3f> positions,
                          std::vector<std::vector<Vec3f>> positionMotion) {
  data_.positions = std::move(positions);
  data_.positionMotion = std::move(positionMotion);
  markDirty(DirtyPoints);
}

void Points::setWidths(std::vector<float> widths) {
  data_.widths = std::move(widths);
  markDirty(DirtyPoints);
}

void Points::setNormals(std::vector<Vec3f> normals) {
  data_.normals = std::move(normals);
  markDirty(DirtyPoints);  // spheres or discs: another shape
}

void Points::setDisplayColor(std::vector<Vec3f> colors, Interpolation interpolation) {
  data_.displayColor = std::move(colors);
  data_.displayColorInterpolation = interpolation;
  markDirty(DirtyPrimvar);
}

void Points::setPrimvars(std::vector<Primvar> primvars) {
  data_.primvars = std::move(primvars);
  markDirty(DirtyPrimvar);
}

void Points::sync(SyncContext& context, uint32_t bits) {
  context.sceneChanged = true;
  if (bits & (DirtyPoints | DirtyPrimvar)) {
    try {
      context.scene.geometry().setPointsGeometry(handle(), data_);
    } catch (const std::invalid_argument& error) {
      context.warn(id() + ": " + error.what() + "; skipped");
      context.scene.geometry().clearMeshGeometry(handle());
    }
  }
  syncPlacement(context, bits);
}

void Points::finalize(SyncContext& context) {
  context.sceneChanged = true;
  context.scene.geometry().removeMesh(handle());
}

}  // namespace penumbra::plugin
