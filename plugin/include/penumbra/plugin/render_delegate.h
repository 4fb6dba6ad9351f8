// The render delegate (cf. HdRenderDelegate + HdRenderIndex): creates and owns prims by id, one
// collection per kind, holds the render settings and the SyncContext (cf. HdRenderParam), and
// syncs the dirty prims into the renderer's Scene, kind by kind in a fixed order; each prim
// syncs itself (Prim::sync) and takes itself out when removed (Prim::finalize)
// (docs/architecture.md).
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/cryptomatte.h"
#include "penumbra/plugin/camera.h"
#include "penumbra/plugin/curves.h"
#include "penumbra/plugin/instancer.h"
#include "penumbra/plugin/light.h"
#include "penumbra/plugin/material.h"
#include "penumbra/plugin/mesh.h"
#include "penumbra/plugin/points.h"
#include "penumbra/plugin/prim_collection.h"
#include "penumbra/plugin/render_buffer.h"
#include "penumbra/plugin/render_settings.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/plugin/volume.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

class RenderDelegate {
 public:
  /// `colorConfig`: the OCIO config that linearises sRGB textures (empty: $OCIO).
  explicit RenderDelegate(const std::string& colorConfig = {});
  ~RenderDelegate();

  /// Rprim types: "mesh", "points", "basisCurves", "volume", "instancer". Sprim types: "camera",
  /// "material", and the light types (lightTypes()). Throws std::invalid_argument for an unknown
  /// type or an id already in use. Instancers copying a prototype of a new mesh's, points' or
  /// curves' id place their copies of it at the next sync.
  void insertRprim(const std::string& type, const PrimId& id);
  void insertSprim(const std::string& type, const PrimId& id);
  /// Bprim types: "renderBuffer".
  void insertBprim(const std::string& type, const PrimId& id);
  /// Takes the prim out of the renderer (Prim::finalize) and drops it; the instancers copying
  /// it drop their copies until a prototype with its id is back. Throws std::out_of_range for an
  /// unknown id.
  void removePrim(const PrimId& id);
  bool hasPrim(const PrimId& id) const;
  std::vector<PrimId> primIds() const;

  /// Typed access; throws std::out_of_range naming the id when it is missing or of another type.
  Mesh& mesh(const PrimId& id);
  Points& points(const PrimId& id);
  Curves& curves(const PrimId& id);
  Volume& volume(const PrimId& id);
  RenderBuffer& renderBuffer(const PrimId& id);
  Instancer& instancer(const PrimId& id);
  Camera& camera(const PrimId& id);
  Light& light(const PrimId& id);
  Material& material(const PrimId& id);
  Prim& prim(const PrimId& id);

  RenderSettingsMap& settings() { return settings_; }
  const RenderSettingsMap& settings() const { return settings_; }

  /// The camera subdivision surfaces are diced for, followed as it moves (re-dicing them),
  /// at the rendered width. Empty (the default): each render's own camera and width, as
  /// Cycles dices, so that a frame's facets depend on that frame alone (a farm's frames, a
  /// resumed sequence and a fresh process dice alike); a view that moves re-dices.
  void setDicingCamera(PrimId cameraId);
  /// Light and shadow linking: the classes (class i + 1 is classes[i]) that placements name
  /// (PlacedRprim::setLinkingClass, Instancer::setLinkingClasses) over the lights' link slots
  /// (Light::setLinkSlot, Mesh::setLightLinkSlot).
  void setLinkingClasses(const std::vector<LinkingClass>& classes);
  /// Sets the link slot of the light or mesh light `id`. Throws std::out_of_range for an id
  /// that is neither.
  void setLightLinkSlot(const PrimId& id, int slot);
  const PrimId& dicingCamera() const { return dicingCamera_; }

