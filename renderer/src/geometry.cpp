#include "penumbra/geometry.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "penumbra/curves_shape.h"
#include "penumbra/mesh_shape.h"
#include "penumbra/points_shape.h"

namespace penumbra {

void Geometry::BoxUnion::set(size_t index, const Box& box) {
  if (index >= leaves_) {
    size_t leaves = std::max<size_t>(leaves_, 1);
    while (leaves <= index) leaves *= 2;
    std::vector<Box> nodes(2 * leaves);
    std::copy(nodes_.begin() + std::ptrdiff_t(leaves_), nodes_.end(),
              nodes.begin() + std::ptrdiff_t(leaves));
    leaves_ = leaves;
    nodes_ = std::move(nodes);
    uniteAll_ = true;
  }
  nodes_[leaves_ + index] = box;
  if (uniteAll_) return;
  changed_.push_back(leaves_ + index);
  if (changed_.size() >= leaves_ / 8) uniteAll_ = true;  // as cheap to unite everything again
}

Geometry::Box Geometry::BoxUnion::all() {
  if (nodes_.empty()) return Box{};
  auto unite = [this](size_t k) {
    nodes_[k] = nodes_[2 * k];
    nodes_[k].extend(nodes_[2 * k + 1]);
  };
  if (uniteAll_) {
    for (size_t k = leaves_ - 1; k >= 1; --k) unite(k);
  } else {
    for (size_t k : changed_)
      for (k /= 2; k >= 1; k /= 2) unite(k);
  }
  changed_.clear();
  uniteAll_ = false;
  return nodes_[1];
}

Geometry::Geometry(const Device& device, MaterialTable& materials)
    : device_(device.get()), materials_(materials), top_(rtcNewScene(device_)) {
  rtcRetainDevice(device_);
  rtcSetSceneFlags(top_, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);  // see skipPlacements
  throwOnEmbreeError(device_, "create a scene");
}

Geometry::~Geometry() {
  for (auto& instancerRecord : instancers_)
    if (instancerRecord)
      for (auto& copy : instancerRecord->copies) releasePlacement(copy);
  for (auto& mesh : meshes_) {
    if (!mesh) continue;
    releasePlacement(mesh->own);
    if (mesh->bvh) rtcReleaseScene(mesh->bvh);
  }
  if (overlay_) rtcReleaseScene(overlay_);
  rtcReleaseScene(top_);
  rtcReleaseDevice(device_);
}

const Geometry::MeshRecord& Geometry::record(MeshId id) const {
  if (id >= meshes_.size() || !meshes_[id])
    throw std::out_of_range("no mesh with id " + std::to_string(id));
  return *meshes_[id];
}

Geometry::MeshRecord& Geometry::record(MeshId id) {
  return const_cast<MeshRecord&>(std::as_const(*this).record(id));
}

const Geometry::InstancerRecord& Geometry::instancer(InstancerId id) const {
  if (id >= instancers_.size() || !instancers_[id])
    throw std::out_of_range("no instancer with id " + std::to_string(id));
  return *instancers_[id];
}

Geometry::InstancerRecord& Geometry::instancer(InstancerId id) {
  return const_cast<InstancerRecord&>(std::as_const(*this).instancer(id));
}

std::unique_ptr<Geometry::Placement> Geometry::newPlacement(MeshId mesh) {
  auto placement = std::make_unique<Placement>();
  placement->mesh = mesh;
  placement->geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
  placement->geomId = rtcAttachGeometry(top_, placement->geometry);
  throwOnEmbreeError(device_, "add an instance");
  if (placement->geomId >= placements_.size()) {
    placements_.resize(placement->geomId + 1, nullptr);
    staleInTop_.resize(placement->geomId + 1, 0);
  }
  placements_[placement->geomId] = placement.get();
  ++topGeometries_;
  topChanged_ = true;
  return placement;
}

void Geometry::releasePlacement(std::unique_ptr<Placement>& placement) {
  if (!placement) return;
  if (MeshRecord& mesh = *meshes_[placement->mesh]; !placement->instancer && mesh.overlay)
    removeFromOverlay(mesh);
  rtcDetachGeometry(top_, placement->geomId);
  --topGeometries_;
  topChanged_ = true;
  rtcReleaseGeometry(placement->geometry);
  placements_[placement->geomId] = nullptr;
  placement.reset();
}

bool Geometry::mayOverlay(const MeshRecord& mesh) const {
  return built_ && topGeometries_ >= kOverlayThreshold && mesh.bvh && mesh.bvh == mesh.placedBvh &&
         (mesh.overlay || overlaid_ < kMaxOverlaid);
}

void Geometry::updatePlacement(Placement& placement, bool enabled) {
  MeshRecord& mesh = *meshes_[placement.mesh];
  enabled = enabled && mesh.bvh;
  if (placement.instancer) {
    placeInstance(placement.geometry, placement, enabled);
    topChanged_ = true;
    return;
  }
  enabled = enabled && invertible(placement);
  mesh.ownBeyondReach = enabled && !withinReach(placement);
  enabled = enabled && !mesh.ownBeyondReach;
  mesh.ownEnabled = enabled;
  ownBounds_.set(placement.mesh, worldBounds(placement, enabled));
  if (mayOverlay(mesh)) {
    if (!mesh.overlay) {
      if (!overlay_) overlay_ = rtcNewScene(device_);
      mesh.overlay = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
      mesh.overlayGeomId = rtcAttachGeometry(overlay_, mesh.overlay);
      throwOnEmbreeError(device_, "add an instance to the overlay");
      if (mesh.overlayGeomId >= overlayIds_.size()) overlayIds_.resize(mesh.overlayGeomId + 1);
      overlayIds_[mesh.overlayGeomId] = placement.geomId;
      staleInTop_[placement.geomId] = 1;
      ++overlaid_;
    }
    placeInstance(mesh.overlay, placement, enabled);
    overlayChanged_ = true;
    return;
  }
  if (mesh.overlay) removeFromOverlay(mesh);
  placeInstance(placement.geometry, placement, enabled);
  mesh.placedBvh = mesh.bvh;
  topChanged_ = true;
}

void Geometry::removeFromOverlay(MeshRecord& mesh) {
  rtcDetachGeometry(overlay_, mesh.overlayGeomId);
  rtcReleaseGeometry(mesh.overlay);
  mesh.overlay = nullptr;
  staleInTop_[mesh.own->geomId] = 0;
  --overlaid_;
  overlayChanged_ = true;
}

void Geometry::foldOverlay() {
  for (auto& mesh : meshes_) {
    if (!mesh || !mesh->overlay) continue;
    removeFromOverlay(*mesh);
    placeInstance(mesh->own->geometry, *mesh->own, mesh->ownEnabled);
    mesh->placedBvh = mesh->bvh;
    topChanged_ = true;
  }
}

bool Geometry::prepareForSamples(uint64_t cameraSamples) {
  // Folding rebuilds top_, about 0.45 µs an instance; the overlay costs the rays of each camera
  // sample a filter call per candidate hit and a second, short traversal, about 0.02 µs (2-4 %
  // of a 960-pixel render of 10,000 meshes, measured).
  if (overlaid_ == 0 || cameraSamples < kFoldingSamplesPerInstance * topGeometries_) return false;
  foldOverlay();
  return true;
}

Geometry::Box Geometry::boundsOf(RTCScene committed) {
  RTCBounds b;
  rtcGetSceneBounds(committed, &b);
  return {{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}};
}

Geometry::Box Geometry::worldBounds(const Placement& placement, bool enabled) const {
  Box box;
  if (!enabled) return box;
  const Box& object = meshes_[placement.mesh]->objectBounds;
  for (const Transform& step : placement.objectToWorld.steps())
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3f point = step.applyToPoint({corner & 1 ? object.upper.x : object.lower.x,
                                             corner & 2 ? object.upper.y : object.lower.y,
                                             corner & 4 ? object.upper.z : object.lower.z});
      box.extend({point, point});
    }
  return box;
}

