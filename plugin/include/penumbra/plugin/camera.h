// Camera sprim: UsdGeomCamera's parameters and transform. It puts nothing in the scene: render
// passes read its parameters, and its sync tells them that it changed.
#pragma once

#include <stdexcept>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"

namespace penumbra::plugin {

class Camera : public Prim {
 public:
  using Prim::Prim;

  /// Sets everything but the transform; animated lens samples are reset to the scalars.
  void setParams(const CameraParams& params) {
    const MotionTransform transform = params_.cameraToWorld;
    params_ = params;
    params_.cameraToWorld = transform;
    markDirty(DirtyParams);
  }
  /// Focal length and focus distance sampled uniformly over the shutter (same count, >= 1).
  void setLensMotion(std::vector<float> focalLengths, std::vector<float> focusDistances) {
    if (focalLengths.empty() || focalLengths.size() != focusDistances.size())
      throw std::invalid_argument(
          id() + ": lens motion needs as many focus distances as focal lengths (>= 1)");
    params_.focalLengthSteps = std::move(focalLengths);
    params_.focusDistanceSteps = std::move(focusDistances);
    markDirty(DirtyParams);
  }
  void setTransform(const MotionTransform& cameraToWorld) override {
    params_.cameraToWorld = cameraToWorld;
    markDirty(DirtyTransform);
  }
  const CameraParams& params() const { return params_; }

  void sync(SyncContext& context, uint32_t) override { context.camerasChanged = true; }

 private:
  CameraParams params_;
};

}  // namespace penumbra::plugin
