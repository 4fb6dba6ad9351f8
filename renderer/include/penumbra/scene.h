// The scene the tracer sees: triangle meshes as Embree instances (one BVH per mesh, placed by
// one instance of its own, so that a transform edit does not rebuild geometry, and by any number
// of instancer copies sharing that BVH), materials and lights. Plain data only; no USD.
#pragma once

#include <embree3/rtcore.h>

#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/light.h"
#include "penumbra/light_sampler.h"
#include "penumbra/material.h"
#include "penumbra/mesh.h"
#include "penumbra/motion.h"
#include "penumbra/shading.h"
#include "penumbra/texture.h"

namespace penumbra {

/// Owns the Embree device: the one piece of process-wide state the renderer has.
class Device {
 public:
  Device();
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;
  RTCDevice get() const { return device_; }

 private:
  RTCDevice device_;
};

/// A ray's first intersection with a mesh.
struct SurfaceHit {
  float distance = 0;
  Vec3f position;
  Vec3f normal;         // unit geometric normal on the authored front side
  Vec3f shadingNormal;  // unit, interpolated where the mesh has normals, on the same side
  Vec3f emission;       // emitted radiance
  /// Where the material may be anisotropic: the surface's tangent (surfaceTangent); else zero.
  Vec3f tangent{0.0f};
  /// The bound material's parameters evaluated here (textures, primvar readers, normal map), or
  /// fallbackSurface() with displayColor and displayOpacity for meshes without one.
  MaterialParams material;
  int lightIndex = -1;  // the mesh light this surface is (UsdLuxMeshLightAPI)
  bool closed = false;  // a solid: the mesh bounds one, or its material is not thin-walled
  bool matte = false;   // a holdout (PassVisibility::matte): only distance and position are set
  // Which surface this is, for AOVs and primvar lookups (as in SurfacePoint).
  uint32_t meshId = 0;
  int instance = -1;  // the instancer copy hit, -1: the mesh's own placement
  const TriangleMesh* mesh = nullptr;
  uint32_t triangle = 0;
  float u = 0, v = 0;
  const std::vector<Primvar>* instancePrimvars = nullptr;
};

/// How a render pass shows a mesh or an instancer's copies (the UsdRenderPass cameraVisibility
/// and matte collections). Either way the geometry still casts shadows and shows in reflections.
struct PassVisibility {
  bool camera = true;  // false: camera rays pass through it
  bool matte = false;  // camera rays that meet it end there, adding no colour and no alpha
};

/// Camera rays do not see the back faces of single-sided meshes (doubleSided = 0), as in
/// Storm; other rays see both sides, so that a single-sided wall still blocks light.
enum class RayKind { Camera, Secondary };

class Scene {
 public:
  using MeshId = uint32_t;
  using InstancerId = uint32_t;
  /// Material index meaning "none bound": displayColor is the albedo.
  static constexpr int kNoMaterial = -1;

  /// `colorConfig`: the OCIO config that linearises textures (empty: $OCIO).
  explicit Scene(const Device& device, const std::string& colorConfig = {});
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  MeshId addMesh();
  void removeMesh(MeshId id);
  /// Replaces the mesh's geometry and rebuilds its BVH, unless its points and triangles are
  /// those it has already (a primvar or sidedness edit): then only the shading data changes.
  void setMeshGeometry(MeshId id, TriangleMesh mesh);
  /// How many mesh BVHs setMeshGeometry has built.
  uint64_t meshBvhBuilds() const { return meshBvhBuilds_; }
  /// Seconds spent building acceleration structures so far: meshes' BVHs, the top-level BVH,
  /// the light tree and the lights' BVH.
  double bvhBuildSeconds() const { return bvhBuildSeconds_; }
  /// Instances in the top-level BVHs (the scene's and its overlay's) that commit() has built so
  /// far: what edits that place, show or hide meshes have cost to build.
  uint64_t topLevelBvhPrimitives() const { return topLevelBvhPrimitives_; }
  /// How many meshes are placed by the overlay (see commit()).
  size_t overlaidPlacements() const { return overlaid_; }
  /// Drops the mesh's geometry (it stays registered but renders nothing).
  void clearMeshGeometry(MeshId id);
  /// Places the mesh; an animated transform gives Embree multi-segment instance motion.
  void setMeshInstance(MeshId id, const MotionTransform& objectToWorld, int materialIndex,
                       bool visible);

  /// Makes the mesh the emitting surface of light `lightIndex` (a LightType::Mesh light), or
  /// not (-1): its front side then shows the light's radiance.
  void setMeshLight(MeshId id, int lightIndex);
  /// How camera rays treat the mesh itself (not its instancers' copies).
  void setMeshPassVisibility(MeshId id, PassVisibility pass);

