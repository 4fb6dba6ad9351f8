#include "penumbra/plugin/render_delegate.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "penumbra/plugin/light_types.h"

namespace penumbra::plugin {

RenderDelegate::RenderDelegate(const std::string& colorConfig)
    : scene_(std::make_unique<Scene>(device_, colorConfig)) {}

// The scene (and its Embree objects) must go before the device.
RenderDelegate::~RenderDelegate() {
  rprims_.clear();
  sprims_.clear();
  bprims_.clear();
  scene_.reset();
}

namespace {
using PrimCollection = std::map<PrimId, std::unique_ptr<Prim>>;
}  // namespace

void RenderDelegate::insertRprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  std::unique_ptr<Prim> inserted;
  if (type == "mesh")
    inserted = std::make_unique<Mesh>(id, scene_->geometry().addMesh());
  else if (type == "instancer")
    inserted = std::make_unique<Instancer>(id, scene_->geometry().addInstancer());
  else
    throw std::invalid_argument(id + ": unsupported rprim type '" + type + "'");
  inserted->track(&changeTracker_);
  rprims_[id] = std::move(inserted);
  meshesStructureChanged_ = true;
}

void RenderDelegate::insertBprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type != "renderBuffer")
    throw std::invalid_argument(id + ": unsupported bprim type '" + type + "'");
  auto& inserted = bprims_[id] = std::make_unique<RenderBuffer>(id);
  inserted->track(&changeTracker_);
}

void RenderDelegate::insertSprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  std::unique_ptr<Prim> inserted;
  if (type == "camera") {
    inserted = std::make_unique<Camera>(id);
  } else if (type == "material") {
    inserted = std::make_unique<Material>(id);
    int index;
    if (freeMaterialIndices_.empty()) {
      index = int(scene_->materials().materialCount());
      scene_->setMaterial(size_t(index), {});  // its own is built at its sync
    } else {
      index = *freeMaterialIndices_.begin();
      freeMaterialIndices_.erase(freeMaterialIndices_.begin());
    }
    materialIndex_[id] = index;
    materialsInsertedOrRemoved_.insert(id);
    materialsStructureChanged_ = true;
  } else if (isLightTypeName(type)) {
    inserted = std::make_unique<Light>(id, lightTypeFromName(type));  // joins the lights at sync
  } else {
    throw std::invalid_argument(id + ": unsupported sprim type '" + type + "'");
  }
  inserted->track(&changeTracker_);
  sprims_[id] = std::move(inserted);
}

void RenderDelegate::removePrim(const PrimId& id) {
  Prim& removed = prim(id);
  if (auto* mesh = dynamic_cast<Mesh*>(&removed)) {
    // Its instancers lose their copies (and get them back if it is inserted again).
    // (An entry may be stale: an instancer removed, or now copying another mesh.)
    for (const PrimId& instancerId : mesh->instancers())
      if (const auto found = rprims_.find(instancerId); found != rprims_.end())
        if (auto* copies = dynamic_cast<Instancer*>(found->second.get());
            copies && copies->prototype() == id) {
          scene_->geometry().removeInstancer(copies->handle());
          copies->setHandle(scene_->geometry().addInstancer());
          copies->markDirty(DirtyTransform);
        }
    if (lightIndex_.erase(id)) lightsStructureChanged_ = true;
    scene_->geometry().removeMesh(mesh->handle());
    meshesStructureChanged_ = true;
  }
  if (auto* copies = dynamic_cast<Instancer*>(&removed)) {
    scene_->geometry().removeInstancer(copies->handle());
    if (const auto found = rprims_.find(copies->prototype()); found != rprims_.end())
      if (auto* prototype = dynamic_cast<Mesh*>(found->second.get()))
        prototype->removeInstancer(id);
    meshesStructureChanged_ = true;
  }
  if (dynamic_cast<Material*>(&removed)) {
    const int index = materialIndex_.at(id);
    scene_->setMaterial(size_t(index), {});  // unused until another material takes the index
    freeMaterialIndices_.insert(index);
    materialIndex_.erase(id);
    materialsInsertedOrRemoved_.insert(id);
    materialsStructureChanged_ = true;
  }
  if (dynamic_cast<Light*>(&removed) && lightIndex_.erase(id)) lightsStructureChanged_ = true;
  changeTracker_.forget(id);
  if (!rprims_.erase(id) && !sprims_.erase(id)) bprims_.erase(id);
}

