// Prims the C++ render tests build their scenes from.
#pragma once

#include "penumbra/plugin/render_delegate.h"

namespace penumbra::test {

/// A square in the XZ plane at height y, facing +Y (counter-clockwise seen from above).
inline void addFloor(plugin::RenderDelegate& delegate, const plugin::PrimId& id, float halfSize,
                     float y = 0) {
  delegate.insertRprim("mesh", id);
  plugin::Mesh& mesh = delegate.mesh(id);
  mesh.setPoints({{-halfSize, y, -halfSize},
                  {-halfSize, y, halfSize},
                  {halfSize, y, halfSize},
                  {halfSize, y, -halfSize}});
  mesh.setTopology({4}, {0, 1, 2, 3}, false, "none");
}

/// Camera "/cam" with a square aperture of 1 (its field of view set by `focalLength`).
inline void addCamera(plugin::RenderDelegate& delegate, const Transform& transform,
                      float focalLength = 50) {
  delegate.insertSprim("camera", "/cam");
  CameraParams params;
  params.focalLength = focalLength;
  params.horizontalAperture = params.verticalAperture = 1;
  params.nearClip = 0.01f;
  delegate.camera("/cam").setParams(params);
  delegate.camera("/cam").setTransform(transform);
}

}  // namespace penumbra::test
