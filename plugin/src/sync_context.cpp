#include "penumbra/plugin/sync_context.h"

namespace penumbra::plugin {

bool DicingContext::operator==(const DicingContext& other) const {
  const CameraParams &a = camera, &b = other.camera;
  return imageWidth == other.imageWidth && a.cameraToWorld.first().m == b.cameraToWorld.first().m &&
         a.focalLength == b.focalLength && a.horizontalAperture == b.horizontalAperture &&
         a.projection == b.projection && a.nearClip == b.nearClip;
}

int MaterialIndices::insert(const PrimId& id, Scene& scene) {
  int index;
  if (free_.empty()) {
    index = int(scene.materials().materialCount());
    scene.setMaterial(size_t(index), {});  // its own is built at its sync
  } else {
    index = *free_.begin();
    free_.erase(free_.begin());
  }
  index_[id] = index;
  insertedOrRemoved_.insert(id);
  return index;
}

void MaterialIndices::remove(const PrimId& id, Scene& scene) {
  const int index = index_.at(id);
  scene.setMaterial(size_t(index), {});  // unused until another material takes the index
  free_.insert(index);
  index_.erase(id);
  insertedOrRemoved_.insert(id);
}

std::optional<int> MaterialIndices::find(const PrimId& id) const {
  const auto found = index_.find(id);
  if (found == index_.end()) return std::nullopt;
  return found->second;
}

void LightList::synced(const PrimId& id, std::optional<penumbra::Light> rendered, Scene& scene,
                       std::optional<Geometry::MeshId> emittingMesh) {
  const auto listed = listed_.find(id);
  if (rendered) {
    synced_.insert_or_assign(id, std::move(*rendered));
    if (listed != listed_.end()) return;           // it replaces its own entry
    listed_.emplace(id, Entry{-1, emittingMesh});  // it joins: update gives it its index
  } else if (listed != listed_.end()) {
    listed_.erase(listed);  // it leaves
    if (emittingMesh) scene.lights().setMeshLight(*emittingMesh, -1);
  } else {
    return;  // it neither renders nor did
  }
  structureChanged_ = true;
}

void LightList::remove(const PrimId& id) {
  if (listed_.erase(id)) structureChanged_ = true;
}

bool LightList::update(Scene& scene) {
  const bool changed = structureChanged_ || !synced_.empty();
  if (structureChanged_) {
    std::vector<penumbra::Light> previous = scene.lights().releaseLights(), lights;
    lights.reserve(listed_.size());
    for (auto& [id, entry] : listed_) {
      const auto synced = synced_.find(id);
      lights.push_back(
          std::move(synced != synced_.end() ? synced->second : previous.at(size_t(entry.index))));
      entry.index = int(lights.size()) - 1;
      if (entry.emittingMesh) scene.lights().setMeshLight(*entry.emittingMesh, entry.index);
    }
    scene.lights().setLights(std::move(lights));
  } else {
    for (auto& [id, light] : synced_)
      scene.lights().setLight(size_t(listed_.at(id).index), std::move(light));
  }
  synced_.clear();
  structureChanged_ = false;
  return changed;
}

}  // namespace penumbra::plugin