void Geometry::forEachObjectBounds(const std::function<void(int materialIndex, const Vec3f& lower,
                                                            const Vec3f& upper)>& visit) const {
  for (const std::unique_ptr<MeshRecord>& mesh : meshes_) {
    if (!mesh || !renderable(*mesh)) continue;
    const auto visitBox = [&](const Box& box) {
      if (box.lower.x > box.upper.x) return;
      visit(mesh->materialIndex, box.lower, box.upper);
      for (const int material : mesh->slotMaterials)
        if (material != mesh->materialIndex) visit(material, box.lower, box.upper);
    };
    if (mesh->own) visitBox(worldBounds(*mesh->own, mesh->ownEnabled));
    for (const InstancerId id : mesh->instancers) visitBox(instancer(id).bounds);
  }
}

bool Geometry::hidesFromRays() const {
  const auto hides = [](const PassVisibility& pass) {
    return !pass.shadow || !pass.diffuse || !pass.glossy || !pass.transmission;
  };
  for (const std::unique_ptr<MeshRecord>& mesh : meshes_)
    if (mesh && renderable(*mesh) && mesh->ownEnabled && hides(mesh->pass)) return true;
  for (const std::unique_ptr<InstancerRecord>& copies : instancers_)
    if (copies && copies->visible && !copies->copies.empty() && hides(copies->pass)) return true;
  return false;
}