  /// Syncs the dirty prims into the scene and commits it (cf. HdRenderIndex::SyncAll): each
  /// prim on a dirty list syncs itself from its dirty bits, given the SyncContext, and is
  /// marked clean. The order is fixed, each kind in id order: materials; the meshes bound to a
  /// material inserted or removed since the last sync are placed again (they need not be
  /// dirty); lights; cameras; meshes (placed with their material's index; a mesh light syncs
  /// its light); points and curves (placed as meshes are); volumes (their fields read
  /// through the context's VolumeFieldCache); instancers (their copies follow
  /// their prototype's geometry, so after every kind of geometry); render buffers.
  /// Then the lights that synced go into the scene's light list (LightList::update).
  /// `view`: the camera and width of the pass asking, which become the dicing context of the
  /// first sync when no dicing camera is set. Returns true if anything a render depends on
  /// changed (scene contents or any camera), so that passes restart accumulation.
  /// `cameraSamples`: how many the pass is about to take (pixels × samples per pixel), which
  /// decides whether placements edited since the last full build stay in the scene's overlay
  /// (Geometry::prepareForSamples).
  bool sync(const DicingContext& view, uint64_t cameraSamples = UINT64_MAX);
  /// Bytes the next sync will allocate to build the dirty meshes, points, curves, volumes and
  /// instancers (an estimate from their counts: penumbra::estimatedBuildBytes,
  /// estimatedPointsBytes, estimatedCurvesBytes; from their files' sizes for the volumes' grids
  /// not read yet: Volume::estimatedSyncBytes), to be checked against a memory budget before it
  /// runs.
  size_t estimatedSyncBytes() const;
  /// Incremented by every sync that changed the scene's contents.
  uint64_t sceneVersion() const { return sceneVersion_; }
  /// What syncs have cost so far: meshes triangulated or diced, of which subdivision
  /// surfaces diced, and mesh BVHs built (a mesh whose triangles did not change keeps its BVH);
  /// renderer materials built and the textures they opened; renderer lights built (mesh lights
  /// too) and light textures loaded; instances in the top-level BVHs built
  /// (Geometry::topLevelBvhPrimitives); volume grids read from files (a grid held for another
  /// volume or an earlier sync, its file unchanged, is not read again) and the bytes the
  /// scene's volumes hold.
  struct SyncStatistics {
    uint64_t meshGeometrySyncs = 0;
    uint64_t subdivisionDicings = 0;
    uint64_t meshBvhBuilds = 0;
    uint64_t topLevelBvhPrimitives = 0;
    double tessellationSeconds = 0;  // triangulating and dicing meshes
    double bvhBuildSeconds = 0;      // meshes' BVHs, the top-level BVH and the lights'
    uint64_t materialBuilds = 0;
    uint64_t materialTextureOpens = 0;
    uint64_t lightBuilds = 0;
    uint64_t lightTextureLoads = 0;
    uint64_t volumeFieldReads = 0;
    uint64_t volumeBytes = 0;
  };
  SyncStatistics syncStatistics() const;
  const Scene& scene() const { return *scene_; }

  /// The mesh, points and curves rprims by the id the primId AOV gives them.
  std::map<uint32_t, PrimId> primIdManifest() const;
  /// Cryptomatte names as the renderer knows what they name: the hash (penumbra::murmurHash3)
  /// of each name of `names` by the placement it names. A mesh, points or curves rprim id has
  /// one name (its own placement); an instancer id one per copy, in the order of its
  /// transforms (they name its prototype's copies). Throws std::invalid_argument for another
  /// id, or for as many names as an instancer does not have copies.
  PlacementHashes placementHashes(const std::map<PrimId, std::vector<std::string>>& names) const;
  /// The hashes of `names` (mesh id → a name for each of its subsets, in setSubsetMaterials'
  /// order) by the meshes' objects. Throws std::invalid_argument for an id that is no mesh in
  /// the render index, or for more names than the mesh has subsets.
  SlotHashes slotHashes(const std::map<PrimId, std::vector<std::string>>& names) const;

  /// Warnings raised since the last call, each naming its prim.
  std::vector<std::string> takeWarnings();

 private:
  /// The dicing context for this sync, given the pass's view.
  DicingContext dicingContext(const DicingContext& view);
  /// Places again the meshes, points and curves bound to a material inserted or removed since
  /// the last sync (they render with it now, or with their displayColor); the dirty ones place
  /// themselves.
  void placeUsersOfNewAndRemovedMaterials();
  /// Gives each subdivided prototype mesh its instancers' copies (Mesh::setCopyPlacements)
  /// before meshes sync, so that it is diced for them.
  void placeCopiesForDicing();
  /// Calls `visit(instancer)` for each instancer copying `prototype`.
  template <typename Visit>
  void forEachInstancerOf(const PrimId& prototype, Visit visit);
  /// Calls `visit(collection)` for each kind's collection of `self` (const or not).
  template <typename Self, typename Visit>
  static void forEachKind(Self& self, Visit visit);

  Device device_;
  std::unique_ptr<Scene> scene_;
  // The render index (cf. HdRenderIndex), one collection per kind: rprims (meshes, points,
  // curves, volumes, instancers), sprims (cameras, materials, lights), bprims (render buffers).
  PrimCollection<Mesh> meshes_;
  PrimCollection<Points> points_;
  PrimCollection<Curves> curves_;
  PrimCollection<Volume> volumes_;
  PrimCollection<Instancer> instancers_;
  PrimCollection<Camera> cameras_;
  PrimCollection<Material> materials_;
  PrimCollection<Light> lights_;
  PrimCollection<RenderBuffer> renderBuffers_;
  SyncContext context_;
  RenderSettingsMap settings_;
  PrimId dicingCamera_;
  std::optional<DicingContext> dicedFor_;
  int dicedComplexity_ = 0;
  uint64_t sceneVersion_ = 0;
};

/// Bytes that building `points` for rendering allocates at its peak (Embree's buffers per
/// motion step, the renderer's copy and the BVH over the points), estimated from their counts.
size_t estimatedPointsBytes(const PointsData& points);

}  // namespace penumbra::plugin
