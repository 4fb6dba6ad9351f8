#include "penumbra/plugin/render_delegate.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <utility>

#include "penumbra/plugin/light_types.h"

namespace penumbra::plugin {

RenderDelegate::RenderDelegate(const std::string& colorConfig)
    : scene_(std::make_unique<Scene>(device_, colorConfig)),
      context_(*scene_, meshes_, points_, curves_, instancers_) {}

// The scene (and its Embree objects) must go before the device.
RenderDelegate::~RenderDelegate() {
  forEachKind(*this, [](auto& kind) { kind.clear(); });
  scene_.reset();
}

template <typename Self, typename Visit>
void RenderDelegate::forEachKind(Self& self, Visit visit) {
  visit(self.meshes_);
  visit(self.points_);
  visit(self.curves_);
  visit(self.volumes_);
  visit(self.instancers_);
  visit(self.cameras_);
  visit(self.materials_);
  visit(self.lights_);
  visit(self.renderBuffers_);
}

void RenderDelegate::insertRprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type == "instancer") {
    instancers_.insert(std::make_unique<Instancer>(id, scene_->geometry().addInstancer()));
    return;
  }
  if (type == "volume") {  // not in the geometry: instancers cannot copy it
    volumes_.insert(std::make_unique<Volume>(id, scene_->volumes().add()));
    return;
  }
  if (type == "mesh")
    meshes_.insert(std::make_unique<Mesh>(id, scene_->geometry().addMesh()));
  else if (type == "points")
    points_.insert(std::make_unique<Points>(id, scene_->geometry().addMesh()));
  else if (type == "basisCurves")
    curves_.insert(std::make_unique<Curves>(id, scene_->geometry().addMesh()));
  else
    throw std::invalid_argument(id + ": unsupported rprim type '" + type + "'");
  // Instancers that found no prototype of this id place their copies of it at the next sync.
  forEachInstancerOf(id, [](Instancer& copies) { copies.markDirty(DirtyTransform); });
}

template <typename Visit>
void RenderDelegate::forEachInstancerOf(const PrimId& prototype, Visit visit) {
  const auto listed = context_.instancersByPrototype.find(prototype);
  if (listed == context_.instancersByPrototype.end()) return;
  for (const PrimId& id : listed->second)
    if (Instancer* copies = instancers_.find(id); copies && copies->prototype() == prototype)
      visit(*copies);
}

void RenderDelegate::insertBprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type != "renderBuffer")
    throw std::invalid_argument(id + ": unsupported bprim type '" + type + "'");
  renderBuffers_.insert(std::make_unique<RenderBuffer>(id));
}

void RenderDelegate::insertSprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type == "camera") {
    cameras_.insert(std::make_unique<Camera>(id));
  } else if (type == "material") {
    context_.materials.insert(id, *scene_);  // its entry is built at its sync
    materials_.insert(std::make_unique<Material>(id));
  } else if (isLightTypeName(type)) {
    lights_.insert(std::make_unique<Light>(id, lightTypeFromName(type)));  // listed at its sync
  } else {
    throw std::invalid_argument(id + ": unsupported sprim type '" + type + "'");
  }
}

void RenderDelegate::removePrim(const PrimId& id) {
  Prim& removed = prim(id);
  // A mesh drops its instancers' copies as it finalizes; the copies of points and curves go
  // here, before their prototype.
  if (points_.find(id) || curves_.find(id))
    forEachInstancerOf(id, [&](Instancer& copies) { copies.dropCopies(context_); });
  removed.finalize(context_);
  forEachKind(*this, [&](auto& kind) { kind.erase(id); });
}

bool RenderDelegate::hasPrim(const PrimId& id) const {
  bool found = false;
  forEachKind(*this, [&](const auto& kind) { found = found || kind.find(id); });
  return found;
}

std::vector<PrimId> RenderDelegate::primIds() const {
  std::vector<PrimId> ids;
  forEachKind(*this, [&](const auto& kind) { kind.appendIds(ids); });
  std::sort(ids.begin(), ids.end());
  return ids;
}