bool Geometry::withinReach(const Placement& placement) const {
  const Box box = worldBounds(placement, true);
  if (box.lower.x > box.upper.x) return true;  // empty: nothing to place
  const auto within = [](const Vec3f& p) {
    // Written so that NaN fails too.
    return std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate &&
           std::abs(p.z) <= kMaxCoordinate;
  };
  return within(box.lower) && within(box.upper);
}

bool Geometry::invertible(const Placement& placement) {
  for (const Transform& step : placement.objectToWorld.steps()) {
    // Embree inverts each instance transform in single precision for every ray.
    if (!(std::abs(step.linearDeterminant()) >= double(std::numeric_limits<float>::min())))
      return false;
    // Every entry a float; and the rays Embree carries into the object must stay within its
    // 1.8e18 (it asserts so): a scale of 1e-18 along one axis took a unit direction there.
    // kMaxInverseScale on the linear part keeps directions far inside that, and origins within
    // 1e6 of the object too.
    const Transform inverse = step.inverse();
    for (int row = 0; row < 4; ++row)
      for (int column = 0; column < 4; ++column) {
        const double bound =
            row < 3 && column < 3 ? kMaxInverseScale : double(std::numeric_limits<float>::max());
        if (!(std::abs(inverse.at(row, column)) <= bound)) return false;
      }
  }
  return true;
}

bool Geometry::beyondReach(MeshId id) const {
  return record(id).ownBeyondReach;
}

size_t Geometry::copiesBeyondReach(InstancerId id) const {
  return instancer(id).beyondReach;
}

void Geometry::placeInstance(RTCGeometry geometry, const Placement& placement, bool enabled) const {
  const MeshRecord& mesh = *meshes_[placement.mesh];
  if (mesh.bvh) rtcSetGeometryInstancedScene(geometry, mesh.bvh);
  const std::vector<Transform>& steps = placement.objectToWorld.steps();
  rtcSetGeometryTimeStepCount(geometry, unsigned(steps.size()));
  if (steps.size() == 1) {
    const std::array<float, 12> matrix = steps.front().toEmbreeColumnMajor3x4();
    rtcSetGeometryTransform(geometry, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, matrix.data());
  } else {
    // Quaternion-decomposed steps: Embree slerps the rotation, so turns travel on arcs.
    Quaternion previous;
    for (unsigned step = 0; step < steps.size(); ++step) {
      const TransformDecomposition& d = placement.objectToWorld.decompositions()[step];
      Quaternion q = d.rotation;
      if (q.w * previous.w + q.x * previous.x + q.y * previous.y + q.z * previous.z < 0)
        q = {-q.w, -q.x, -q.y, -q.z};  // same rotation, on the near side of the previous key
      previous = q;
      RTCQuaternionDecomposition embree;
      rtcInitQuaternionDecomposition(&embree);
      embree.scale_x = float(d.scaleShear[0]);
      embree.skew_xy = float(d.scaleShear[1]);
      embree.skew_xz = float(d.scaleShear[2]);
      embree.scale_y = float(d.scaleShear[3]);
      embree.skew_yz = float(d.scaleShear[4]);
      embree.scale_z = float(d.scaleShear[5]);
      embree.quaternion_r = float(q.w);
      embree.quaternion_i = float(q.x);
      embree.quaternion_j = float(q.y);
      embree.quaternion_k = float(q.z);
      embree.translation_x = float(d.translation[0]);
      embree.translation_y = float(d.translation[1]);
      embree.translation_z = float(d.translation[2]);
      rtcSetGeometryTransformQuaternion(geometry, step, &embree);
    }
  }
  rtcSetGeometryMask(geometry, ray_mask::ofPlacement(passOf(placement)));
  if (enabled)
    rtcEnableGeometry(geometry);
  else
    rtcDisableGeometry(geometry);
  rtcCommitGeometry(geometry);
  throwOnEmbreeError(device_, "update an instance");
}

