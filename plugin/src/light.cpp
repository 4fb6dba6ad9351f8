#include "penumbra/plugin/light.h"

#include <stdexcept>

#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {

Light::Light(PrimId id, LightType type, std::optional<Geometry::MeshId> emittingMesh)
    : Prim(std::move(id)), emittingMesh_(emittingMesh) {
  params_.type = type;
  // UsdLux's fallback intensity differs for DistantLight (sunlight).
  if (type == LightType::Distant) params_.intensity = 50000;
}

void Light::setParam(const std::string& name, const ParamValue& value) {
  static const std::map<std::string, float LightParams::*> numbers = {
      {"intensity", &LightParams::intensity},
      {"exposure", &LightParams::exposure},
      {"colorTemperature", &LightParams::colorTemperature},
      {"diffuse", &LightParams::diffuse},
      {"specular", &LightParams::specular},
      {"width", &LightParams::width},
      {"height", &LightParams::height},
      {"radius", &LightParams::radius},
      {"length", &LightParams::length},
      {"angle", &LightParams::angle},
      {"shaping:cone:angle", &LightParams::coneAngle},
      {"shaping:cone:softness", &LightParams::coneSoftness},
      {"shaping:focus", &LightParams::focus}};
  static const std::map<std::string, bool LightParams::*> flags = {
      {"normalize", &LightParams::normalize},
      {"enableColorTemperature", &LightParams::enableColorTemperature},
      {"treatAsPoint", &LightParams::treatAsPoint},
      {"shadow:enable", &LightParams::shadowEnable},
      {"cameraVisible", &LightParams::cameraVisible}};
  static const std::map<std::string, Vec3f LightParams::*> colors = {
      {"color", &LightParams::color}, {"shaping:focusTint", &LightParams::focusTint}};
  try {
    if (const auto number = numbers.find(name); number != numbers.end())
      params_.*(number->second) = paramAsFloat(name, value);
    else if (const auto flag = flags.find(name); flag != flags.end())
      params_.*(flag->second) = paramAsBool(name, value);
    else if (const auto color = colors.find(name); color != colors.end())
      params_.*(color->second) = paramAsColor(name, value);
    else if (name == "texture:file")
      textureFile_ = paramAsString(name, value);
    else if (name == "treatAsLine")
      paramAsBool(name, value);  // a hint only: the cylinder itself is always rendered
    else
      throw std::invalid_argument("unknown light parameter '" + name + "'");
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(id() + ": " + error.what());
  }
  markDirty(DirtyParams);
}

void Light::loadTexture(SyncContext& context) {
  if (textureFile_ == loadedTextureFile_) return;
  loadedTextureFile_ = textureFile_;
  params_.texture.reset();
  if (textureFile_.empty()) return;
  ++context.counters.lightTextureLoads;
  params_.texture = LightTexture::load(context.scene.materials().sharedTextures(), textureFile_,
                                       params_.type == LightType::Dome);
}

void Light::setMeshTriangles(std::shared_ptr<const std::vector<Vec3f>> triangles) {
  params_.meshTriangles = std::move(triangles);
  markDirty(DirtyParams);
}

void Light::sync(SyncContext& context, uint32_t dirtyBits) {
  if (dirtyBits & DirtyParams) {
    try {
      loadTexture(context);
    } catch (const std::runtime_error& error) {
      context.warn(id() + ": " + error.what() + "; the light renders without its texture");
    }
  }
  std::optional<penumbra::Light> rendered;
  if (visible_) {
    ++context.counters.lightBuilds;
    try {
      rendered.emplace(params_);
    } catch (const std::invalid_argument& error) {
      context.warn(id() + ": " + error.what() + "; the light is skipped");
    }
  }
  context.lights.synced(id(), std::move(rendered), context.scene, emittingMesh_);
}

void Light::finalize(SyncContext& context) {
  context.lights.remove(id());
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
