// What a prim's sync reads and changes besides the prim itself (cf. Hydra's HdRenderParam, which
// HdRprim::Sync and HdSprim::Sync receive): the scene, the material indices, the dicing context,
// the warnings and the sync counters. The render delegate builds one per sync
// (docs/architecture.md).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

/// What subdivision surfaces are diced for: a camera and an image width.
struct DicingContext {
  CameraParams camera;
  int imageWidth = 960;

  bool operator==(const DicingContext& other) const;
  bool operator!=(const DicingContext& other) const { return !(*this == other); }
};

/// What syncs have done so far (RenderDelegate::syncStatistics).
struct SyncCounters {
  uint64_t meshGeometrySyncs = 0;
  uint64_t subdivisionDicings = 0;
  double tessellationSeconds = 0;     // triangulating and dicing meshes
  uint64_t materialBuilds = 0;        // renderer materials built (Material::sync)
  uint64_t materialTextureOpens = 0;  // textures those builds opened
  uint64_t lightBuilds = 0;           // renderer lights built (Light::sync), mesh lights too
  uint64_t lightTextureLoads = 0;     // light textures (texture:file) loaded
};

struct SyncContext {
  Scene& scene;
  /// The scene's index of each material sprim: fixed from its insertion to its removal, so
  /// that an edit of one material leaves the meshes bound to others as they are.
  const std::map<PrimId, int>& materialIndex;
  const DicingContext& dicing;
  /// RenderSettingsMap::complexity: how finely subdivision surfaces are diced.
  int complexity = 0;
  std::vector<std::string>& warnings;
  SyncCounters& counters;

  void warn(std::string message) { warnings.push_back(std::move(message)); }
};

}  // namespace penumbra::plugin