const PassVisibility& Geometry::passOf(const Placement& placement) const {
  return placement.instancer ? placement.instancer->pass : meshes_[placement.mesh]->pass;
}

template <typename Predicate>
bool Geometry::anyMaterialOf(const MeshRecord& mesh, Predicate cuts) const {
  if (cuts(materials_.find(mesh.materialIndex))) return true;
  for (const int material : mesh.slotMaterials)
    if (cuts(materials_.find(material))) return true;
  return false;
}

uint32_t Geometry::faceSlotOf(const MeshRecord& mesh, uint32_t primitive) {
  if (mesh.faceSlots.empty()) return 0;
  const int face = mesh.shape->elementOf(primitive);
  return face >= 0 && size_t(face) < mesh.faceSlots.size() ? mesh.faceSlots[size_t(face)] : 0;
}

int Geometry::materialOf(const MeshRecord& mesh, uint32_t faceSlot) {
  return faceSlot == 0 ? mesh.materialIndex : mesh.slotMaterials[faceSlot - 1];
}

bool Geometry::renderable(const MeshRecord& mesh) const {
  if (!mesh.bvh) return false;
  return anyMaterialOf(
      mesh, [](const Material* material) { return !material || !cutsOutWhole(*material); });
}

bool Geometry::updateHitFilters(MeshRecord& mesh) {
  if (!mesh.geometry) return false;
  // With per-face materials, faces whose material cuts them out whole are cut out per hit.
  const bool perFace = !mesh.faceSlots.empty();
  const bool cutouts = anyMaterialOf(mesh, [perFace](const Material* material) {
    return material && (cutsOutPerHit(*material) || (perFace && cutsOutWhole(*material)));
  });
  if (cutouts == mesh.cutoutFilter) return false;
  mesh.cutoutFilter = cutouts;
  applyHitFilters(mesh);
  return true;
}

void Geometry::applyHitFilters(MeshRecord& mesh) {
  rtcSetGeometryIntersectFilterFunction(
      mesh.geometry, mesh.cutoutFilter || !mesh.doubleSided ? filterHits : nullptr);
  rtcSetGeometryOccludedFilterFunction(mesh.geometry, mesh.cutoutFilter ? filterHits : nullptr);
  rtcCommitGeometry(mesh.geometry);
  rtcCommitScene(mesh.bvh);
  throwOnEmbreeError(device_, "update a mesh's hit filters");
  // Its instances, then top_, are to be committed again (Embree's instancing rules), so its own
  // placement may not go to the overlay until it is.
  mesh.placedBvh = nullptr;
}

void Geometry::updateAllPlacements(MeshId id) {
  MeshRecord& mesh = record(id);
  const bool shown = renderable(mesh);
  updatePlacement(*mesh.own, shown && mesh.visible);
  for (const InstancerId user : mesh.instancers) {
    InstancerRecord& copies = instancer(user);
    updateCopies(copies, shown && copies.visible);
  }
}