bool RenderDelegate::hasPrim(const PrimId& id) const {
  return rprims_.count(id) != 0 || sprims_.count(id) != 0 || bprims_.count(id) != 0;
}

std::vector<PrimId> RenderDelegate::primIds() const {
  std::vector<PrimId> ids;
  for (const PrimCollection* collection : {&rprims_, &sprims_, &bprims_})
    for (const auto& entry : *collection) ids.push_back(entry.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

Prim& RenderDelegate::prim(const PrimId& id) {
  for (PrimCollection* collection : {&rprims_, &sprims_, &bprims_})
    if (const auto found = collection->find(id); found != collection->end()) return *found->second;
  throw std::out_of_range(id + ": no such prim in the render index");
}

namespace {
template <typename T>
T& primAs(PrimCollection& collection, const PrimId& id, const char* typeName) {
  const auto found = collection.find(id);
  if (found != collection.end())
    if (auto* typed = dynamic_cast<T*>(found->second.get())) return *typed;
  throw std::out_of_range(id + ": no " + typeName + " with this id in the render index");
}
}  // namespace

std::map<uint32_t, PrimId> RenderDelegate::primIdManifest() const {
  std::map<uint32_t, PrimId> manifest;
  for (const auto& [id, prim] : rprims_)
    if (const auto* mesh = dynamic_cast<const Mesh*>(prim.get())) manifest[mesh->handle()] = id;
  return manifest;
}

Mesh& RenderDelegate::mesh(const PrimId& id) {
  return primAs<Mesh>(rprims_, id, "mesh");
}
RenderBuffer& RenderDelegate::renderBuffer(const PrimId& id) {
  return primAs<RenderBuffer>(bprims_, id, "render buffer");
}
Instancer& RenderDelegate::instancer(const PrimId& id) {
  return primAs<Instancer>(rprims_, id, "instancer");
}
Camera& RenderDelegate::camera(const PrimId& id) {
  return primAs<Camera>(sprims_, id, "camera");
}
Light& RenderDelegate::light(const PrimId& id) {
  return primAs<Light>(sprims_, id, "light");
}
Material& RenderDelegate::material(const PrimId& id) {
  return primAs<Material>(sprims_, id, "material");
}

void RenderDelegate::setDicingCamera(PrimId cameraId) {
  dicingCamera_ = std::move(cameraId);
}

RenderDelegate::SyncStatistics RenderDelegate::syncStatistics() const {
  SyncStatistics statistics;
  statistics.meshGeometrySyncs = counters_.meshGeometrySyncs;
  statistics.subdivisionDicings = counters_.subdivisionDicings;
  statistics.meshBvhBuilds = scene_->geometry().meshBvhBuilds();
  statistics.topLevelBvhPrimitives = scene_->geometry().topLevelBvhPrimitives();
  statistics.tessellationSeconds = counters_.tessellationSeconds;
  statistics.bvhBuildSeconds = scene_->bvhBuildSeconds();
  statistics.materialBuilds = counters_.materialBuilds;
  statistics.materialTextureOpens = counters_.materialTextureOpens;
  statistics.lightBuilds = counters_.lightBuilds;
  statistics.lightTextureLoads = counters_.lightTextureLoads;
  return statistics;
}

std::vector<std::string> RenderDelegate::takeWarnings() {
  std::vector<std::string> taken;
  taken.swap(warnings_);
  return taken;
}

void RenderDelegate::placeUsersOfNewAndRemovedMaterials(SyncContext& context) {
  if (materialsInsertedOrRemoved_.empty()) return;
  for (auto& [id, prim] : rprims_)
    if (auto* user = dynamic_cast<Mesh*>(prim.get());
        user && !(user->dirtyBits() & Mesh::kPlacementDirtyBits) &&
        materialsInsertedOrRemoved_.count(user->materialId()))
      user->place(context);
  materialsInsertedOrRemoved_.clear();
}

void RenderDelegate::lightSynced(const PrimId& id, std::optional<penumbra::Light> rendered,
                                 const Mesh* mesh) {
  const auto listed = lightIndex_.find(id);
  if (rendered) {
    lightsSynced_.insert_or_assign(id, std::move(*rendered));
    if (listed != lightIndex_.end()) return;  // it replaces its own entry
    lightIndex_.emplace(id, -1);              // it joins: updateLightList gives it its index
  } else if (listed != lightIndex_.end()) {
    lightIndex_.erase(listed);  // it leaves
    if (mesh) scene_->lights().setMeshLight(mesh->handle(), -1);
  } else {
    return;  // it neither renders nor did
  }
  lightsStructureChanged_ = true;
}

void RenderDelegate::updateLightList() {
  if (lightsStructureChanged_) {
    std::vector<penumbra::Light> previous = scene_->lights().releaseLights(), lights;
    lights.reserve(lightIndex_.size());
    for (auto& [id, index] : lightIndex_) {
      const auto synced = lightsSynced_.find(id);
      lights.push_back(
          std::move(synced != lightsSynced_.end() ? synced->second : previous.at(size_t(index))));
      index = int(lights.size()) - 1;
      if (const auto rprim = rprims_.find(id); rprim != rprims_.end())
        if (const auto* mesh = dynamic_cast<const Mesh*>(rprim->second.get()))
          scene_->lights().setMeshLight(mesh->handle(), index);
    }
    scene_->lights().setLights(std::move(lights));
  } else {
    for (auto& [id, light] : lightsSynced_)
      scene_->lights().setLight(size_t(lightIndex_.at(id)), std::move(light));
  }
  lightsSynced_.clear();
}

Mesh* RenderDelegate::prototypeOf(const Instancer& copies) {
  const auto found = rprims_.find(copies.prototype());
  auto* prototype = found == rprims_.end() ? nullptr : dynamic_cast<Mesh*>(found->second.get());
  if (!prototype)
    warn(copies.id() + ": prototype " + copies.prototype() +
         " is not a mesh in the render index; the instances are skipped");
  return prototype;
}

DicingContext RenderDelegate::dicingContext(const DicingContext& view) {
  if (!firstView_) firstView_ = view;
  if (dicingCamera_.empty()) return *firstView_;
  const auto found = sprims_.find(dicingCamera_);
  const auto* camera =
      found == sprims_.end() ? nullptr : dynamic_cast<Camera*>(found->second.get());
  if (!camera) {
    warn("dicing camera " + dicingCamera_ +
         " is not a camera in the render index; the first render's camera is used");
    return *firstView_;
  }
  return {camera->params(), firstView_->imageWidth};
}

size_t RenderDelegate::estimatedSyncBytes() const {
  size_t bytes = 0;
  for (const PrimId& id : changeTracker_.dirty()) {
    const auto found = rprims_.find(id);
    if (found == rprims_.end()) continue;
    const Prim* prim = found->second.get();
    if (const auto* mesh = dynamic_cast<const Mesh*>(prim); mesh && mesh->visible())
      bytes += estimatedBuildBytes(mesh->data(), mesh->subdivisionScheme() != "none");
    else if (const auto* copies = dynamic_cast<const Instancer*>(prim); copies && copies->visible())
      bytes += estimatedInstanceBytes(
          copies->transforms().size(),
          copies->transforms().empty() ? 1 : copies->transforms()[0].steps().size());
  }
  return bytes;
}

bool RenderDelegate::sync(const DicingContext& view, uint64_t cameraSamples) {
  scene_->materials().textures().setCacheSize(size_t(settings_.textureCacheMB) << 20);
  // A new dicing context or complexity re-dices every subdivision surface.
  const DicingContext dicing = dicingContext(view);
  if (dicedFor_ != dicing || dicedComplexity_ != settings_.complexity) {
    if (dicedFor_)
      for (auto& [id, prim] : rprims_)
        if (auto* mesh = dynamic_cast<Mesh*>(prim.get());
            mesh && mesh->subdivisionScheme() != "none")
          mesh->markDirty(DirtyPoints);
    dicedFor_ = dicing;
    dicedComplexity_ = settings_.complexity;
  }
  bool meshesDirty = meshesStructureChanged_, camerasDirty = false;
  std::vector<Material*> dirtyMaterials;
  std::vector<Light*> dirtyLights;
  std::vector<Mesh*> dirtyMeshes;
  std::vector<Instancer*> dirtyInstancers;
  for (const PrimId& id : changeTracker_.take()) {
    if (const auto found = rprims_.find(id); found != rprims_.end()) {
      meshesDirty = true;
      if (auto* mesh = dynamic_cast<Mesh*>(found->second.get()))
        dirtyMeshes.push_back(mesh);
      else if (auto* copies = dynamic_cast<Instancer*>(found->second.get()))
        dirtyInstancers.push_back(copies);
    } else if (const auto sprim = sprims_.find(id); sprim != sprims_.end()) {
      Prim& changed = *sprim->second;
      if (auto* material = dynamic_cast<Material*>(&changed)) {
        dirtyMaterials.push_back(material);
      } else if (auto* light = dynamic_cast<Light*>(&changed)) {
        dirtyLights.push_back(light);
      } else if (changed.dirtyBits() != Clean) {  // cameras
        camerasDirty = true;
        changed.markClean();
      }
    } else if (const auto bprim = bprims_.find(id); bprim != bprims_.end()) {
      bprim->second->markClean();
    }
  }
  SyncContext context{*scene_, materialIndex_, dicing, settings_.complexity, warnings_, counters_};
  // Sprims before rprims, as in Hydra: meshes place themselves with their material's index.
  // Each dirty material builds its own entry of the scene's list; meshes bound to one keep its
  // index and follow it there (Scene::setMaterial).
  for (Material* material : dirtyMaterials) material->sync(context);
  placeUsersOfNewAndRemovedMaterials(context);
  for (Light* light : dirtyLights) {
    light->sync(context);
    lightSynced(light->id(), light->takeRendered(), nullptr);
  }
  for (Mesh* dirtyMesh : dirtyMeshes) {
    const bool lightSyncs = dirtyMesh->dirtyBits() & Mesh::kLightDirtyBits;
    dirtyMesh->sync(context);
    if (lightSyncs) {  // a mesh light, or one no longer
      Light* light = dirtyMesh->light();
      lightSynced(dirtyMesh->id(), light ? light->takeRendered() : std::nullopt, dirtyMesh);
    }
  }
  // After the meshes: copies follow their prototype's geometry, placed by the scene.
  for (Instancer* copies : dirtyInstancers) copies->sync(context, prototypeOf(*copies));
  const bool materialsDirty = materialsStructureChanged_ || !dirtyMaterials.empty();
  const bool lightsDirty = lightsStructureChanged_ || !lightsSynced_.empty();
  updateLightList();
  materialsStructureChanged_ = lightsStructureChanged_ = meshesStructureChanged_ = false;
  const bool sceneChanged = materialsDirty || lightsDirty || meshesDirty;
  // Folding the overlay changes how rays find hits, not which: no new scene version.
  if (scene_->geometry().prepareForSamples(cameraSamples) || sceneChanged) scene_->commit();
  if (sceneChanged) ++sceneVersion_;
  return sceneChanged || camerasDirty;
}

}  // namespace penumbra::plugin
