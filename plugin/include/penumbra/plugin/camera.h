// Camera sprim: UsdGeomCamera's parameters and transform.
#pragma once

#include "penumbra/camera.h"
#include "penumbra/plugin/prim.h"

namespace penumbra::plugin {

class Camera : public Prim {
 public:
  using Prim::Prim;

  void setParams(const CameraParams& params) {
    const Transform transform = params_.cameraToWorld;
    params_ = params;
    params_.cameraToWorld = transform;
    markDirty(DirtyParams);
  }
  void setTransform(const Transform& cameraToWorld) {
    params_.cameraToWorld = cameraToWorld;
    markDirty(DirtyTransform);
  }
  const CameraParams& params() const { return params_; }

 private:
  CameraParams params_;
};

}  // namespace penumbra::plugin