void Geometry::updateCopies(InstancerRecord& copies, bool shown) {
  copies.bounds = Box{};
  copies.beyondReach = 0;
  const bool enabled = shown && meshes_[copies.prototype]->bvh;
  for (auto& copy : copies.copies) {
    const bool shows = enabled && invertible(*copy);
    const bool placed = shows && withinReach(*copy);
    copies.beyondReach += shows && !placed;
    updatePlacement(*copy, placed);
    copies.bounds.extend(worldBounds(*copy, placed));
  }
}

Geometry::MeshId Geometry::addMesh() {
  const MeshId id = MeshId(meshes_.size());
  meshes_.push_back(std::make_unique<MeshRecord>());
  meshes_.back()->own = newPlacement(id);
  updatePlacement(*meshes_.back()->own, false);  // nothing to show until it has geometry
  return id;
}

void Geometry::removeMesh(MeshId id) {
  MeshRecord& mesh = record(id);
  if (!mesh.instancers.empty())
    throw std::logic_error("mesh " + std::to_string(id) + " is still placed by an instancer");
  releasePlacement(mesh.own);
  if (mesh.bvh) rtcReleaseScene(mesh.bvh);
  meshes_[id].reset();
  ownBounds_.set(id, Box{});
}

void Geometry::setMeshGeometry(MeshId id, TriangleMesh data) {
  record(id);  // throws for an unknown id before any name is registered
  for (const Primvar& primvar : data.primvars) materials_.registerPrimvarName(primvar.name);
  setShape(id, std::make_shared<const MeshShape>(std::move(data)));
}

void Geometry::setPointsGeometry(MeshId id, PointsData points) {
  record(id);  // throws for an unknown id before any name is registered
  validatePoints(points);
  for (const Primvar& primvar : points.primvars) materials_.registerPrimvarName(primvar.name);
  setShape(id, std::make_shared<const PointsShape>(std::move(points)));
}

void Geometry::setCurvesGeometry(MeshId id, CurvesData curves) {
  record(id);  // throws for an unknown id before any name is registered
  validateCurves(curves);
  for (const Primvar& primvar : curves.primvars) materials_.registerPrimvarName(primvar.name);
  setShape(id, std::make_shared<const CurvesShape>(std::move(curves)));
}

void Geometry::setShape(MeshId id, std::shared_ptr<const Shape> shape) {
  MeshRecord& mesh = record(id);
  if (mesh.shape && mesh.geometry && shape->tracesAs(*mesh.shape)) {
    // Same surface: its BVH stands; the hit filter follows the sidedness.
    const bool sidednessChanged = shape->doubleSided() != mesh.doubleSided;
    mesh.shape = std::move(shape);
    if (sidednessChanged) {
      mesh.doubleSided = mesh.shape->doubleSided();
      applyHitFilters(mesh);
      updateAllPlacements(id);
    }
    return;
  }
  RTCScene bvh = nullptr;
  Box objectBounds;
  RTCGeometry geometry = shape->newEmbreeGeometry(device_);
  if (geometry) {
    bvh = rtcNewScene(device_);
    rtcSetSceneFlags(bvh, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);  // see skipPlacements
    rtcSetGeometryUserData(geometry, &mesh);
    if (!shape->doubleSided()) rtcSetGeometryIntersectFilterFunction(geometry, filterHits);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(bvh, geometry);
    rtcReleaseGeometry(geometry);  // `bvh` keeps it
    const auto started = std::chrono::steady_clock::now();
    rtcCommitScene(bvh);
    meshBvhBuildSeconds_ +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    throwOnEmbreeError(device_, "build a mesh BVH");
    ++meshBvhBuilds_;
    objectBounds = boundsOf(bvh);
  }
  mesh.geometry = geometry;
  mesh.cutoutFilter = false;
  // Instances keep their own reference to the old BVH until they are pointed at the new one.
  if (mesh.bvh) rtcReleaseScene(mesh.bvh);
  mesh.bvh = bvh;
  mesh.objectBounds = objectBounds;
  mesh.doubleSided = shape->doubleSided();
  mesh.shape = std::move(shape);
  updateHitFilters(mesh);
  updateAllPlacements(id);
}

