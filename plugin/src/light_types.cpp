#include "penumbra/plugin/light_types.h"

#include <stdexcept>

namespace penumbra::plugin {

const std::vector<LightTypeInfo>& lightTypes() {
  static const std::vector<LightTypeInfo> types = {
      {"RectLight", "rectLight", LightType::Rect},
      {"DiskLight", "diskLight", LightType::Disk},
      {"SphereLight", "sphereLight", LightType::Sphere},
      {"CylinderLight", "cylinderLight", LightType::Cylinder},
      {"DistantLight", "distantLight", LightType::Distant},
      {"DomeLight", "domeLight", LightType::Dome}};
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

const std::vector<LightInputInfo>& lightInputs() {
  using Kind = LightInputKind;
  using Origin = LightInputOrigin;
  using P = LightParams;
  using T = LightType;
  static const std::vector<LightInputInfo> inputs = {
      {"color", Kind::Color, Origin::LightAPI, &P::color, {}},
      {"intensity", Kind::Float, Origin::LightAPI, &P::intensity, {}},
      {"exposure", Kind::Float, Origin::LightAPI, &P::exposure, {}},
      {"normalize", Kind::Bool, Origin::LightAPI, &P::normalize, {}},
      {"enableColorTemperature", Kind::Bool, Origin::LightAPI, &P::enableColorTemperature, {}},
      {"colorTemperature", Kind::Float, Origin::LightAPI, &P::colorTemperature, {}},
      {"diffuse", Kind::Float, Origin::LightAPI, &P::diffuse, {}},
      {"specular", Kind::Float, Origin::LightAPI, &P::specular, {}},
      {"width", Kind::Float, Origin::LightSchema, &P::width, {T::Rect}},
      {"height", Kind::Float, Origin::LightSchema, &P::height, {T::Rect}},
      {"radius", Kind::Float, Origin::LightSchema, &P::radius, {T::Disk, T::Sphere, T::Cylinder}},
      {"length", Kind::Float, Origin::LightSchema, &P::length, {T::Cylinder}},
      {"treatAsPoint", Kind::Bool, Origin::LightSchema, &P::treatAsPoint, {T::Sphere}},
      {"treatAsLine", Kind::Bool, Origin::LightSchema, std::monostate{}, {T::Cylinder}},
      {"angle", Kind::Float, Origin::LightSchema, &P::angle, {T::Distant}},
      {"texture:file", Kind::Asset, Origin::LightSchema, std::monostate{}, {T::Rect, T::Dome}},
      {"shaping:cone:angle", Kind::Float, Origin::ShapingAPI, &P::coneAngle, {}},
      {"shaping:cone:softness", Kind::Float, Origin::ShapingAPI, &P::coneSoftness, {}},
      {"shaping:focus", Kind::Float, Origin::ShapingAPI, &P::focus, {}},
      {"shaping:focusTint", Kind::Color, Origin::ShapingAPI, &P::focusTint, {}},
      {"shaping:ies:file", Kind::Asset, Origin::ShapingAPI, std::monostate{}, {}},
      {"shaping:ies:angleScale", Kind::Float, Origin::ShapingAPI, &P::iesAngleScale, {}},
      {"shaping:ies:normalize", Kind::Bool, Origin::ShapingAPI, &P::iesNormalize, {}},
      {"shadow:enable", Kind::Bool, Origin::ShadowAPI, &P::shadowEnable, {}},
      {"cameraVisible", Kind::Bool, Origin::FrontEnd, &P::cameraVisible, {}}};
  return inputs;
}

const LightInputInfo* findLightInput(const std::string& name) {
  for (const LightInputInfo& input : lightInputs())
    if (input.name == name) return &input;
  return nullptr;
}

}  // namespace penumbra::plugin