  /// Copies of a mesh (its geometry and material), one per transform, sharing its BVH: memory
  /// grows with the number of copies, not with their triangles. The mesh itself need not be
  /// visible (a prototype). Replaces the instancer's previous copies.
  InstancerId addInstancer();
  void setInstances(InstancerId id, MeshId prototype, std::vector<MotionTransform> transforms,
                    bool visible);
  void removeInstancer(InstancerId id);
  /// Per-copy primvars of an instancer (one value per copy, in the order of setInstances'
  /// transforms), overriding the prototype's primvars of the same name; displayColor among them
  /// colours copies without a material. Throws std::invalid_argument for a count that does not
  /// match the copies.
  void setInstancePrimvars(InstancerId id, std::vector<Primvar> primvars);
  /// How camera rays treat the instancer's copies.
  void setInstancerPassVisibility(InstancerId id, PassVisibility pass);

  /// Materials are referenced by index. Where a material's opacity is below its non-zero
  /// opacityThreshold the surface is cut out: whole meshes for constant opacity, per hit for
  /// textured opacity. Their texture handles refer to textures().
  /// Sets the material at `index` (at most materialCount(): that appends one), leaving the
  /// others as they are; the meshes using it follow (cut-outs, hit filters), looked for only if
  /// its cut-outs change. An index no mesh uses any longer is given a default Material, which
  /// disperses no light.
  /// Throws std::out_of_range for an index past the end, std::invalid_argument (leaving the
  /// list as it was) for a primvar name whose 64-bit key another name has.
  void setMaterial(size_t index, Material material);
  size_t materialCount() const { return materials_.size(); }
  /// The textures materials read; open files here before referencing them.
  TextureSystem& textures() { return *textures_; }
  const TextureSystem& textures() const { return *textures_; }
  /// The same, for what may outlive the scene (light textures read through it).
  const std::shared_ptr<TextureSystem>& sharedTextures() { return textures_; }
  /// The lights, in the order they are sampled in (their order decides which sample numbers
  /// each light draws: keep it stable). The light sampler is rebuilt at commit().
  void setLights(std::vector<Light> lights) {
    lights_ = std::move(lights);
    lightsChanged_ = true;
  }
  /// Replaces light `index` alone (a parameter edit), the others kept as they are. Throws
  /// std::out_of_range for an index past the end.
  void setLight(size_t index, Light light);
  /// Moves the lights out (to be put back, reordered, by setLights before the next render).
  std::vector<Light> releaseLights() {
    lightsChanged_ = true;
    return std::exchange(lights_, {});
  }
  const std::vector<Light>& lights() const { return lights_; }
  /// Chooses lights for next-event estimation (set by commit()).
  const LightSampler& lightSampler() const { return lightSampler_; }
  /// Indices of the dome and distant lights, which rays that escape the scene meet.
  const std::vector<uint32_t>& infiniteLights() const { return infiniteLights_; }
  /// How forEachLightHit reaches its visitor through Embree's callbacks.
  using LightHitCallback = void (*)(const void* visitor, uint32_t index, const LightHit& hit);
  /// Calls visit(lightIndex, LightHit) for each area light (rect, disk, sphere, cylinder) whose
  /// emitting surface the ray meets before `tMax`, found through an Embree BVH of the lights.
  /// Mesh lights are met as geometry instead (SurfaceHit::lightIndex).
  template <class Visit>
  void forEachLightHit(const Ray& ray, float tMax, Visit&& visit) const {
    visitLightHits(
        ray, tMax,
        [](const void* visitor, uint32_t index, const LightHit& hit) {
          (*static_cast<const std::remove_reference_t<Visit>*>(visitor))(index, hit);
        },
        &visit);
  }

  /// Rebuilds the top-level BVH, and the light sampler and the lights' BVH if lights changed;
  /// call after edits and before tracing.
  ///
  /// Moving, showing or hiding one mesh would rebuild a top-level BVH over every placement.
  /// Once the scene has been built with kOverlayThreshold placements or more, such an edit of
  /// a mesh's own placement (its BVH unchanged) goes to an overlay instead: a second, small
  /// top-level BVH of the meshes edited since, which rays trace after the scene's, whose stale
  /// instances of them they skip (an intersect-context filter). Up to kMaxOverlaid meshes wait
  /// there; the overlay is folded into the scene's BVH when that is rebuilt anyway, or when a
  /// render takes enough samples to pay for the rebuild (prepareForSamples). Hits are those of
  /// a scene built afresh, but for surfaces at exactly the same distance.
  void commit();
  /// Tells the scene how many camera samples (pixels × samples per pixel) the next render
  /// takes: enough of them fold the overlay into the scene's BVH, which rays trace faster than
  /// the two. Returns whether it did (commit() is then due).
  bool prepareForSamples(uint64_t cameraSamples);
  /// Instances in the top-level BVH from which an edit goes to the overlay (a rebuild of about
  /// 0.4 ms), and how many meshes the overlay holds at most.
  static constexpr size_t kOverlayThreshold = 1024;
  static constexpr size_t kMaxOverlaid = 64;
  /// Camera samples per instance of the top-level BVH from which prepareForSamples folds.
  static constexpr uint64_t kFoldingSamplesPerInstance = 16;
  /// True when a material disperses light (abbeNumber > 0 on a translucent material): paths
  /// are then traced spectrally (set by commit()).
  bool spectral() const { return spectral_; }

