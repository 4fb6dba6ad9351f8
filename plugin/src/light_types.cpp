#include "penumbra/plugin/light_types.h"

#include <stdexcept>

namespace penumbra::plugin {

const std::vector<LightTypeInfo>& lightTypes() {
  static const std::vector<LightTypeInfo> types = {
      {"RectLight", "rectLight", LightType::Rect, {"width", "height"}},
      {"DiskLight", "diskLight", LightType::Disk, {"radius"}},
      {"SphereLight", "sphereLight", LightType::Sphere, {"radius", "treatAsPoint"}},
      {"CylinderLight", "cylinderLight", LightType::Cylinder, {"radius", "length", "treatAsLine"}},
      {"DistantLight", "distantLight", LightType::Distant, {"angle"}},
      {"DomeLight", "domeLight", LightType::Dome, {}}};
  return types;
}

bool isLightTypeName(const std::string& sprimType) {
  for (const LightTypeInfo& info : lightTypes())
    if (info.sprimType == sprimType) return true;
  return false;
}

LightType lightTypeFromName(const std::string& sprimType) {
  for (const LightTypeInfo& info : lightTypes())
    if (info.sprimType == sprimType) return info.type;
  throw std::invalid_argument("unknown light type " + sprimType);
}

}  // namespace penumbra::plugin