void Geometry::clearMeshGeometry(MeshId id) {
  setMeshGeometry(id, TriangleMesh{});
}

void Geometry::setMeshInstance(MeshId id, const MotionTransform& objectToWorld, int materialIndex,
                               bool visible) {
  MeshRecord& mesh = record(id);
  const bool wasRenderable = renderable(mesh);
  mesh.own->objectToWorld = objectToWorld;
  mesh.materialIndex = materialIndex;
  mesh.visible = visible;
  // Copies follow only what the mesh's material does to them, not its own placement.
  if (updateHitFilters(mesh) || renderable(mesh) != wasRenderable)
    updateAllPlacements(id);
  else
    updatePlacement(*mesh.own, renderable(mesh) && visible);
}

void Geometry::followMaterial(size_t index, MaterialTable::CutoutChange change) {
  if (!change.whole && !change.perHit) return;
  for (MeshId id = 0; id < meshes_.size(); ++id) {
    MeshRecord* mesh = meshes_[id].get();
    if (!mesh || (mesh->materialIndex != int(index) &&
                  std::find(mesh->slotMaterials.begin(), mesh->slotMaterials.end(), int(index)) ==
                      mesh->slotMaterials.end()))
      continue;
    if (updateHitFilters(*mesh) || change.whole) updateAllPlacements(id);
  }
}

void Geometry::setMeshFaceMaterials(MeshId id, std::vector<uint32_t> faceSlots,
                                    std::vector<int> slotMaterials) {
  MeshRecord& mesh = record(id);
  for (const uint32_t slot : faceSlots)
    if (slot > slotMaterials.size())
      throw std::invalid_argument("a face takes subset slot " + std::to_string(slot) + " of " +
                                  std::to_string(slotMaterials.size()));
  if (faceSlots.empty()) slotMaterials.clear();
  if (faceSlots == mesh.faceSlots && slotMaterials == mesh.slotMaterials) return;
  const bool wasRenderable = renderable(mesh);
  mesh.faceSlots = std::move(faceSlots);
  mesh.slotMaterials = std::move(slotMaterials);
  if (updateHitFilters(mesh) || renderable(mesh) != wasRenderable) updateAllPlacements(id);
}

void Geometry::setMeshPassVisibility(MeshId id, PassVisibility pass) {
  MeshRecord& mesh = record(id);
  mesh.pass = pass;
  updatePlacement(*mesh.own, renderable(mesh) && mesh.visible);
}

Geometry::InstancerId Geometry::addInstancer() {
  instancers_.push_back(std::make_unique<InstancerRecord>());
  return InstancerId(instancers_.size() - 1);
}

void Geometry::setInstances(InstancerId id, MeshId prototype,
                            std::vector<MotionTransform> transforms, bool visible) {
  InstancerRecord& copies = instancer(id);
  MeshRecord& mesh = record(prototype);
  if (copies.prototype != prototype || copies.copies.empty()) {
    if (!copies.copies.empty()) {
      auto& users = record(copies.prototype).instancers;
      users.erase(std::remove(users.begin(), users.end(), id), users.end());
    }
    if (std::find(mesh.instancers.begin(), mesh.instancers.end(), id) == mesh.instancers.end())
      mesh.instancers.push_back(id);
  }
  copies.prototype = prototype;
  copies.visible = visible;
  if (transforms.size() != copies.copies.size()) {  // one value per copy
    copies.primvars.clear();
    copies.linkingClasses.clear();
  }
  // Reuse the Embree geometries already there; create or drop the difference.
  while (copies.copies.size() > transforms.size()) {
    releasePlacement(copies.copies.back());
    copies.copies.pop_back();
  }
  while (copies.copies.size() < transforms.size()) copies.copies.push_back(newPlacement(prototype));
  for (size_t i = 0; i < transforms.size(); ++i) {
    Placement& copy = *copies.copies[i];
    copy.mesh = prototype;
    copy.instancer = &copies;
    copy.copy = uint32_t(i);
    copy.objectToWorld = std::move(transforms[i]);
    copy.linkingClass =
        copies.linkingClasses.empty() ? LinkingTable::kLinkedToAll : copies.linkingClasses[i];
  }
  updateCopies(copies, renderable(mesh) && visible);
}

