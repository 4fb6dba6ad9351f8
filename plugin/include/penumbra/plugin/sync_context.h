// What a prim's sync and finalize read and change besides the prim itself (cf. Hydra's
// HdRenderParam, which HdRprim::Sync, HdSprim::Sync and their Finalize receive): the renderer's
// scene, the material indices, the light list, the meshes, points, curves and instancers (which
// instancers and their prototypes reach each other through), the volumes' field cache, the dicing
// context, the warnings and the sync counters. The render delegate owns one for its lifetime
// (docs/architecture.md).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/light.h"
#include "penumbra/plugin/ies_profile_cache.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/prim_collection.h"
#include "penumbra/plugin/volume_field_cache.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

class Mesh;
class Points;
class Curves;
class Instancer;

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

/// Each material sprim's index in the scene's material list, from its insertion to its removal,
/// so that an edit of one material leaves the meshes bound to others as they are. Indices freed
/// by removals are used again, lowest first.
class MaterialIndices {
 public:
  /// Gives material `id` an index: its entry stays empty until the material syncs.
  int insert(const PrimId& id, Scene& scene);
  /// Frees material `id`'s index: its entry is empty until another material takes it.
  void remove(const PrimId& id, Scene& scene);
  /// The index of material `id`, if it is in the render index.
  std::optional<int> find(const PrimId& id) const;
  /// The index of material `id`; throws std::out_of_range if it is not in the render index.
  int at(const PrimId& id) const { return index_.at(id); }
  /// The materials inserted or removed since the last call: the meshes naming them render with
  /// them now, or with their displayColor.
  std::set<PrimId> takeInsertedOrRemoved() { return std::exchange(insertedOrRemoved_, {}); }

 private:
  std::map<PrimId, int> index_;
  std::set<int> free_;
  std::set<PrimId> insertedOrRemoved_;
};

/// The scene's light list: light sprims and mesh lights in id order, so that the order they are
/// sampled in does not depend on the order of edits. A light that syncs hands its renderer light
/// over (synced); after the prims synced, the render delegate puts them in the scene (update).
class LightList {
 public:
  /// Light `id` synced into `rendered` (none: it does not render now); `emittingMesh`: the
  /// mesh whose surface emits, for a mesh light. The light joins the list, replaces its entry
  /// there, or leaves it.
  void synced(const PrimId& id, std::optional<penumbra::Light> rendered, Scene& scene,
              std::optional<Geometry::MeshId> emittingMesh);
  /// Light `id` left the render index.
  void remove(const PrimId& id);
  /// Puts the lights synced since the last update in the scene's list: the whole list again
  /// when lights joined or left it (the others' renderer lights moved along as they are, not
  /// built again), else each in its own entry. Returns true if the scene's lights changed.
  bool update(Scene& scene);

 private:
  struct Entry {
    int index;  // in the scene's list; -1 until the update after it joined
    std::optional<Geometry::MeshId> emittingMesh;
  };
  std::map<PrimId, Entry> listed_;
  std::map<PrimId, penumbra::Light> synced_;  // since the last update
  bool structureChanged_ = false;             // lights joined or left the list
};

struct SyncContext {
  SyncContext(Scene& renderScene, PrimCollection<Mesh>& meshPrims,
              PrimCollection<Points>& pointsPrims, PrimCollection<Curves>& curvesPrims,
              PrimCollection<Instancer>& instancerPrims)
      : scene(renderScene),
        meshes(meshPrims),
        points(pointsPrims),
        curves(curvesPrims),
        instancers(instancerPrims) {}

  Scene& scene;
  PrimCollection<Mesh>& meshes;
  PrimCollection<Points>& points;
  PrimCollection<Curves>& curves;
  PrimCollection<Instancer>& instancers;
  MaterialIndices materials;
  LightList lights;
  /// The instancers naming each prototype id, as they last synced (Instancer::sync), whether
  /// or not a prototype of that id is in the render index: its removal drops their copies, its
  /// insertion has them placed again.
  std::map<PrimId, std::set<PrimId>> instancersByPrototype;
  /// The context of this sync (set by the render delegate before the prims sync).
  DicingContext dicing;
  /// The volumes' fields read from files, shared between volumes, syncs and frames.
  VolumeFieldCache volumeFields;
  /// The lights' IES profiles read from files, shared likewise.
  IesProfileCache iesProfiles;
  /// RenderSettingsMap::complexity: how finely subdivision surfaces are diced.
  int complexity = 0;
  std::vector<std::string> warnings;
  SyncCounters counters;
  /// Raised by the syncs and finalizes that change the scene's contents (renders restart on a
  /// new scene version), and by camera syncs; the render delegate lowers them after each sync.
  bool sceneChanged = false;
  bool camerasChanged = false;

  void warn(std::string message) { warnings.push_back(std::move(message)); }
};

}  // namespace penumbra::plugin
