// The UsdLux lights the render delegate renders: one table (lightTypes) of each one's UsdLux
// schema, light sprim type and renderer light type, which the Python scene delegate reads too.
#pragma once

#include <string>
#include <vector>

#include "penumbra/light.h"

namespace penumbra::plugin {

struct LightTypeInfo {
  std::string schema;     // UsdLux schema type name ("RectLight")
  std::string sprimType;  // the light sprim's type ("rectLight")
  LightType type;
  /// The schema's own inputs that shape the light (beside UsdLuxLightAPI's), by the parameter
  /// names Light::setParam takes.
  std::vector<std::string> shapeInputs;
};

/// Every supported light type.
const std::vector<LightTypeInfo>& lightTypes();
bool isLightTypeName(const std::string& sprimType);
/// The renderer light type of a light sprim type; throws std::invalid_argument for another name.
LightType lightTypeFromName(const std::string& sprimType);

}  // namespace penumbra::plugin
