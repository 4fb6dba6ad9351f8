#include "penumbra/plugin/light.h"

#include <map>

#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {
namespace {

const std::map<std::string, LightType>& lightTypes() {
  static const std::map<std::string, LightType> types = {{"rectLight", LightType::Rect},
                                                         {"diskLight", LightType::Disk},
                                                         {"sphereLight", LightType::Sphere},
                                                         {"distantLight", LightType::Distant},
                                                         {"domeLight", LightType::Dome}};
  return types;
}

}  // namespace

bool isLightTypeName(const std::string& typeName) {
  return lightTypes().count(typeName) != 0;
}

LightType lightTypeFromName(const std::string& typeName) {
  const auto found = lightTypes().find(typeName);
  if (found == lightTypes().end()) throw std::invalid_argument("unknown light type " + typeName);
  return found->second;
}

Light::Light(PrimId id, LightType type) : Prim(std::move(id)) {
  params_.type = type;
  // UsdLux's fallback intensity differs for DistantLight (sunlight).
  if (type == LightType::Distant) params_.intensity = 50000;
}

void Light::setParam(const std::string& name, const ParamValue& value) {
  try {
    LightParams& p = params_;
    if (name == "color")
      p.color = paramAsColor(name, value);
    else if (name == "intensity")
      p.intensity = paramAsFloat(name, value);
    else if (name == "exposure")
      p.exposure = paramAsFloat(name, value);
    else if (name == "normalize")
      p.normalize = paramAsBool(name, value);
    else if (name == "enableColorTemperature")
      p.enableColorTemperature = paramAsBool(name, value);
    else if (name == "colorTemperature")
      p.colorTemperature = paramAsFloat(name, value);
    else if (name == "width")
      p.width = paramAsFloat(name, value);
    else if (name == "height")
      p.height = paramAsFloat(name, value);
    else if (name == "radius")
      p.radius = paramAsFloat(name, value);
    else if (name == "angle")
      p.angle = paramAsFloat(name, value);
    else if (name == "treatAsPoint")
      p.treatAsPoint = paramAsBool(name, value);
    else
      throw std::invalid_argument("unknown light parameter '" + name + "'");
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(id() + ": " + error.what());
  }
  markDirty(DirtyParams);
}

void Light::setTransform(const MotionTransform& lightToWorld) {
  params_.lightToWorld = lightToWorld.first();
  markDirty(DirtyTransform);
}

void Light::setVisible(bool visible) {
  visible_ = visible;
  markDirty(DirtyVisibility);
}

}  // namespace penumbra::plugin
