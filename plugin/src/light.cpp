#include "penumbra/plugin/light.h"

#include <stdexcept>
#include <variant>

#include "penumbra/plugin/light_types.h"
#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {

Light::Light(PrimId id, LightType type, std::optional<Geometry::MeshId> emittingMesh)
    : Prim(std::move(id)), emittingMesh_(emittingMesh) {
  params_.type = type;
  // UsdLux's fallback intensity differs for DistantLight (sunlight).
  if (type == LightType::Distant) params_.intensity = 50000;
}

void Light::setParam(const std::string& name, const ParamValue& value) {
  try {
    const LightInputInfo* input = findLightInput(name);
    if (!input) throw std::invalid_argument("unknown light parameter '" + name + "'");
    switch (input->kind) {
      case LightInputKind::Float:
        params_.*std::get<float LightParams::*>(input->member) = paramAsFloat(name, value);
        break;
      case LightInputKind::Color:
        params_.*std::get<Vec3f LightParams::*>(input->member) = paramAsColor(name, value);
        break;
      case LightInputKind::Bool: {
        const bool flag = paramAsBool(name, value);
        // Checked even where it sets nothing (treatAsLine, a hint only).
        if (const auto* member = std::get_if<bool LightParams::*>(&input->member))
          params_.*(*member) = flag;
        break;
      }
      case LightInputKind::Asset:
        (name == "shaping:ies:file" ? ies_ : texture_).file = paramAsString(name, value);
        break;
    }
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(id() + ": " + error.what());
  }
  markDirty(DirtyParams);
}

void Light::loadTexture(SyncContext& context) {
  if (!texture_.takeReload()) return;
  params_.texture.reset();
  if (texture_.file.empty()) return;
  ++context.counters.lightTextureLoads;
  params_.texture = LightTexture::load(context.scene.materials().sharedTextures(), texture_.file,
                                       params_.type == LightType::Dome);
}

void Light::loadIes(SyncContext& context) {
  if (!ies_.takeReload()) return;
  params_.ies.reset();
  if (!ies_.file.empty()) params_.ies = context.iesProfiles.load(ies_.file);
}

void Light::setMeshTriangles(std::shared_ptr<const std::vector<Vec3f>> triangles,
                             std::shared_ptr<const MovingMeshLight> motion) {
  params_.meshTriangles = std::move(triangles);
  params_.meshMotion = std::move(motion);
  markDirty(DirtyParams);
}

void Light::sync(SyncContext& context, uint32_t dirtyBits) {
  if (dirtyBits & DirtyParams) {
    try {
      loadTexture(context);
    } catch (const std::runtime_error& error) {
      context.warn(id() + ": " + error.what() + "; the light renders without its texture");
    }
    try {
      loadIes(context);
    } catch (const std::exception& error) {  // a bad_alloc too: the profile, not the render
      context.warn(id() + ": " + error.what() + "; the light renders without its IES profile");
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
