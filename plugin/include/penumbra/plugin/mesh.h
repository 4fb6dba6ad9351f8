// Mesh rprim: topology, points, display colour, material binding, transform, visibility, and
// the light of UsdLuxMeshLightAPI (the mesh's surface emits): the mesh owns that light and
// syncs it with itself, so that it joins, follows and leaves the scene's light list as the mesh
// changes.
#pragma once

#include <memory>
#include <set>
#include <string>
#include <vector>

#include "penumbra/mesh.h"
#include "penumbra/plugin/light.h"
#include "penumbra/plugin/placement.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/scene.h"
#include "penumbra/subdivision.h"

namespace penumbra::plugin {

class Mesh : public PlacedRprim {
 public:
  using PlacedRprim::PlacedRprim;

  void setTopology(std::vector<int> counts, std::vector<int> indices, bool leftHanded,
                   std::string subdivisionScheme);
  /// `pointMotion`: the points at later, uniformly spaced shutter times (see MeshData).
  /// UsdGeomMesh's subdivision tags (creases, corners, holes, boundary rules).
  void setSubdivisionTags(SubdivisionTags tags);
  void setPoints(std::vector<Vec3f> points, std::vector<std::vector<Vec3f>> pointMotion = {});
  void setDoubleSided(bool doubleSided);
  void setDisplayColor(std::vector<Vec3f> colors, Interpolation interpolation);
  /// Authored shading normals (empty: flat shading, or the limit normals of subdivision).
  void setNormals(std::vector<Vec3f> normals, Interpolation interpolation);
  /// The primvars materials may read (`st`, ...), replacing those set before.
  void setPrimvars(std::vector<Primvar> primvars);
  /// Removes primvars whose size does not fit the topology; returns what was wrong with each.
  std::vector<std::string> dropInvalidPrimvars();
  /// UsdLuxMeshLightAPI: the mesh also emits, and is sampled as a light, with these inputs
  /// (names as Light::setParam). `enabled` false removes the light.
  void setLight(bool enabled, const std::vector<std::pair<std::string, ParamValue>>& params);
  /// Whether its light's texture or IES file changed on disk since it was loaded
  /// (Light::filesChanged).
  bool lightFilesChanged() const { return light_ && light_->filesChanged(); }
  /// Its light's linking slot (Light::setLinkSlot), kept when setLight replaces the light.
  void setLightLinkSlot(int slot) {
    lightLinkSlot_ = slot;
    markDirty(DirtyParams);
  }

  /// The instancers placing copies of this mesh (cf. HdRprim::GetInstancerId, from the
  /// prototype's side): each registers as it syncs, and leaves as it is removed.
  const std::set<PrimId>& instancers() const { return instancers_; }
  void addInstancer(const PrimId& instancer) { instancers_.insert(instancer); }
  void removeInstancer(const PrimId& instancer) { instancers_.erase(instancer); }

  /// Syncs what its dirty bits say changed into the scene (cf. HdMesh::Sync): triangulates or
  /// dices its geometry (the scene keeps the BVH when the triangles are the same), places its
  /// instance, and syncs its light (on kLightDirtyBits), which joins, replaces or leaves its
  /// entry of the scene's light list (a mesh that is no longer a light leaves it).
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Removes it from the scene and its light from the light list; its instancers drop their
  /// copies (Instancer::dropCopies), which come back if a mesh with its id is inserted again.
  void finalize(SyncContext& context) override;
  const MeshData& data() const { return data_; }
  const std::string& subdivisionScheme() const { return subdivisionScheme_; }
  const SubdivisionTags& subdivisionTags() const { return tags_; }
  /// The tessellator of the current topology (built on first use, dropped when topology or tags
  /// change); null for meshes that are not subdivided.
  /// Tags that do not fit the cage are left out with one warning (usableSubdivisionTags).
  const LimitSurfaceTessellator* tessellator(SubdivisionScheme scheme, SyncContext& context);
  /// Bytes its next sync will allocate (penumbra::estimatedBuildBytes).
  size_t estimatedSyncBytes() const;

  /// Where its instancers place copies of it (each instancer's prototype-to-world transforms):
  /// a subdivision surface keeps the kDicingCopies placements that see its cage largest from
  /// the dicing camera and is diced for them as well as for its own placement (a hidden
  /// prototype sits wherever its copies' space has its origin). Marks it dirty when they change.
  void setCopyPlacements(const std::vector<const std::vector<MotionTransform>*>& copies,
                         const SyncContext& context);
  static constexpr size_t kDicingCopies = 16;

 protected:
  size_t faceCount() const override { return data_.faceVertexCounts.size(); }

 private:
  /// The dirty bits on which a mesh light's sync builds its light again.
  static constexpr uint32_t kLightDirtyBits =
      DirtyTopology | DirtyPoints | DirtyTransform | DirtyVisibility | DirtyParams;

  /// The triangles to render: its polygons, or its limit surface diced at `rates` (computed
  /// here when none are given).
  TriangleMesh triangles(SyncContext& context, std::optional<std::vector<int>> rates = {});
  /// Segments per edge of each base face for its placement now (see triangles()).
  std::vector<int> dicingRates(const LimitSurfaceTessellator& limit,
                               const SyncContext& context) const;
  /// The rates of its placement now when they differ from those the limit surface was diced
  /// at (moved nearer or farther, scaled): a transform alone then dices it again, so that its
  /// facets depend on its placement now, not on the placements it had before.
  std::optional<std::vector<int>> changedDicingRates(const SyncContext& context) const;
  /// Gives its light the triangles it emits from, those the mesh is traced as (a subdivision
  /// surface's limit surface), in world space at shutter open and, if it moves, over the
  /// shutter; or hides it (the mesh is hidden or invalid), and syncs it; without a light, the
  /// mesh leaves the light list if it was there.
  void syncLight(SyncContext& context);

  MeshData data_;
  std::string subdivisionScheme_ = "none";
  SubdivisionTags tags_;
  std::unique_ptr<LimitSurfaceTessellator> tessellator_;
  std::vector<int> dicedRates_;            // the rates the limit surface was last diced at
  std::vector<Transform> copyPlacements_;  // setCopyPlacements
  std::unique_ptr<Light> light_;
  int lightLinkSlot_ = -1;
  std::set<PrimId> instancers_;
};

}  // namespace penumbra::plugin