Prim& RenderDelegate::prim(const PrimId& id) {
  Prim* found = nullptr;
  forEachKind(*this, [&](auto& kind) {
    if (!found) found = kind.find(id);
  });
  if (!found) throw std::out_of_range(id + ": no such prim in the render index");
  return *found;
}

std::map<uint32_t, PrimId> RenderDelegate::primIdManifest() const {
  std::map<uint32_t, PrimId> manifest;
  meshes_.forEach([&](const Mesh& mesh) { manifest[mesh.handle()] = mesh.id(); });
  points_.forEach([&](const Points& points) { manifest[points.handle()] = points.id(); });
  curves_.forEach([&](const Curves& curves) { manifest[curves.handle()] = curves.id(); });
  return manifest;
}

SlotHashes RenderDelegate::slotHashes(
    const std::map<PrimId, std::vector<std::string>>& names) const {
  SlotHashes hashes;
  for (const auto& [id, subsetNames] : names) {
    const Mesh* mesh = meshes_.find(id);
    if (!mesh)
      throw std::invalid_argument(id + ": subset names are for meshes in the render index");
    if (subsetNames.size() > mesh->subsetMaterials().size())
      throw std::invalid_argument(id + ": " + std::to_string(subsetNames.size()) +
                                  " subset names for " +
                                  std::to_string(mesh->subsetMaterials().size()) + " subsets");
    std::vector<uint32_t>& slots = hashes[mesh->handle()];
    for (const std::string& name : subsetNames) slots.push_back(murmurHash3(name));
  }
  return hashes;
}

PlacementHashes RenderDelegate::placementHashes(
    const std::map<PrimId, std::vector<std::string>>& names) const {
  const auto placedRprim = [this](const PrimId& id) -> const PlacedRprim* {
    if (const Mesh* mesh = meshes_.find(id)) return mesh;
    if (const Points* points = points_.find(id)) return points;
    return curves_.find(id);
  };
  PlacementHashes hashes;
  for (const auto& [id, placementNames] : names) {
    if (const PlacedRprim* rprim = placedRprim(id)) {
      if (placementNames.size() != 1)
        throw std::invalid_argument(id +
                                    ": a mesh, points or curves takes one Cryptomatte name, "
                                    "not " +
                                    std::to_string(placementNames.size()));
      hashes[placementKey(rprim->handle(), -1)] = murmurHash3(placementNames.front());
      continue;
    }
    const Instancer* instancer = instancers_.find(id);
    if (!instancer)
      throw std::invalid_argument(id +
                                  ": Cryptomatte names are for meshes, points, curves and "
                                  "instancers in the render index");
    if (placementNames.size() != instancer->transforms().size())
      throw std::invalid_argument(id + ": " + std::to_string(placementNames.size()) +
                                  " Cryptomatte names for " +
                                  std::to_string(instancer->transforms().size()) + " copies");
    const PlacedRprim* prototype = placedRprim(instancer->prototype());
    if (!prototype) continue;  // no copies are placed (the instancer's sync warned)
    for (size_t copy = 0; copy < placementNames.size(); ++copy)
      hashes[placementKey(prototype->handle(), int(copy))] = murmurHash3(placementNames[copy]);
  }
  return hashes;
}

Mesh& RenderDelegate::mesh(const PrimId& id) {
  return meshes_.at(id, "mesh");
}
Points& RenderDelegate::points(const PrimId& id) {
  return points_.at(id, "points");
}
Curves& RenderDelegate::curves(const PrimId& id) {
  return curves_.at(id, "curves");
}
Volume& RenderDelegate::volume(const PrimId& id) {
  return volumes_.at(id, "volume");
}
RenderBuffer& RenderDelegate::renderBuffer(const PrimId& id) {
  return renderBuffers_.at(id, "render buffer");
}
Instancer& RenderDelegate::instancer(const PrimId& id) {
  return instancers_.at(id, "instancer");
}
Camera& RenderDelegate::camera(const PrimId& id) {
  return cameras_.at(id, "camera");
}
Light& RenderDelegate::light(const PrimId& id) {
  return lights_.at(id, "light");
}
Material& RenderDelegate::material(const PrimId& id) {
  return materials_.at(id, "material");
}