  /// The first hit, shaded: textures are filtered over `cone`'s cross-section there.
  std::optional<SurfaceHit> intersect(const Ray& ray, RayKind kind, const RayCone& cone = {}) const;
  /// The distance to the first hit, infinity for none: the intersection alone, unshaded.
  float hitDistance(const Ray& ray, RayKind kind) const;
  /// True if anything blocks the segment [tNear, tFar] of the ray.
  bool occluded(const Ray& ray) const;
  /// Offset for spawning rays from `point` so that they do not re-hit its surface.
  float rayEpsilon(const Vec3f& point) const;
  /// The widest value of primvar `name` on any mesh or instancer (0: none has it).
  int primvarWidth(const PrimvarName& name) const;

 private:
  struct InstancerRecord;
  /// One Embree instance geometry in top_: a placement of a mesh's BVH.
  struct Placement {
    RTCGeometry geometry = nullptr;
    unsigned geomId = 0;
    MeshId mesh = 0;
    MotionTransform objectToWorld;
    const InstancerRecord* instancer = nullptr;  // for copies: whose, and which copy
    uint32_t copy = 0;
  };
  /// An axis-aligned box; empty (lower > upper) by default.
  struct Box {
    Vec3f lower{kInfinity, kInfinity, kInfinity};
    Vec3f upper{-kInfinity, -kInfinity, -kInfinity};
    void extend(const Box& other) {
      lower = componentMin(lower, other.lower);
      upper = componentMax(upper, other.upper);
    }
  };
  /// Boxes by index and their union: a tree of unions over the boxes (a binary heap in one
  /// array), brought up to date when the union is asked for, O(log n) a box changed since.
  class BoxUnion {
   public:
    void set(size_t index, const Box& box);
    Box all();

   private:
    size_t leaves_ = 0;            // a power of two: box i is node leaves_ + i
    std::vector<Box> nodes_;       // node k unites nodes 2k and 2k + 1
    std::vector<size_t> changed_;  // nodes of the boxes set since all()
    bool uniteAll_ = false;        // instead: so many changed, or the tree grew
  };
  struct MeshRecord {
    RTCScene bvh = nullptr;
    RTCGeometry triangles = nullptr;  // in `bvh`
    bool cutoutFilter = false;        // triangles filter hits by textured opacity
    std::shared_ptr<const TriangleMesh> data;
    int materialIndex = kNoMaterial;
    int lightIndex = -1;
    bool visible = true;
    PassVisibility pass;
    std::unique_ptr<Placement> own;
    std::vector<InstancerId> instancers;  // those placing copies of this mesh
    Box objectBounds;                     // of its BVH
    // Its own placement: whether it shows, the BVH its instance in top_
    // places as committed, and its instance in the overlay, if any (rays then see that one).
    bool ownEnabled = false;
    RTCScene placedBvh = nullptr;
    RTCGeometry overlay = nullptr;
    unsigned overlayGeomId = 0;
  };
  struct InstancerRecord {
    MeshId prototype = 0;
    bool visible = true;
    PassVisibility pass;
    std::vector<std::unique_ptr<Placement>> copies;
    std::vector<Primvar> primvars;  // one value per copy
    Box bounds;                     // in the world, of the copies shown
  };