void Geometry::setInstancePrimvars(InstancerId id, std::vector<Primvar> primvars) {
  InstancerRecord& copies = instancer(id);
  for (const Primvar& primvar : primvars) {
    materials_.registerPrimvarName(primvar.name);
    if (primvar.width < 1 || primvar.width > 4 ||
        primvar.values.size() != copies.copies.size() * size_t(primvar.width))
      throw std::invalid_argument("per-instance primvar " + primvar.name.str() + " has " +
                                  std::to_string(primvar.values.size()) + " floats for " +
                                  std::to_string(copies.copies.size()) + " copies of width " +
                                  std::to_string(primvar.width));
  }
  copies.primvars = std::move(primvars);
}

void Geometry::setInstanceLinkingClasses(InstancerId id, std::vector<uint32_t> classes) {
  InstancerRecord& copies = instancer(id);
  if (!classes.empty() && classes.size() != copies.copies.size())
    throw std::invalid_argument(std::to_string(classes.size()) + " linking classes for " +
                                std::to_string(copies.copies.size()) + " copies");
  // The classes are read by shading and the shadow-ray filter only: Embree's state stays.
  for (size_t i = 0; i < copies.copies.size(); ++i)
    copies.copies[i]->linkingClass = classes.empty() ? LinkingTable::kLinkedToAll : classes[i];
  copies.linkingClasses = std::move(classes);
}

void Geometry::setMeshLinkingClass(MeshId id, uint32_t linkingClass) {
  record(id).own->linkingClass = linkingClass;
}

void Geometry::setInstancerPassVisibility(InstancerId id, PassVisibility pass) {
  InstancerRecord& copies = instancer(id);
  copies.pass = pass;
  if (copies.copies.empty()) return;
  updateCopies(copies, renderable(record(copies.prototype)) && copies.visible);
}

void Geometry::removeInstancer(InstancerId id) {
  InstancerRecord& copies = instancer(id);
  if (!copies.copies.empty()) {
    auto& users = record(copies.prototype).instancers;
    users.erase(std::remove(users.begin(), users.end(), id), users.end());
  }
  for (auto& copy : copies.copies) releasePlacement(copy);
  instancers_[id].reset();
}

void Geometry::commit() {
  if (overlaid_ && topChanged_) foldOverlay();  // top_ is rebuilt anyway
  if (overlayChanged_ && overlaid_) {
    rtcCommitScene(overlay_);
    throwOnEmbreeError(device_, "build the overlay BVH");
    overlayBounds_ = boundsOf(overlay_);
    topLevelBvhPrimitives_ += overlaid_;
  }
  if (topChanged_ || overlayChanged_) {
    // From the placements' own boxes rather than from Embree's BVH, whose top_ still holds the
    // overlaid placements where they were: an edited scene and one built afresh agree.
    Box world = ownBounds_.all();
    for (const auto& copies : instancers_)
      if (copies) world.extend(copies->bounds);
    const Vec3f size = world.upper - world.lower;
    const float extent = std::max({size.x, size.y, size.z});
    extent_ = std::isfinite(extent) && extent > 0 ? extent : 1.0f;
  }
  if (topChanged_) topLevelBvhPrimitives_ += topGeometries_;
  rtcCommitScene(top_);  // returns at once when nothing in it changed
  throwOnEmbreeError(device_, "build the scene BVH");
  built_ = true;
  topChanged_ = overlayChanged_ = false;
}

int Geometry::primvarWidth(const PrimvarName& name) const {
  materials_.checkPrimvarName(name);
  int width = 0;
  for (const auto& mesh : meshes_)
    if (mesh && mesh->shape) width = std::max(width, mesh->shape->primvarWidth(name));
  for (const auto& copies : instancers_)
    if (copies)
      if (const Primvar* primvar = penumbra::findPrimvar(copies->primvars, name))
        width = std::max(width, primvar->width);
  return width;
}

}  // namespace penumbra