void RenderDelegate::setDicingCamera(PrimId cameraId) {
  dicingCamera_ = std::move(cameraId);
}

void RenderDelegate::setLinkingClasses(const std::vector<LinkingClass>& classes) {
  scene_->geometry().setLinkingClasses(classes);
  context_.sceneChanged = true;
}

void RenderDelegate::setLightLinkSlot(const PrimId& id, int slot) {
  if (meshes_.find(id))
    mesh(id).setLightLinkSlot(slot);
  else
    light(id).setLinkSlot(slot);
}

RenderDelegate::SyncStatistics RenderDelegate::syncStatistics() const {
  const SyncCounters& counters = context_.counters;
  SyncStatistics statistics;
  statistics.meshGeometrySyncs = counters.meshGeometrySyncs;
  statistics.subdivisionDicings = counters.subdivisionDicings;
  statistics.meshBvhBuilds = scene_->geometry().meshBvhBuilds();
  statistics.topLevelBvhPrimitives = scene_->geometry().topLevelBvhPrimitives();
  statistics.tessellationSeconds = counters.tessellationSeconds;
  statistics.bvhBuildSeconds = scene_->bvhBuildSeconds();
  statistics.materialBuilds = counters.materialBuilds;
  statistics.materialTextureOpens = counters.materialTextureOpens;
  statistics.lightBuilds = counters.lightBuilds;
  statistics.lightTextureLoads = counters.lightTextureLoads;
  statistics.volumeFieldReads = context_.volumeFields.reads();
  statistics.volumeBytes = scene_->volumes().memoryBytes();
  return statistics;
}

std::vector<std::string> RenderDelegate::takeWarnings() {
  for (std::string& message : scene_->materials().textures().takeLookupFailures())
    context_.warn(std::move(message));
  return std::exchange(context_.warnings, {});
}

void RenderDelegate::placeUsersOfNewAndRemovedMaterials() {
  const std::set<PrimId> insertedOrRemoved = context_.materials.takeInsertedOrRemoved();
  if (insertedOrRemoved.empty()) return;
  const auto placeAgain = [&](const auto& user) {
    if (!(user.dirtyBits() & PlacedRprim::kPlacementDirtyBits) && user.bindsAny(insertedOrRemoved))
      user.place(context_);
  };
  meshes_.forEach(placeAgain);
  points_.forEach(placeAgain);
  curves_.forEach(placeAgain);
}

DicingContext RenderDelegate::dicingContext(const DicingContext& view) {
  if (dicingCamera_.empty()) return view;
  const Camera* camera = cameras_.find(dicingCamera_);
  if (!camera) {
    context_.warn("dicing camera " + dicingCamera_ +
                  " is not a camera in the render index; the render's camera is used");
    return view;
  }
  return {camera->params(), view.imageWidth};
}

size_t RenderDelegate::estimatedSyncBytes() const {
  size_t bytes = 0;
  for (const PrimId& id : meshes_.dirty()) bytes += meshes_.find(id)->estimatedSyncBytes();
  for (const PrimId& id : points_.dirty()) {
    const Points& points = *points_.find(id);
    if (points.visible()) bytes += estimatedPointsBytes(points.data());
  }
  for (const PrimId& id : curves_.dirty()) bytes += curves_.find(id)->estimatedSyncBytes();
  // Every volume: one whose files were written again reads them at the next sync.
  volumes_.forEach(
      [&](const Volume& volume) { bytes += volume.estimatedSyncBytes(context_.volumeFields); });
  for (const PrimId& id : instancers_.dirty()) bytes += instancers_.find(id)->estimatedSyncBytes();
  return bytes;
}

void RenderDelegate::placeCopiesForDicing() {
  std::map<PrimId, std::vector<const std::vector<MotionTransform>*>> copies;
  instancers_.forEach([&](const Instancer& instancer) {
    if (instancer.visible()) copies[instancer.prototype()].push_back(&instancer.transforms());
  });
  meshes_.forEach([&](Mesh& mesh) {
    if (mesh.subdivisionScheme() == "none") return;
    const auto found = copies.find(mesh.id());
    mesh.setCopyPlacements(found == copies.end() ? decltype(copies)::mapped_type{} : found->second,
                           context_);
  });
}

