#include "penumbra/scene.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>

#include "penumbra/shading.h"
#include "penumbra/spectrum.h"

namespace penumbra {
namespace {

void throwOnEmbreeError(RTCDevice device, const char* what) {
  const RTCError error = rtcGetDeviceError(device);
  if (error != RTC_ERROR_NONE)
    throw std::runtime_error(std::string("Embree failed to ") + what + " (error " +
                             std::to_string(int(error)) + ")");
}

// Ray mask bits of the placements: camera rays test only kCameraRays, so geometry a render pass
// hides from the camera keeps only kOtherRays and still casts shadows and reflects.
constexpr unsigned kCameraRays = 1u;
constexpr unsigned kOtherRays = 2u;

/// Whether the ray's segment [tnear, tfar] meets the box, slightly widened against rounding.
bool segmentMeetsBox(const RTCRay& ray, const Vec3f& lower, const Vec3f& upper) {
  const float pad = 1e-4f * std::max({maxAbsComponent(lower), maxAbsComponent(upper), 1.0f});
  const float origin[3] = {ray.org_x, ray.org_y, ray.org_z};
  const float direction[3] = {ray.dir_x, ray.dir_y, ray.dir_z};
  float tNear = ray.tnear, tFar = ray.tfar;
  for (int axis = 0; axis < 3; ++axis) {
    const float low = lower[axis] - pad, high = upper[axis] + pad;
    if (direction[axis] == 0) {
      if (origin[axis] < low || origin[axis] > high) return false;
      continue;
    }
    float t0 = (low - origin[axis]) / direction[axis], t1 = (high - origin[axis]) / direction[axis];
    if (t0 > t1) std::swap(t0, t1);
    tNear = std::max(tNear, t0);
    tFar = std::min(tFar, t1);
    if (tNear > tFar) return false;
  }
  return true;
}

RTCRay toEmbreeRay(const Ray& ray) {
  RTCRay r;
  r.org_x = ray.origin.x;
  r.org_y = ray.origin.y;
  r.org_z = ray.origin.z;
  r.dir_x = ray.direction.x;
  r.dir_y = ray.direction.y;
  r.dir_z = ray.direction.z;
  r.tnear = ray.tNear;
  r.tfar = ray.tFar;
  r.time = ray.time;
  r.mask = 0xffffffffu;
  r.id = 0;
  r.flags = 0;
  return r;
}

}  // namespace

/// An intersect context that tells the hit filters whether the ray comes from the camera, where
/// the materials are, and, in the overlay, whose placements its instances are.
struct Scene::TraceContext {
  RTCIntersectContext embree;  // first member: Embree passes a pointer to it to the filters
  bool cameraRay;
  const Scene* scene;
  const std::vector<uint32_t>* overlayIds = nullptr;  // while tracing the overlay

  /// For a trace of `scene`'s top_ (skipping overlaid placements' stale instances there).
  TraceContext(const Scene& traced, RayKind kind)
      : cameraRay(kind == RayKind::Camera), scene(&traced) {
    rtcInitIntersectContext(&embree);
    if (traced.overlaid_) embree.filter = skipOverlaid;
  }

