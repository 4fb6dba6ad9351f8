// Light sprims: one class for the UsdLux intrinsic lights, the type fixed at insertion.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/light.h"
#include "penumbra/motion.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"

namespace penumbra::plugin {

class Light : public Prim {
 public:
  Light(PrimId id, LightType type);

  /// Sets a UsdLux input by its name without "inputs:" (color, intensity, exposure, normalize,
  /// enableColorTemperature, colorTemperature, diffuse, specular, width, height, radius, length,
  /// angle, treatAsPoint, treatAsLine, texture:file, shaping:cone:angle, shaping:cone:softness,
  /// shaping:focus, shaping:focusTint, shadow:enable).
  /// Throws std::invalid_argument for an unknown name or a value of the wrong type.
  void setParam(const std::string& name, const ParamValue& value);
  /// Lights keep their transform at the start of the shutter (motion blur of lights is not
  /// supported yet): only the first sample is used.
  void setTransform(const MotionTransform& lightToWorld);
  void setVisible(bool visible);
  /// A mesh light's emitting triangles in world space (3 points each), set by its mesh's sync.
  void setMeshTriangles(std::shared_ptr<const std::vector<Vec3f>> triangles);

  /// Builds its renderer light from what its dirty bits say changed (cf. HdLight::Sync):
  /// texture:file is loaded only when the file changed (a warning names a file that cannot be
  /// read: the light then renders untextured), and a light whose inputs are invalid is skipped
  /// with a warning, once per change. Then it is clean; the render delegate moves the light
  /// into the scene's light list (takeRendered).
  void sync(SyncContext& context);
  /// The renderer light built by the last sync, handed over once; none if the light is hidden
  /// or was skipped.
  std::optional<penumbra::Light> takeRendered() { return std::exchange(rendered_, std::nullopt); }

  const LightParams& params() const { return params_; }
  bool visible() const { return visible_; }

 private:
  /// Loads texture:file if it changed since the last call. Throws std::runtime_error naming the
  /// file when it cannot be read.
  void loadTexture(SyncContext& context);

  LightParams params_;
  bool visible_ = true;
  std::string textureFile_, loadedTextureFile_;
  std::optional<penumbra::Light> rendered_;
};

}  // namespace penumbra::plugin
