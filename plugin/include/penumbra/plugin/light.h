// Light sprims: one class for the UsdLux intrinsic lights, the type fixed at insertion.
#pragma once

#include "penumbra/light.h"
#include "penumbra/motion.h"
#include "penumbra/plugin/prim.h"

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
  /// Loads texture:file (through `textures`) if it changed since the last call. Throws
  /// std::runtime_error naming the file when it cannot be read (the light then renders
  /// untextured).
  void loadTexture(std::shared_ptr<TextureSystem> textures);
  /// Lights keep their transform at the start of the shutter (motion blur of lights is not
  /// supported yet): only the first sample is used.
  void setTransform(const MotionTransform& lightToWorld);
  void setVisible(bool visible);

  const LightParams& params() const { return params_; }
  bool visible() const { return visible_; }

 private:
  LightParams params_;
  bool visible_ = true;
  std::string textureFile_, loadedTextureFile_;
};

/// The light type for a sprim type name ("rectLight", ...); throws std::invalid_argument.
LightType lightTypeFromName(const std::string& typeName);
bool isLightTypeName(const std::string& typeName);

}  // namespace penumbra::plugin