bool RenderDelegate::sync(const DicingContext& view, uint64_t cameraSamples) {
  scene_->materials().textures().setCacheSize(size_t(settings_.textureCacheMB) << 20);
  // Texture files repainted since they were read are read again (a lookdev loop: paint, render);
  // lights build their sampling from theirs at sync.
  std::vector<std::string> unreadable;
  if (scene_->materials().textures().reloadChangedFiles(&unreadable) > 0) {
    context_.sceneChanged = true;
    lights_.forEach([](Light& light) { light.markDirty(DirtyParams); });
  }
  // Lights load their texture or IES profile again once its file changed (or one that could not
  // be read is mended): their sampling and shaping are built from it.
  lights_.forEach([](Light& light) {
    if (light.filesChanged()) light.markDirty(DirtyParams);
  });
  meshes_.forEach([](Mesh& mesh) {
    if (mesh.lightFilesChanged()) mesh.markDirty(DirtyParams);  // its UsdLuxMeshLightAPI light
  });
  for (const std::string& error : unreadable)
    context_.warn(error + "; the textures reading it give their fallback values");
  // Materials read again what they could not read before, once it changed.
  materials_.forEach([](Material& material) {
    if (material.unreadableFilesChanged()) material.markDirty(DirtyParams);
  });
  // So are OpenVDB files written again (a simulation cached again under the same name).
  volumes_.forEach([](Volume& volume) {
    if (volume.fieldFilesChanged()) volume.markDirty(DirtyParams);
  });
  // A new dicing context or complexity re-dices every subdivision surface.
  const DicingContext dicing = dicingContext(view);
  const bool dicingMoved = dicedFor_ != dicing;
  if (dicedFor_ != dicing || dicedComplexity_ != settings_.complexity) {
    if (dicedFor_)
      meshes_.forEach([](Mesh& mesh) {
        if (mesh.subdivisionScheme() != "none") mesh.markDirty(DirtyPoints);
      });
    dicedFor_ = dicing;
    dicedComplexity_ = settings_.complexity;
  }
  context_.dicing = dicing;
  context_.complexity = settings_.complexity;
  if (dicingMoved || !instancers_.dirty().empty()) placeCopiesForDicing();
  // Sprims before rprims, as in Hydra: meshes place themselves with their material's index.
  // Each dirty material builds its own entry of the scene's list; meshes bound to one keep its
  // index and follow it there (Scene::setMaterial).
  materials_.syncDirty(context_);
  placeUsersOfNewAndRemovedMaterials();
  lights_.syncDirty(context_);
  cameras_.syncDirty(context_);
  meshes_.syncDirty(context_);
  points_.syncDirty(context_);
  curves_.syncDirty(context_);
  volumes_.syncDirty(context_);
  // After the geometry: copies follow their prototype's geometry, placed by the scene.
  instancers_.syncDirty(context_);
  renderBuffers_.syncDirty(context_);
  const bool lightsChanged = context_.lights.update(*scene_);
  const bool sceneChanged = context_.sceneChanged || lightsChanged;
  const bool camerasChanged = context_.camerasChanged;
  context_.sceneChanged = context_.camerasChanged = false;
  // Folding the overlay changes how rays find hits, not which: no new scene version.
  if (scene_->geometry().prepareForSamples(cameraSamples) || sceneChanged) scene_->commit();
  if (sceneChanged) ++sceneVersion_;
  return sceneChanged || camerasChanged;
}

size_t estimatedPointsBytes(const PointsData& points) {
  // Per point and motion step: Embree's (x, y, z, radius) buffer and the renderer's copy; per
  // point: its primitive reference during the build and its share of the BVH. 78 MiB were
  // measured for a million static spheres (96 B a point estimated).
  constexpr size_t kBytesPerPointStep = 32, kBytesPerPoint = 64;
  const size_t steps = 1 + points.positionMotion.size();
  return points.positions.size() * (steps * kBytesPerPointStep + kBytesPerPoint);
}

}  // namespace penumbra::plugin
