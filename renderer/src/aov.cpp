#include "penumbra/aov.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "penumbra/hair_bsdf.h"

namespace penumbra {
namespace {

constexpr const char* kPrimvarPrefix = "primvars:";

const std::vector<std::pair<std::string, AovKind>>& namedAovs() {
  static const std::vector<std::pair<std::string, AovKind>> names = {
      {"color", AovKind::Color},
      {"alpha", AovKind::Alpha},
      {"depth", AovKind::Depth},
      {"Z", AovKind::Z},
      {"normal", AovKind::Normal},
      {"Neye", AovKind::CameraNormal},
      {"position", AovKind::Position},
      {"albedo", AovKind::Albedo},
      {"primId", AovKind::PrimId},
      {"instanceId", AovKind::InstanceId},
      {"elementId", AovKind::ElementId},
      {"sampleCount", AovKind::SampleCount},
      {"variance", AovKind::Variance},
      {"CryptoObject", AovKind::CryptoObject},
      {"CryptoMaterial", AovKind::CryptoMaterial},
      {"CryptoAsset", AovKind::CryptoAsset},
  };
  return names;
}

}  // namespace

bool AovRequest::needsFirstHit() const {
  return kind != AovKind::Color && kind != AovKind::Alpha && kind != AovKind::Z &&
         kind != AovKind::SampleCount && kind != AovKind::Variance;
}

const std::vector<std::string>& aovNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> result;
    for (const auto& [name, kind] : namedAovs()) result.push_back(name);
    result.push_back(std::string(kPrimvarPrefix) + "NAME");
    return result;
  }();
  return names;
}

AovRequest parseAov(const std::string& name) {
  for (const auto& [known, kind] : namedAovs())
    if (name == known) return {kind, {}};
  const std::string prefix = kPrimvarPrefix;
  if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0)
    return {AovKind::Primvar, PrimvarName(name.substr(prefix.size()))};
  std::string list;
  for (const std::string& known : aovNames()) list += (list.empty() ? "" : ", ") + known;
  throw std::invalid_argument("unknown AOV '" + name + "' (known: " + list + ")");
}

Vec3f surfaceAlbedo(const MaterialParams& material) {
  // A fibre's colour is that of its absorption under multiple scattering (Chiang et al.).
  if (material.hair) return hairColorAt(material);
  Vec3f reflectance = material.diffuseColor;
  if (material.useSpecularWorkflow) reflectance += material.specularColor;
  reflectance = {std::min(reflectance.x, 1.0f), std::min(reflectance.y, 1.0f),
                 std::min(reflectance.z, 1.0f)};
  const float opacity = std::clamp(material.opacity, 0.0f, 1.0f);
  return reflectance * opacity + Vec3f(1.0f - opacity);
}

}  // namespace penumbra
