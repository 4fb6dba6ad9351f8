// The UsdLux lights the render delegate renders, defined once: one table (lightTypes) of each
// one's UsdLux schema, light sprim type and renderer light type, and one (lightInputs) of the
// inputs a light sprim takes, by which Light::setParam sets them and from which the Python
// scene delegate derives what it reads from a UsdLux light.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "penumbra/light.h"

namespace penumbra::plugin {

struct LightTypeInfo {
  std::string schema;     // UsdLux schema type name ("RectLight")
  std::string sprimType;  // the light sprim's type ("rectLight")
  LightType type;
};

/// Every supported light type.
const std::vector<LightTypeInfo>& lightTypes();
bool isLightTypeName(const std::string& sprimType);
/// The renderer light type of a light sprim type; throws std::invalid_argument for another name.
LightType lightTypeFromName(const std::string& sprimType);

/// The value a light input takes.
enum class LightInputKind : uint8_t { Float, Color, Bool, Asset };

/// Where a scene delegate finds a light input.
enum class LightInputOrigin : uint8_t {
  /// UsdLuxLightAPI: every light, mesh lights included.
  LightAPI,
  /// The schema of the light types that LightInputInfo::lightTypes lists (a shape, a texture).
  LightSchema,
  /// UsdLuxShapingAPI, where applied.
  ShapingAPI,
  /// UsdLuxShadowAPI, where applied.
  ShadowAPI,
  /// No UsdLux input: the front end's choice (usdrecord hides dome lights from the camera).
  FrontEnd,
};

/// The LightParams member an input sets; none for texture:file, which the light loads itself
/// (Light::sync), and for treatAsLine, a hint only (the cylinder itself is always rendered).
using LightParamMember =
    std::variant<std::monostate, float LightParams::*, bool LightParams::*, Vec3f LightParams::*>;

/// One input of the table.
struct LightInputInfo {
  /// As UsdLux spells it without "inputs:" ("shaping:cone:angle"; treatAsPoint and treatAsLine
  /// have no "inputs:").
  std::string name;
  LightInputKind kind;
  LightInputOrigin origin;
  LightParamMember member;
  /// For LightSchema inputs, the light types whose schema has it; empty otherwise.
  std::vector<LightType> lightTypes;
};

/// Every input: UsdLuxLightAPI's, the light schemas', UsdLuxShapingAPI's, UsdLuxShadowAPI's, then
/// the front end's.
const std::vector<LightInputInfo>& lightInputs();
/// The input named `name`; nullptr for another name.
const LightInputInfo* findLightInput(const std::string& name);

}  // namespace penumbra::plugin
