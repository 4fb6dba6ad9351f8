// What a prim's sync reads and changes besides the prim itself (cf. Hydra's HdRenderParam, which
// HdRprim::Sync receives): the scene, the material indices, the dicing context, the warnings and
// the sync counters. The render delegate builds one per sync (docs/architecture.md).
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
  double tessellationSeconds = 0;  // triangulating and dicing meshes
};

struct SyncContext {
  Scene& scene;
  /// The scene's index of each material sprim.
  const std::map<PrimId, int>& materialIndex;
  const DicingContext& dicing;
  /// RenderSettingsMap::complexity: how finely subdivision surfaces are diced.
  int complexity = 0;
  std::vector<std::string>& warnings;
  SyncCounters& counters;

  void warn(std::string message) { warnings.push_back(std::move(message)); }
};

}  // namespace penumbra::plugin
