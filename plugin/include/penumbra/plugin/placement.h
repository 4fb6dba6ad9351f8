// An rprim whose object stands in the scene (cf. what HdRprim keeps besides its geometry): the
// object's handle, its material id, transform, visibility and pass visibility, and how a sync
// places the object with them. Meshes and points are placed rprims; each kind adds its geometry.
#pragma once

#include <cstdint>
#include <set>
#include <vector>

#include "penumbra/motion.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

/// Why a placement Geometry::beyondReach reports is not rendered (for warnings).
extern const char* const kBeyondReach;

/// A GeomSubset's material binding (UsdShadeMaterialBindingAPI on a subset of family
/// "materialBind"): the material and the faces it binds.
struct SubsetMaterial {
  PrimId material;  // empty: none usable (the faces show displayColor)
  std::vector<int> faces;
};

class PlacedRprim : public Prim {
 public:
  /// The dirty bits on which a sync places the object again.
  static constexpr uint32_t kPlacementDirtyBits =
      DirtyMaterialId | DirtyTransform | DirtyVisibility;

  PlacedRprim(PrimId id, Geometry::MeshId handle) : Prim(std::move(id)), handle_(handle) {}

  void setMaterialId(PrimId materialId) override;
  void setTransform(const MotionTransform& objectToWorld) override;
  void setVisible(bool visible) override;
  void setPassVisibility(PassVisibility pass) override;
  /// Its light and shadow linking class (LinkingTable; 0: linked to every light).
  void setLinkingClass(uint32_t linkingClass);
  /// Per-face material bindings, overriding its material on their faces; where subsets
  /// overlap, the first binds the face. Faces not below faceCount() are left out. Throws
  /// std::invalid_argument for a negative face.
  void setSubsetMaterials(std::vector<SubsetMaterial> subsets);
  /// Whether it binds one of `materials`, itself or through a subset.
  bool bindsAny(const std::set<PrimId>& materials) const;

  /// Binds its faces and places its object with its transform, material and visibility (a
  /// material it or its subsets bind changed or moved in the scene's list).
  void place(SyncContext& context) const;

  Geometry::MeshId handle() const { return handle_; }
  const PrimId& materialId() const { return materialId_; }
  const std::vector<SubsetMaterial>& subsetMaterials() const { return subsetMaterials_; }
  const MotionTransform& transform() const { return objectToWorld_; }
  bool visible() const { return visible_; }
  PassVisibility passVisibility() const { return pass_; }
  uint32_t linkingClass() const { return linkingClass_; }

 protected:
  /// What a sync does for the placement on `bits`: warns of a newly bound material missing from
  /// the render index and binds its faces (on DirtyMaterialId), applies the pass visibility,
  /// and places the object (on kPlacementDirtyBits).
  void syncPlacement(SyncContext& context, uint32_t bits) const;
  /// How many faces subsets may bind (none: this kind has no faces).
  virtual size_t faceCount() const { return 0; }
  /// Gives the geometry its subsets' materials and the faces each binds, subset k being slot
  /// k + 1 (Geometry::setMeshFaceMaterials): after their materials or its faces changed.
  void bindFaces(SyncContext& context) const;

 private:
  /// Places its object with its transform, material and visibility.
  void placeObject(SyncContext& context) const;

  Geometry::MeshId handle_;
  PrimId materialId_;
  std::vector<SubsetMaterial> subsetMaterials_;
  MotionTransform objectToWorld_;
  bool visible_ = true;
  PassVisibility pass_;
  uint32_t linkingClass_ = LinkingTable::kLinkedToAll;
};

}  // namespace penumbra::plugin