  /// The top_ geomID of the placement of an instance met in the BVH being traced.
  uint32_t placementId(uint32_t instanceGeomId) const {
    return overlayIds ? (*overlayIds)[instanceGeomId] : instanceGeomId;
  }
};

void Scene::BoxUnion::set(size_t index, const Box& box) {
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

Scene::Box Scene::BoxUnion::all() {
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

Device::Device() : device_(rtcNewDevice(nullptr)) {
  if (!device_) throw std::runtime_error("Embree could not create a device");
}

Device::~Device() {
  rtcReleaseDevice(device_);
}

Scene::Scene(const Device& device, const std::string& colorConfig)
    : device_(device.get()),
      top_(rtcNewScene(device_)),
      textures_(std::make_shared<TextureSystem>(colorConfig)) {
  rtcRetainDevice(device_);
  rtcSetSceneFlags(top_, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);  // see skipOverlaid
  throwOnEmbreeError(device_, "create a scene");
}

Scene::~Scene() {
  for (auto& instancerRecord : instancers_)
    if (instancerRecord)
      for (auto& copy : instancerRecord->copies) releasePlacement(copy);
  for (auto& mesh : meshes_) {
    if (!mesh) continue;
    releasePlacement(mesh->own);
    if (mesh->bvh) rtcReleaseScene(mesh->bvh);
  }
  if (overlay_) rtcReleaseScene(overlay_);
  if (lightScene_) rtcReleaseScene(lightScene_);
  rtcReleaseScene(top_);
  rtcReleaseDevice(device_);
}

Scene::MeshRecord& Scene::record(MeshId id) {
  if (id >= meshes_.size() || !meshes_[id])
    throw std::out_of_range("no mesh with id " + std::to_string(id));
  return *meshes_[id];
}

Scene::InstancerRecord& Scene::instancer(InstancerId id) {
  if (id >= instancers_.size() || !instancers_[id])
    throw std::out_of_range("no instancer with id " + std::to_string(id));
  return *instancers_[id];
}

std::unique_ptr<Scene::Placement> Scene::newPlacement(MeshId mesh) {
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

void Scene::releasePlacement(std::unique_ptr<Placement>& placement) {
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

bool Scene::mayOverlay(const MeshRecord& mesh) const {
  return built_ && topGeometries_ >= kOverlayThreshold && mesh.bvh && mesh.bvh == mesh.placedBvh &&
         (mesh.overlay || overlaid_ < kMaxOverlaid);
}

void Scene::updatePlacement(Placement& placement, bool enabled) {
  MeshRecord& mesh = *meshes_[placement.mesh];
  enabled = enabled && mesh.bvh;
  if (placement.instancer) {
    placeInstance(placement.geometry, placement, enabled);
    topChanged_ = true;
    return;
  }
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

void Scene::removeFromOverlay(MeshRecord& mesh) {
  rtcDetachGeometry(overlay_, mesh.overlayGeomId);
  rtcReleaseGeometry(mesh.overlay);
  mesh.overlay = nullptr;
  staleInTop_[mesh.own->geomId] = 0;
  --overlaid_;
  overlayChanged_ = true;
}

void Scene::foldOverlay() {
  for (auto& mesh : meshes_) {
    if (!mesh || !mesh->overlay) continue;
    removeFromOverlay(*mesh);
    placeInstance(mesh->own->geometry, *mesh->own, mesh->ownEnabled);
    mesh->placedBvh = mesh->bvh;
    topChanged_ = true;
  }
}

bool Scene::prepareForSamples(uint64_t cameraSamples) {
  // Folding rebuilds top_, about 0.45 µs an instance; the overlay costs the rays of each camera
  // sample a filter call per candidate hit and a second, short traversal, about 0.02 µs (2-4 %
  // of a 960-pixel render of 10,000 meshes, measured).
  if (overlaid_ == 0 || cameraSamples < kFoldingSamplesPerInstance * topGeometries_) return false;
  foldOverlay();
  return true;
}

Scene::Box Scene::boundsOf(RTCScene committed) {
  RTCBounds b;
  rtcGetSceneBounds(committed, &b);
  return {{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}};
}

Scene::Box Scene::worldBounds(const Placement& placement, bool enabled) const {
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

void Scene::placeInstance(RTCGeometry geometry, const Placement& placement, bool enabled) const {
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
  rtcSetGeometryMask(geometry, passOf(placement).camera ? kCameraRays | kOtherRays : kOtherRays);
  if (enabled)
    rtcEnableGeometry(geometry);
  else
    rtcDisableGeometry(geometry);
  rtcCommitGeometry(geometry);
  throwOnEmbreeError(device_, "update an instance");
}

const PassVisibility& Scene::passOf(const Placement& placement) const {
  return placement.instancer ? placement.instancer->pass : meshes_[placement.mesh]->pass;
}

const Material* Scene::materialOf(const MeshRecord& mesh) const {
  if (mesh.materialIndex < 0 || size_t(mesh.materialIndex) >= materials_.size()) return nullptr;
  return &materials_[size_t(mesh.materialIndex)];
}

namespace {
/// Whether a material cuts whole meshes out (constant opacity below its threshold).
bool cutsOut(const Material& material) {
  const MaterialParams& constants = material.constants;
  return !material.opacityVaries() && constants.opacityThreshold > 0 &&
         constants.opacity < constants.opacityThreshold;
}
/// Whether a material cuts surfaces out per hit (textured opacity with a threshold).
bool cutsOutPerHit(const Material& material) {
  return material.opacityVaries() && material.constants.opacityThreshold > 0;
}
}  // namespace

bool Scene::renderable(const MeshRecord& mesh) const {
  if (!mesh.bvh) return false;
  const Material* material = materialOf(mesh);
  return !material || !cutsOut(*material);
}

bool Scene::updateHitFilters(MeshRecord& mesh) {
  if (!mesh.triangles) return false;
  const Material* material = materialOf(mesh);
  const bool cutouts = material && cutsOutPerHit(*material);
  if (cutouts == mesh.cutoutFilter) return false;
  mesh.cutoutFilter = cutouts;
  applyHitFilters(mesh);
  return true;
}

void Scene::applyHitFilters(MeshRecord& mesh) {
  rtcSetGeometryIntersectFilterFunction(
      mesh.triangles, mesh.cutoutFilter || !mesh.data->doubleSided ? filterHits : nullptr);
  rtcSetGeometryOccludedFilterFunction(mesh.triangles, mesh.cutoutFilter ? filterHits : nullptr);
  rtcCommitGeometry(mesh.triangles);
  rtcCommitScene(mesh.bvh);
  throwOnEmbreeError(device_, "update a mesh's hit filters");
  // Its instances, then top_, are to be committed again (Embree's instancing rules), so its own
  // placement may not go to the overlay until it is.
  mesh.placedBvh = nullptr;
}

void Scene::filterHits(const RTCFilterFunctionNArguments* args) {
  const auto* context = reinterpret_cast<const TraceContext*>(args->context);
  const auto* mesh = static_cast<const MeshRecord*>(args->geometryUserPtr);
  const Material* material = mesh->cutoutFilter ? context->scene->materialOf(*mesh) : nullptr;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    // Camera rays do not see the back faces of single-sided meshes. Embree's geometric normal
    // is (v1-v0)×(v2-v0) in object space, which faces the viewer for counter-clockwise (front)
    // triangles; the ray is in the same object space here, so the test holds under any
    // instance transform.
    if (context->cameraRay && !mesh->data->doubleSided) {
      const float facing =
          RTCRayN_dir_x(args->ray, args->N, i) * RTCHitN_Ng_x(args->hit, args->N, i) +
          RTCRayN_dir_y(args->ray, args->N, i) * RTCHitN_Ng_y(args->hit, args->N, i) +
          RTCRayN_dir_z(args->ray, args->N, i) * RTCHitN_Ng_z(args->hit, args->N, i);
      if (facing > 0) {
        args->valid[i] = 0;
        continue;
      }
    }
    if (!material) continue;
    SurfacePoint point;
    point.mesh = mesh->data.get();
    point.triangle = RTCHitN_primID(args->hit, args->N, i);
    point.u = RTCHitN_u(args->hit, args->N, i);
    point.v = RTCHitN_v(args->hit, args->N, i);
    const float time = RTCRayN_time(args->ray, args->N, i);
    for (int corner = 0; corner < 3; ++corner)
      point.corners[corner] = point.mesh->cornerAt(point.triangle, corner, time);
    context->scene->attachInstancePrimvars(
        context->placementId(RTCHitN_instID(args->hit, args->N, i, 0)), &point);
    if (evaluateOpacity(*material, *context->scene->textures_, point) <
        material->constants.opacityThreshold)
      args->valid[i] = 0;
  }
}

void Scene::attachInstancePrimvars(unsigned geomId, SurfacePoint* point) const {
  const Placement& placement = *placements_[geomId];
  if (placement.instancer && !placement.instancer->primvars.empty()) {
    point->instancePrimvars = &placement.instancer->primvars;
    point->instance = placement.copy;
  }
}

void Scene::updateAllPlacements(MeshId id) {
  MeshRecord& mesh = record(id);
  const bool shown = renderable(mesh);
  updatePlacement(*mesh.own, shown && mesh.visible);
  for (const InstancerId user : mesh.instancers) {
    InstancerRecord& copies = instancer(user);
    updateCopies(copies, shown && copies.visible);
  }
}

void Scene::updateCopies(InstancerRecord& copies, bool shown) {
  copies.bounds = Box{};
  const bool enabled = shown && meshes_[copies.prototype]->bvh;
  for (auto& copy : copies.copies) {
    updatePlacement(*copy, enabled);
    copies.bounds.extend(worldBounds(*copy, enabled));
  }
}

Scene::MeshId Scene::addMesh() {
  const MeshId id = MeshId(meshes_.size());
  meshes_.push_back(std::make_unique<MeshRecord>());
  meshes_.back()->own = newPlacement(id);
  updatePlacement(*meshes_.back()->own, false);  // nothing to show until it has geometry
  return id;
}

void Scene::removeMesh(MeshId id) {
  MeshRecord& mesh = record(id);
  if (!mesh.instancers.empty())
    throw std::logic_error("mesh " + std::to_string(id) + " is still placed by an instancer");
  releasePlacement(mesh.own);
  if (mesh.bvh) rtcReleaseScene(mesh.bvh);
  meshes_[id].reset();
  ownBounds_.set(id, Box{});
}

namespace {

template <typename T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
  static_assert(std::is_trivially_copyable_v<T>);
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

/// Whether two meshes have the same triangles at the same points (bit for bit) at every step.
bool sameSurface(const TriangleMesh& a, const TriangleMesh& b) {
  if (!sameBits(a.triangles, b.triangles) || !sameBits(a.points, b.points) ||
      a.pointMotion.size() != b.pointMotion.size())
    return false;
  for (size_t step = 0; step < a.pointMotion.size(); ++step)
    if (!sameBits(a.pointMotion[step], b.pointMotion[step])) return false;
  return true;
}
}  // namespace

void Scene::checkPrimvarName(const PrimvarName& name) const {
  const auto found = primvarNames_.find(name.key());
  if (found != primvarNames_.end() && found->second != name.str())
    throw std::invalid_argument("primvar names '" + found->second + "' and '" + name.str() +
                                "' have the same 64-bit key; rename one of them");
}

void Scene::registerPrimvarName(const PrimvarName& name) {
  if (name.empty()) return;
  checkPrimvarName(name);
  primvarNames_.emplace(name.key(), name.str());
}

void Scene::setMeshGeometry(MeshId id, TriangleMesh data) {
  MeshRecord& mesh = record(id);
  for (const Primvar& primvar : data.primvars) registerPrimvarName(primvar.name);
  if (mesh.data && mesh.triangles && sameSurface(data, *mesh.data)) {
    // Same surface: its BVH stands; the hit filter follows the sidedness.
    const bool sidednessChanged = data.doubleSided != mesh.data->doubleSided;
    mesh.data = std::make_shared<const TriangleMesh>(std::move(data));
    if (sidednessChanged) {
      applyHitFilters(mesh);
      updateAllPlacements(id);
    }
    return;
  }
  RTCScene bvh = nullptr;
  Box objectBounds;
  if (!data.triangles.empty()) {
    bvh = rtcNewScene(device_);
    rtcSetSceneFlags(bvh, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);  // see skipOverlaid
    RTCGeometry triangles = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    const unsigned stepCount = unsigned(data.pointMotion.size() + 1);
    rtcSetGeometryTimeStepCount(triangles, stepCount);
    bool allocated = true;
    for (unsigned step = 0; step < stepCount; ++step) {
      const std::vector<Vec3f>& points = step == 0 ? data.points : data.pointMotion[step - 1];
      auto* vertices = static_cast<Vec3f*>(
          rtcSetNewGeometryBuffer(triangles, RTC_BUFFER_TYPE_VERTEX, step, RTC_FORMAT_FLOAT3,
                                  sizeof(Vec3f), points.size()));
      if (vertices)
        std::copy(points.begin(), points.end(), vertices);
      else
        allocated = false;
    }
    auto* indices = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(triangles, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(uint32_t), data.triangles.size() / 3));
    if (!allocated || !indices) {
      rtcReleaseGeometry(triangles);
      rtcReleaseScene(bvh);
      throwOnEmbreeError(device_, "allocate mesh buffers");
      throw std::runtime_error("Embree could not allocate mesh buffers");
    }
    std::copy(data.triangles.begin(), data.triangles.end(), indices);
    rtcSetGeometryUserData(triangles, &mesh);
    if (!data.doubleSided) rtcSetGeometryIntersectFilterFunction(triangles, filterHits);
    rtcCommitGeometry(triangles);
    rtcAttachGeometry(bvh, triangles);
    rtcReleaseGeometry(triangles);  // `bvh` keeps it
    const auto started = std::chrono::steady_clock::now();
    rtcCommitScene(bvh);
    bvhBuildSeconds_ +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    throwOnEmbreeError(device_, "build a mesh BVH");
    ++meshBvhBuilds_;
    objectBounds = boundsOf(bvh);
    mesh.triangles = triangles;
  } else {
    mesh.triangles = nullptr;
  }
  mesh.cutoutFilter = false;
  // Instances keep their own reference to the old BVH until they are pointed at the new one.
  if (mesh.bvh) rtcReleaseScene(mesh.bvh);
  mesh.bvh = bvh;
  mesh.objectBounds = objectBounds;
  mesh.data = std::make_shared<const TriangleMesh>(std::move(data));
  updateHitFilters(mesh);
  updateAllPlacements(id);
}

void Scene::clearMeshGeometry(MeshId id) {
  setMeshGeometry(id, TriangleMesh{});
}

void Scene::setMeshInstance(MeshId id, const MotionTransform& objectToWorld, int materialIndex,
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

void Scene::setMaterial(size_t index, Material material) {
  if (index > materials_.size())
    throw std::out_of_range("material index " + std::to_string(index) + " past the " +
                            std::to_string(materials_.size()) + " materials");
  for (const InputConnection& connection : material.connections)
    registerPrimvarName(connection.primvar);
  for (const TextureReader& reader : material.textures)
    registerPrimvarName(reader.coordinates.primvar);
  for (const ExpressionProgram& program : material.programs)
    for (const ExpressionNode& node : program.nodes) registerPrimvarName(node.primvar);
  if (index == materials_.size()) materials_.emplace_back();
  Material& replaced = materials_[index];
  // Only cut-outs make the meshes using a material depend on it outside of shading; unless they
  // change (seldom), those meshes are not even looked for.
  const bool placementsChange = cutsOut(material) != cutsOut(replaced);
  const bool filtersChange = cutsOutPerHit(material) != cutsOutPerHit(replaced);
  replaced = std::move(material);
  if (!placementsChange && !filtersChange) return;
  for (MeshId id = 0; id < meshes_.size(); ++id) {
    MeshRecord* mesh = meshes_[id].get();
    if (!mesh || mesh->materialIndex != int(index)) continue;
    if (updateHitFilters(*mesh) || placementsChange) updateAllPlacements(id);
  }
}

void Scene::setLight(size_t index, Light light) {
  if (index >= lights_.size())
    throw std::out_of_range("light index " + std::to_string(index) + " past the " +
                            std::to_string(lights_.size()) + " lights");
  lights_[index] = std::move(light);
  lightsChanged_ = true;
}

void Scene::setMeshLight(MeshId id, int lightIndex) {
  record(id).lightIndex = lightIndex;
}

void Scene::setMeshPassVisibility(MeshId id, PassVisibility pass) {
  MeshRecord& mesh = record(id);
  mesh.pass = pass;
  updatePlacement(*mesh.own, renderable(mesh) && mesh.visible);
}

Scene::InstancerId Scene::addInstancer() {
  instancers_.push_back(std::make_unique<InstancerRecord>());
  return InstancerId(instancers_.size() - 1);
}

void Scene::setInstances(InstancerId id, MeshId prototype, std::vector<MotionTransform> transforms,
                         bool visible) {
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
  if (transforms.size() != copies.copies.size()) copies.primvars.clear();  // one value per copy
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
  }
  updateCopies(copies, renderable(mesh) && visible);
}

void Scene::setInstancePrimvars(InstancerId id, std::vector<Primvar> primvars) {
  InstancerRecord& copies = instancer(id);
  for (const Primvar& primvar : primvars) {
    registerPrimvarName(primvar.name);
    if (primvar.width < 1 || primvar.width > 4 ||
        primvar.values.size() != copies.copies.size() * size_t(primvar.width))
      throw std::invalid_argument("per-instance primvar " + primvar.name.str() + " has " +
                                  std::to_string(primvar.values.size()) + " floats for " +
                                  std::to_string(copies.copies.size()) + " copies of width " +
                                  std::to_string(primvar.width));
  }
  copies.primvars = std::move(primvars);
}

void Scene::setInstancerPassVisibility(InstancerId id, PassVisibility pass) {
  InstancerRecord& copies = instancer(id);
  copies.pass = pass;
  if (copies.copies.empty()) return;
  updateCopies(copies, renderable(record(copies.prototype)) && copies.visible);
}

void Scene::removeInstancer(InstancerId id) {
  InstancerRecord& copies = instancer(id);
  if (!copies.copies.empty()) {
    auto& users = record(copies.prototype).instancers;
    users.erase(std::remove(users.begin(), users.end(), id), users.end());
  }
  for (auto& copy : copies.copies) releasePlacement(copy);
  instancers_[id].reset();
}

void Scene::commit() {
  const auto started = std::chrono::steady_clock::now();
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
    sceneExtent_ = std::isfinite(extent) && extent > 0 ? extent : 1.0f;
  }
  if (topChanged_) topLevelBvhPrimitives_ += topGeometries_;
  rtcCommitScene(top_);  // returns at once when nothing in it changed
  throwOnEmbreeError(device_, "build the scene BVH");
  built_ = true;
  topChanged_ = overlayChanged_ = false;
  if (lightsChanged_) {
    lightSampler_ = LightSampler(lights_);
    infiniteLights_.clear();
    for (size_t i = 0; i < lights_.size(); ++i)
      if (lights_[i].isInfinite()) infiniteLights_.push_back(uint32_t(i));
    buildLightScene();
    lightsChanged_ = false;
  }
  bvhBuildSeconds_ +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  spectral_ = std::any_of(materials_.begin(), materials_.end(), [](const Material& m) {
    return m.constants.abbeNumber > 0 && (m.constants.opacity < 1 || m.opacityVaries());
  });
  if (spectral_) prepareSpectralTables();  // now rather than on the first ray
}

float Scene::rayEpsilon(const Vec3f& point) const {
  // Relative to the coordinates' magnitude (float rounding of the hit point and of the instance
  // transform), with a floor tied to the scene's size so that it works in any unit.
  return 2e-5f * std::max(maxAbsComponent(point), 1e-2f * sceneExtent_);
}

int Scene::primvarWidth(const PrimvarName& name) const {
  checkPrimvarName(name);
  int width = 0;
  for (const auto& mesh : meshes_)
    if (mesh && mesh->data) {
      if (const Primvar* primvar = mesh->data->findPrimvar(name))
        width = std::max(width, primvar->width);
      else if (name == displayColorName() && !mesh->data->displayColor.empty())
        width = std::max(width, 3);
    }
  for (const auto& copies : instancers_)
    if (copies)
      if (const Primvar* primvar = penumbra::findPrimvar(copies->primvars, name))
        width = std::max(width, primvar->width);
  return width;
}

RTCRayHit Scene::trace(const Ray& ray, RayKind kind) const {
  TraceContext context(*this, kind);
  RTCRayHit rayHit;
  rayHit.ray = toEmbreeRay(ray);
  if (context.cameraRay) rayHit.ray.mask = kCameraRays;
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayHit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(top_, &context.embree, &rayHit);
  if (overlaid_) traceOverlay(context, rayHit);
  return rayHit;
}

bool Scene::mayHitOverlay(const RTCRay& ray) const {
  return segmentMeetsBox(ray, overlayBounds_.lower, overlayBounds_.upper);
}

void Scene::traceOverlay(TraceContext& context, RTCRayHit& rayHit) const {
  if (!mayHitOverlay(rayHit.ray)) return;
  context.embree.filter = nullptr;
  context.overlayIds = &overlayIds_;
  // tfar is the nearest hit so far: Embree writes a hit only for a nearer one.
  const RTCHit nearest = rayHit.hit;
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(overlay_, &context.embree, &rayHit);
  if (rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID)
    rayHit.hit = nearest;
  else
    rayHit.hit.instID[0] = overlayIds_[rayHit.hit.instID[0]];
}

void Scene::skipOverlaid(const RTCFilterFunctionNArguments* args) {
  const auto* context = reinterpret_cast<const TraceContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i)
    if (args->valid[i] == -1 &&
        context->scene->staleInTop_[RTCHitN_instID(args->hit, args->N, i, 0)])
      args->valid[i] = 0;
}

float Scene::hitDistance(const Ray& ray, RayKind kind) const {
  const RTCRayHit rayHit = trace(ray, kind);
  return rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID ? kInfinity : rayHit.ray.tfar;
}

std::optional<SurfaceHit> Scene::intersect(const Ray& ray, RayKind kind,
                                           const RayCone& cone) const {
  const RTCRayHit rayHit = trace(ray, kind);
  if (rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

  const Placement& placement = *placements_[rayHit.hit.instID[0]];
  const MeshRecord& mesh = *meshes_[placement.mesh];
  const TriangleMesh& data = *mesh.data;
  const Transform objectToWorld = placement.objectToWorld.at(ray.time);
  SurfacePoint point;
  point.mesh = &data;
  point.triangle = rayHit.hit.primID;
  point.u = rayHit.hit.u;
  point.v = rayHit.hit.v;
  Vec3f objectCorners[3];
  for (int corner = 0; corner < 3; ++corner)
    objectCorners[corner] = data.cornerAt(point.triangle, corner, ray.time);

  SurfaceHit hit;
  hit.distance = rayHit.ray.tfar;
  hit.position = ray.origin + ray.direction * hit.distance;
  if (kind == RayKind::Camera && passOf(placement).matte) {
    hit.matte = true;
    return hit;
  }
  hit.normal = normalize(objectToWorld.applyToNormal(
      cross(objectCorners[1] - objectCorners[0], objectCorners[2] - objectCorners[0])));
  hit.shadingNormal = hit.normal;
  if (!data.normals.empty()) {
    const Vec3f interpolated = objectToWorld.applyToNormal(data.interpolate(
        data.normals, data.normalsInterpolation, point.triangle, point.u, point.v));
    // A shading normal on the other side than the surface would turn shading inside out.
    if (length(interpolated) > 0 && dot(interpolated, hit.normal) > 0)
      hit.shadingNormal = normalize(interpolated);
  }
  hit.closed = data.closed;
  attachInstancePrimvars(rayHit.hit.instID[0], &point);
  hit.meshId = placement.mesh;
  hit.instance = placement.instancer ? int(placement.copy) : -1;
  hit.mesh = &data;
  hit.triangle = point.triangle;
  hit.u = point.u;
  hit.v = point.v;
  hit.instancePrimvars = point.instancePrimvars;
  if (const Material* material = materialOf(mesh)) {
    const bool anisotropic = material->mayBeAnisotropic();
    if (material->varies() || anisotropic) {
      // Texture footprints and tangent frames need the triangle in world space.
      for (int corner = 0; corner < 3; ++corner)
        point.corners[corner] = objectToWorld.applyToPoint(objectCorners[corner]);
    }
    if (material->varies()) {
      point.normal = hit.normal;
      point.shadingNormal = hit.shadingNormal;
      footprintOnSurface(ray.direction, hit.normal, cone.radiusAt(hit.distance), &point.dpdx,
                         &point.dpdy);
      hit.material = evaluateMaterial(*material, *textures_, point, &hit.shadingNormal);
    } else {
      hit.material = material->constants;
    }
    if (anisotropic) hit.tangent = surfaceTangent(point, objectToWorld);
    // With a threshold, opacity decides presence (the filter cut out what is below it); what
    // remains is opaque, not translucent (UsdPreviewSurface spec).
    if (hit.material.opacityThreshold > 0) hit.material.opacity = 1;
    if (hit.material.thinWalled) hit.closed = !*hit.material.thinWalled;
  } else {
    hit.material = fallbackSurface();
    float value[4];
    int width = 0;
    // Built once: looked up on every hit of a mesh without a material.
    static const PrimvarName displayOpacity("displayOpacity");
    if (primvarAt(point, displayColorName(), value, &width) && width >= 3)
      hit.material.diffuseColor = {value[0], value[1], value[2]};
    if (primvarAt(point, displayOpacity, value, &width)) hit.material.opacity = value[0];
  }
  hit.emission = hit.material.emissiveColor;
  if (mesh.lightIndex >= 0 && size_t(mesh.lightIndex) < lights_.size()) {
    hit.lightIndex = mesh.lightIndex;
    if (dot(ray.direction, hit.normal) < 0)
      hit.emission = lights_[size_t(mesh.lightIndex)].radiance();
  }
  return hit;
}

namespace {

/// What an intersect call on the light BVH carries: the ray's limit and where hits go.
struct LightTraceContext {
  RTCIntersectContext embree;  // first member: Embree passes a pointer to it to the callbacks
  float tMax;
  Scene::LightHitCallback callback;
  const void* visitor;
};

}  // namespace

void Scene::boundLight(const RTCBoundsFunctionArguments* args) {
  const auto* scene = static_cast<const Scene*>(args->geometryUserPtr);
  const LightBounds bounds = scene->lights_[scene->areaLights_[args->primID]].bounds();
  *args->bounds_o = {bounds.lower.x, bounds.lower.y, bounds.lower.z, 0,
                     bounds.upper.x, bounds.upper.y, bounds.upper.z, 0};
}

void Scene::intersectLight(const RTCIntersectFunctionNArguments* args) {
  // Every light met is reported and no hit is accepted, so that traversal goes on to the lights
  // behind it: overlapping emitters all contribute.
  if (args->valid[0] != -1) return;
  const auto* scene = static_cast<const Scene*>(args->geometryUserPtr);
  const auto* context = reinterpret_cast<const LightTraceContext*>(args->context);
  const uint32_t index = scene->areaLights_[args->primID];
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
  const Vec3f origin{RTCRayN_org_x(ray, args->N, 0), RTCRayN_org_y(ray, args->N, 0),
                     RTCRayN_org_z(ray, args->N, 0)};
  const Vec3f direction{RTCRayN_dir_x(ray, args->N, 0), RTCRayN_dir_y(ray, args->N, 0),
                        RTCRayN_dir_z(ray, args->N, 0)};
  if (const std::optional<LightHit> hit =
          scene->lights_[index].intersect(origin, direction, context->tMax))
    context->callback(context->visitor, index, *hit);
}

void Scene::buildLightScene() {
  if (lightScene_) rtcReleaseScene(lightScene_);
  lightScene_ = nullptr;
  areaLights_.clear();
  for (size_t i = 0; i < lights_.size(); ++i) {
    const Light& light = lights_[i];
    if (!light.isInfinite() && !light.isDelta() && light.type() != LightType::Mesh)
      areaLights_.push_back(uint32_t(i));
  }
  if (areaLights_.empty()) return;
  lightScene_ = rtcNewScene(device_);
  RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(geometry, unsigned(areaLights_.size()));
  rtcSetGeometryUserData(geometry, this);
  rtcSetGeometryBoundsFunction(geometry, boundLight, nullptr);
  rtcSetGeometryIntersectFunction(geometry, intersectLight);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(lightScene_, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(lightScene_);
  throwOnEmbreeError(device_, "build the light BVH");
}

void Scene::visitLightHits(const Ray& ray, float tMax, LightHitCallback callback,
                           const void* visitor) const {
  if (!lightScene_) return;
  LightTraceContext context;
  rtcInitIntersectContext(&context.embree);
  context.tMax = tMax;
  context.callback = callback;
  context.visitor = visitor;
  RTCRayHit rayHit;
  rayHit.ray = toEmbreeRay(ray);
  rayHit.ray.tnear = 0;
  rayHit.ray.tfar = tMax;
  rayHit.ray.time = 0;  // lights keep their transform at the frame
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(lightScene_, &context.embree, &rayHit);
}

bool Scene::occluded(const Ray& ray) const {
  TraceContext context(*this, RayKind::Secondary);
  RTCRay r = toEmbreeRay(ray);
  rtcOccluded1(top_, &context.embree, &r);
  if (r.tfar >= 0 && overlaid_ && mayHitOverlay(r)) {
    context.embree.filter = nullptr;
    context.overlayIds = &overlayIds_;
    rtcOccluded1(overlay_, &context.embree, &r);
  }
  return r.tfar < 0;  // Embree sets tfar to -inf when occluded
}

}  // namespace penumbra