  /// rtcIntersect1 through the top-level BVH, with the hit filters' context.
  RTCRayHit trace(const Ray& ray, RayKind kind) const;
  MeshRecord& record(MeshId id);
  InstancerRecord& instancer(InstancerId id);
  std::unique_ptr<Placement> newPlacement(MeshId mesh);
  void releasePlacement(std::unique_ptr<Placement>& placement);
  /// Pushes a placement's BVH, transform, enabled state and ray mask to Embree: for a mesh's
  /// own placement, to its instance in the overlay when it may go there (see commit()), else
  /// to top_.
  void updatePlacement(Placement& placement, bool enabled);
  /// Sets `geometry` to place `placement` as it is now.
  void placeInstance(RTCGeometry geometry, const Placement& placement, bool enabled) const;
  /// Whether an update of the mesh's own placement may go to the overlay rather than rebuild
  /// top_.
  bool mayOverlay(const MeshRecord& mesh) const;
  /// Moves every overlaid placement back into top_ (rebuilt at the next commit()).
  void foldOverlay();
  /// Drops the mesh's instance from the overlay (its instance in top_ is then stale until
  /// updated).
  void removeFromOverlay(MeshRecord& mesh);
  /// Where `placement` shows its mesh (empty when not enabled).
  Box worldBounds(const Placement& placement, bool enabled) const;
  /// Installs the hit filters the mesh's sidedness and cut-outs call for and commits its BVH
  /// again; Embree then wants the instances placing it committed again (updateAllPlacements),
  /// and the top-level BVH rebuilt.
  void applyHitFilters(MeshRecord& mesh);
  /// The box of a committed Embree scene.
  static Box boundsOf(RTCScene committed);
  /// What the hit filters learn of a ray (scene.cpp).
  struct TraceContext;
  /// The overlay's pass of trace(), after top_'s; `context` as top_'s.
  void traceOverlay(TraceContext& context, RTCRayHit& rayHit) const;
  /// Whether the ray's segment may meet an instance in the overlay (its bounds).
  bool mayHitOverlay(const RTCRay& ray) const;
  /// Intersect-context filter of top_ while the overlay holds placements: skips their stale
  /// instances there.
  static void skipOverlaid(const RTCFilterFunctionNArguments* args);
  /// The pass visibility of a placement's owner: its instancer's, or its mesh's.
  const PassVisibility& passOf(const Placement& placement) const;
  /// Whether copies of a mesh render: it has geometry and its material does not cut it out.
  bool renderable(const MeshRecord& mesh) const;
  /// The mesh's material, or null.
  const Material* materialOf(const MeshRecord& mesh) const;
  /// Sets the triangles' hit filters: back-face culling for single-sided meshes, cut-outs where
  /// opacity is textured and thresholded. Returns whether they changed (the mesh's placements
  /// are then to be updated).
  bool updateHitFilters(MeshRecord& mesh);
  /// Points `point` at the per-copy primvars of the placement `geomId`, if it is such a copy.
  void attachInstancePrimvars(unsigned geomId, SurfacePoint* point) const;
  /// Embree hit filter (any hit, intersection and occlusion rays).
  static void filterHits(const RTCFilterFunctionNArguments* args);
  void updateAllPlacements(MeshId id);
  /// Updates an instancer's copies (and their bounds).
  void updateCopies(InstancerRecord& copies, bool shown);
  void visitLightHits(const Ray& ray, float tMax, LightHitCallback callback,
                      const void* visitor) const;
  /// Rebuilds the BVH of the area lights (lightScene_) from lights_.
  void buildLightScene();
  /// Remembers a primvar name entering the scene. Throws std::invalid_argument when another
  /// name has its key, so that lookups by key never mistake one primvar for another.
  void registerPrimvarName(const PrimvarName& name);
  /// The same check, for a name that is looked up without being stored (an AOV's).
  void checkPrimvarName(const PrimvarName& name) const;
  /// Embree callbacks of the light BVH's user geometry (user data: the scene).
  static void boundLight(const RTCBoundsFunctionArguments* args);
  static void intersectLight(const RTCIntersectFunctionNArguments* args);

  RTCDevice device_;
  RTCScene top_;
  std::vector<std::unique_ptr<MeshRecord>> meshes_;           // by MeshId
  std::vector<std::unique_ptr<InstancerRecord>> instancers_;  // by InstancerId
  BoxUnion ownBounds_;  // by MeshId: where its own placement shows the mesh in the world
  std::vector<const Placement*> placements_;  // by Embree geomID in top_
  std::vector<uint8_t> staleInTop_;           // by Embree geomID in top_: overlaid (1) or not (0)
  RTCScene overlay_ = nullptr;                // instances of the overlaid placements
  std::vector<uint32_t> overlayIds_;          // top_ geomID of each overlay_ geomID's placement
  size_t overlaid_ = 0;
  Box overlayBounds_;
  bool overlayChanged_ = false;  // since the last commit()
  bool topChanged_ = true;       // top_ changed since the last commit()
  bool built_ = false;           // commit() has run
  size_t topGeometries_ = 0;     // attached to top_
  uint64_t topLevelBvhPrimitives_ = 0;
  std::vector<Material> materials_;
  std::unordered_map<uint64_t, std::string> primvarNames_;  // by key, every name registered
  std::shared_ptr<TextureSystem> textures_;
  std::vector<Light> lights_;
  LightSampler lightSampler_;
  std::vector<uint32_t> infiniteLights_;
  RTCScene lightScene_ = nullptr;
  std::vector<uint32_t> areaLights_;  // light index of each primitive of lightScene_
  bool lightsChanged_ = true;         // since the last commit()
  float sceneExtent_ = 1;
  bool spectral_ = false;
  uint64_t meshBvhBuilds_ = 0;
  double bvhBuildSeconds_ = 0;
};

}  // namespace penumbra
