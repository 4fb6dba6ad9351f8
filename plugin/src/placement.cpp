#include "penumbra/plugin/placement.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace penumbra::plugin {

static_assert(Geometry::kMaxCoordinate == 1e18f, "kBeyondReach states it");
const char* const kBeyondReach =
    "its world bounds reach beyond 1e18 units from the origin (or are not finite), where "
    "single-precision ray tracing cannot place it";

namespace {

/// Whether the scene delegate already reported the transform itself: it warns of one that is not
/// finite or translates beyond Geometry::kMaxCoordinate for every kind of prim (python/penumbra/
/// usd/core_batch.py), so a second warning, of the bounds, would be one too many.
bool transformReported(const MotionTransform& objectToWorld) {
  for (const Transform& step : objectToWorld.steps())
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 4; ++col) {
        const double value = step.at(row, col);
        const bool translation = row == 3 && col < 3;
        if (!std::isfinite(value) || (translation && std::abs(value) > Geometry::kMaxCoordinate))
          return true;
      }
  return false;
}

}  // namespace

void PlacedRprim::setMaterialId(PrimId materialId) {
  materialId_ = std::move(materialId);
  markDirty(DirtyMaterialId);
}

void PlacedRprim::setSubsetMaterials(std::vector<SubsetMaterial> subsets) {
  for (const SubsetMaterial& subset : subsets)
    for (const int face : subset.faces)
      if (face < 0)
        throw std::invalid_argument(id() + ": a material subset lists face " +
                                    std::to_string(face));
  subsetMaterials_ = std::move(subsets);
  markDirty(DirtyMaterialId);
}

bool PlacedRprim::bindsAny(const std::set<PrimId>& materials) const {
  if (materials.count(materialId_)) return true;
  for (const SubsetMaterial& subset : subsetMaterials_)
    if (materials.count(subset.material)) return true;
  return false;
}

void PlacedRprim::bindFaces(SyncContext& context) const {
  std::vector<uint32_t> faceSlots;
  std::vector<int> slotMaterials;
  const size_t faces = faceCount();
  for (const SubsetMaterial& subset : subsetMaterials_) {
    slotMaterials.push_back(
        subset.material.empty()
            ? MaterialTable::kNoMaterial
            : context.materials.find(subset.material).value_or(MaterialTable::kNoMaterial));
    const uint32_t slot = uint32_t(slotMaterials.size());
    for (const int face : subset.faces) {
      if (size_t(face) >= faces) continue;  // not a face (yet): the topology may gain it
      if (size_t(face) >= faceSlots.size()) faceSlots.resize(size_t(face) + 1, 0);
      if (faceSlots[size_t(face)] == 0) faceSlots[size_t(face)] = slot;
    }
  }
  context.scene.geometry().setMeshFaceMaterials(handle_, std::move(faceSlots),
                                                std::move(slotMaterials));
}

void PlacedRprim::setTransform(const MotionTransform& objectToWorld) {
  objectToWorld_ = objectToWorld;
  markDirty(DirtyTransform);
}

void PlacedRprim::setVisible(bool visible) {
  visible_ = visible;
  markDirty(DirtyVisibility);
}

void PlacedRprim::setPassVisibility(PassVisibility pass) {
  pass_ = pass;
  markDirty(DirtyVisibility);
}

void PlacedRprim::setLinkingClass(uint32_t linkingClass) {
  linkingClass_ = linkingClass;
  markDirty(DirtyVisibility);
}

void PlacedRprim::syncPlacement(SyncContext& context, uint32_t bits) const {
  if (bits & kPlacementDirtyBits) {
    if (bits & DirtyMaterialId) {
      if (!materialId_.empty() && !context.materials.find(materialId_))
        context.warn(id() + ": bound material " + materialId_ +
                     " is not in the render index; displayColor is used");
      for (const SubsetMaterial& subset : subsetMaterials_)
        if (!subset.material.empty() && !context.materials.find(subset.material))
          context.warn(id() + ": material " + subset.material +
                       " bound to a subset of its faces is not in the render index; those faces "
                       "use displayColor");
      bindFaces(context);
    }
    if (bits & DirtyVisibility) {
      context.scene.geometry().setMeshPassVisibility(handle_, pass_);
      context.scene.geometry().setMeshLinkingClass(handle_, linkingClass_);
    }
    placeObject(context);
  }
  // Moved or reshaped (the geometry placed it again as it changed) out of reach.
  if ((bits & (kPlacementDirtyBits | DirtyTopology | DirtyPoints)) &&
      context.scene.geometry().beyondReach(handle_) && !transformReported(objectToWorld_))
    context.warn(id() + ": " + kBeyondReach + "; the prim is not rendered");
}

void PlacedRprim::place(SyncContext& context) const {
  bindFaces(context);
  placeObject(context);
}

void PlacedRprim::placeObject(SyncContext& context) const {
  int materialIndex = MaterialTable::kNoMaterial;
  if (!materialId_.empty())
    materialIndex = context.materials.find(materialId_).value_or(materialIndex);
  context.scene.geometry().setMeshInstance(handle_, objectToWorld_, materialIndex, visible_);
}

}  // namespace penumbra::plugin
