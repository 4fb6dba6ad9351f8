// What rays meet: objects (a Shape each, shape.h) as Embree instances (one BVH per object,
// placed by one instance of its own, so that a transform edit does not rebuild geometry, and by
// any number of instancer copies sharing that BVH), traced through a top-level BVH and its
// overlay. Queries return raw hits (which object, placement and primitive, where on it); what the
// surface is made of is shading's business (surface_hit.h). Plain data only; no USD.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/curves.h"
#include "penumbra/embree.h"
#include "penumbra/linking.h"
#include "penumbra/material_table.h"
#include "penumbra/mesh.h"
#include "penumbra/motion.h"
#include "penumbra/points.h"
#include "penumbra/shape.h"

namespace penumbra {

/// How a render pass shows a mesh or an instancer's copies (the UsdRenderPass cameraVisibility
/// and matte collections, combined with the object's primvars:penumbra:holdout and
/// primvars:penumbra:visibility:camera). Either way the geometry still casts shadows and shows
/// in reflections. The other members are the object's ray visibility
/// (primvars:penumbra:visibility:*, docs/ray-visibility.md): which rays leaving a surface see it.
struct PassVisibility {
  bool camera = true;  // false: camera rays pass through it
  bool matte = false;  // camera rays that meet it end there, adding no colour and no alpha
  // false: shadow rays pass through it (it casts no shadow); rays leaving a diffuse lobe (or a
  // medium), a reflecting lobe, a refracting lobe pass through it.
  bool shadow = true;
  bool diffuse = true;
  bool glossy = true;
  bool transmission = true;
};

/// Which rays a trace is for, so that objects hidden from them (PassVisibility) are passed
/// through. Camera rays do not see the back faces of single-sided meshes (doubleSided = 0), as
/// in Storm; other rays see both sides, so that a single-sided wall still blocks light.
/// Secondary rays see every shown object whatever its ray visibility: the walks inside an object
/// (subsurface, a hair fibre's far wall) and measurements. Diffuse, Glossy and Transmission: rays
/// the path continues with after scattering by that kind of lobe (a medium's phase function and
/// a subsurface exit count as diffuse). Shadow rays are occluded()'s.
enum class RayKind { Camera, Secondary, Diffuse, Glossy, Transmission };

/// The Embree ray mask bits of the ray kinds, and which of them a placement shown as `pass`
/// answers to (Geometry sets these; public so that they can be tested).
namespace ray_mask {
inline constexpr unsigned kCamera = 1u;
inline constexpr unsigned kAny = 2u;  // every shown placement has it: Secondary rays
inline constexpr unsigned kShadow = 4u;
inline constexpr unsigned kDiffuse = 8u;
inline constexpr unsigned kGlossy = 16u;
inline constexpr unsigned kTransmission = 32u;
/// The mask rays of `kind` are traced with.
constexpr unsigned ofRay(RayKind kind) {
  switch (kind) {
    case RayKind::Camera:
      return kCamera;
    case RayKind::Secondary:
      return ~0u;
    case RayKind::Diffuse:
      return kDiffuse;
    case RayKind::Glossy:
      return kGlossy;
    case RayKind::Transmission:
      return kTransmission;
  }
  return ~0u;
}
/// The mask of a placement shown as `pass`.
constexpr unsigned ofPlacement(const PassVisibility& pass) {
  return kAny | (pass.camera ? kCamera : 0u) | (pass.shadow ? kShadow : 0u) |
         (pass.diffuse ? kDiffuse : 0u) | (pass.glossy ? kGlossy : 0u) |
         (pass.transmission ? kTransmission : 0u);
}
}  // namespace ray_mask

/// A ray's first intersection, as the geometry knows it.
struct GeometryHit {
  float distance = 0;
  uint32_t meshId = 0;     // the object hit (Geometry::MeshId)
  int instance = -1;       // the instancer copy hit, -1: the object's own placement
  uint32_t primitive = 0;  // Embree's primID in the object's geometry
  float u = 0, v = 0;      // Embree's barycentrics on it
  Vec3f geometricNormal;   // Embree's Ng there: object space, unnormalised
  const Shape* shape = nullptr;
  const MotionTransform* objectToWorld = nullptr;  // the placement's
  int materialIndex = MaterialTable::kNoMaterial;  // the face's (per-face bindings) or object's
  uint32_t faceSlot = 0;  // the per-face binding (slot) the face takes; 0: the object's own
  PassVisibility pass;    // the placement owner's
  /// For copies of an instancer with per-copy primvars: those primvars (see SurfacePoint).
  const std::vector<Primvar>* instancePrimvars = nullptr;
  uint32_t linkingClass = LinkingTable::kLinkedToAll;  // the placement's (linking.h)
};

/// Gives `point`, on instancer copy `copy`, that copy's per-copy primvars `primvars` (null: the
/// point has only its mesh's).
inline void attachCopyPrimvars(SurfacePoint& point, const std::vector<Primvar>* primvars,
                               uint32_t copy) {
  if (!primvars) return;
  point.instancePrimvars = primvars;
  point.instance = copy;
}

class Geometry {
 public:
  using MeshId = uint32_t;
  using InstancerId = uint32_t;

  /// `materials`: where the hit filters find cut-outs, and where primvar names are registered.
  Geometry(const Device& device, MaterialTable& materials);
  ~Geometry();
  Geometry(const Geometry&) = delete;
  Geometry& operator=(const Geometry&) = delete;

  MeshId addMesh();
  void removeMesh(MeshId id);
  /// Replaces the mesh's geometry and rebuilds its BVH, unless its points and triangles are
  /// those it has already (a primvar or sidedness edit): then only the shading data changes.
  void setMeshGeometry(MeshId id, TriangleMesh mesh);
  /// Makes object `id` (from addMesh(); ids name any kind of object) the points `points`
  /// (validated: std::invalid_argument as validatePoints) and builds its BVH.
  void setPointsGeometry(MeshId id, PointsData points);
  /// Makes object `id` the curves `curves` (validated: std::invalid_argument as validateCurves)
  /// and builds their BVH.
  void setCurvesGeometry(MeshId id, CurvesData curves);
  /// Drops the mesh's geometry (it stays registered but renders nothing).
  void clearMeshGeometry(MeshId id);
  /// What object `id` is traced as (setMeshGeometry's and the like's); null before any.
  const Shape* shape(MeshId id) const { return record(id).shape.get(); }
  /// Places the mesh; an animated transform gives Embree multi-segment instance motion.
  void setMeshInstance(MeshId id, const MotionTransform& objectToWorld, int materialIndex,
                       bool visible);
  /// How camera rays treat the mesh itself (not its instancers' copies).
  void setMeshPassVisibility(MeshId id, PassVisibility pass);
  /// Per-face materials (UsdGeomSubset material bindings): slot k ≥ 1 binds the material
  /// `slotMaterials[k - 1]` (a material index, or MaterialTable::kNoMaterial: displayColor),
  /// and the mesh's face f (its authored face, Shape::elementOf) takes slot `faceSlots[f]`; slot
  /// 0, faces past the end, and every face when faceSlots is empty take the mesh's own
  /// material (setMeshInstance's). Hits say their face's slot (GeometryHit::faceSlot), by which
  /// Cryptomatte names them. Its instancers' copies render so too. Throws
  /// std::invalid_argument for a slot past slotMaterials.
  void setMeshFaceMaterials(MeshId id, std::vector<uint32_t> faceSlots,
                            std::vector<int> slotMaterials);

  /// Farthest a shown placement may reach from the origin, in every coordinate: Embree wants
  /// ray origins within about 1.8e19 (it asserts so), and hits on geometry farther out would
  /// start rays beyond that. A placement reaching farther (or not finite) is not rendered.
  static constexpr float kMaxCoordinate = 1e18f;
  /// Whether the mesh's own placement would show but is not rendered: its world bounds reach
  /// beyond kMaxCoordinate or are not finite.
  bool beyondReach(MeshId id) const;

  /// Copies of a mesh (its geometry and material), one per transform, sharing its BVH: memory
  /// grows with the number of copies, not with their triangles. The mesh itself need not be
  /// visible (a prototype). Replaces the instancer's previous copies.
  InstancerId addInstancer();
  void setInstances(InstancerId id, MeshId prototype, std::vector<MotionTransform> transforms,
                    bool visible);
  void removeInstancer(InstancerId id);
  /// How many of the instancer's copies would show but are not rendered (as beyondReach).
  size_t copiesBeyondReach(InstancerId id) const;
  /// Per-copy primvars of an instancer (one value per copy, in the order of setInstances'
  /// transforms), overriding the prototype's primvars of the same name; displayColor among them
  /// colours copies without a material. Throws std::invalid_argument for a count that does not
  /// match the copies.
  void setInstancePrimvars(InstancerId id, std::vector<Primvar> primvars);
  /// How camera rays treat the instancer's copies.
  void setInstancerPassVisibility(InstancerId id, PassVisibility pass);

  /// Light and shadow linking (linking.h): the classes the placements name.
  void setLinkingClasses(const std::vector<LinkingClass>& classes) { linking_.setClasses(classes); }
  const LinkingTable& linking() const { return linking_; }
  /// The linking class of the mesh's own placement (default LinkingTable::kLinkedToAll).
  void setMeshLinkingClass(MeshId id, uint32_t linkingClass);
  /// The linking class of each of the instancer's copies, in the order of setInstances'
  /// transforms (empty: every copy linked to all lights). Throws std::invalid_argument for a
  /// count that does not match the copies.
  void setInstanceLinkingClasses(InstancerId id, std::vector<uint32_t> classes);

  /// Where a material's opacity is below its non-zero opacityThreshold the surface is cut out:
  /// whole meshes for constant opacity, per hit for textured opacity. After material `index`
  /// was replaced (MaterialTable::replace), the meshes using it follow `change` (their
  /// placements and hit filters); unless it changed anything, they are not even looked for.
  void followMaterial(size_t index, MaterialTable::CutoutChange change);

  /// How many mesh BVHs setMeshGeometry has built.
  uint64_t meshBvhBuilds() const { return meshBvhBuilds_; }
  /// Seconds spent building the meshes' BVHs so far.
  double meshBvhBuildSeconds() const { return meshBvhBuildSeconds_; }
  /// Instances in the top-level BVHs (the main one and the overlay) that commit() has built so
  /// far: what edits that place, show or hide meshes have cost to build.
  uint64_t topLevelBvhPrimitives() const { return topLevelBvhPrimitives_; }
  /// How many meshes are placed by the overlay (see commit()).
  size_t overlaidPlacements() const { return overlaid_; }

  /// Rebuilds the top-level BVH; call after edits and before tracing.
  ///
  /// Moving, showing or hiding one mesh would rebuild a top-level BVH over every placement.
  /// Once the geometry has been built with kOverlayThreshold placements or more, such an edit
  /// of a mesh's own placement (its BVH unchanged) goes to an overlay instead: a second, small
  /// top-level BVH of the meshes edited since, which rays trace after the main top-level BVH,
  /// whose stale instances of them they skip (an intersect-context filter). Up to kMaxOverlaid
  /// meshes wait there; the overlay is folded into the main top-level BVH when that is rebuilt
  /// anyway, or when a render takes enough samples to pay for the rebuild (prepareForSamples).
  /// Hits are those of geometry built afresh, but for surfaces at exactly the same distance.
  void commit();
  /// Tells the geometry how many camera samples (pixels × samples per pixel) the next render
  /// takes: enough of them fold the overlay into the main top-level BVH, which rays trace
  /// faster than the two. Returns whether it did (commit() is then due).
  bool prepareForSamples(uint64_t cameraSamples);
  /// Instances in the top-level BVH from which an edit goes to the overlay (a rebuild of about
  /// 0.4 ms), and how many meshes the overlay holds at most.
  static constexpr size_t kOverlayThreshold = 1024;
  static constexpr size_t kMaxOverlaid = 64;
  /// Camera samples per instance of the top-level BVH from which prepareForSamples folds.
  static constexpr uint64_t kFoldingSamplesPerInstance = 16;
  /// The largest side of the box around everything shown (1 when there is nothing), as of the
  /// last commit().
  float extent() const { return extent_; }

  /// The first hit, or none.
  std::optional<GeometryHit> intersect(const Ray& ray, RayKind kind) const;
  /// The distance to the first hit, infinity for none.
  float hitDistance(const Ray& ray, RayKind kind) const;
  /// True if anything that casts shadows (PassVisibility::shadow) blocks the segment
  /// [tNear, tFar] of the ray; a shadow ray of a light with link slot `linkSlot`
  /// (Light::linkSlot) passes the placements its shadow link excludes.
  bool occluded(const Ray& ray, int linkSlot = -1) const;
  /// The widest value of primvar `name` on any mesh or instancer (0: none has it).
  int primvarWidth(const PrimvarName& name) const;
  /// Calls `visit` with the material index and the world box (lower, upper), over the shutter,
  /// of each shown mesh's own placement and of each instancer's copies of it, in the meshes'
  /// order.
  void forEachObjectBounds(const std::function<void(int materialIndex, const Vec3f& lower,
                                                    const Vec3f& upper)>& visit) const;
  /// Whether a shown object is hidden from some rays leaving surfaces or from shadow rays (its
  /// PassVisibility's ray visibility).
  bool hidesFromRays() const;

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
    uint32_t linkingClass = LinkingTable::kLinkedToAll;
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
    RTCGeometry geometry = nullptr;  // in `bvh`
    bool doubleSided = false;        // the shape's, for the hit filter
    bool cutoutFilter = false;       // `geometry` filters hits by textured opacity
    std::shared_ptr<const Shape> shape;
    int materialIndex = MaterialTable::kNoMaterial;
    std::vector<uint32_t> faceSlots;  // setMeshFaceMaterials
    std::vector<int> slotMaterials;
    bool visible = true;
    PassVisibility pass;
    std::unique_ptr<Placement> own;
    std::vector<InstancerId> instancers;  // those placing copies of this mesh
    Box objectBounds;                     // of its BVH
    // Its own placement: whether it shows, the BVH its instance in top_
    // places as committed, and its instance in the overlay, if any (rays then see that one).
    bool ownEnabled = false;
    bool ownBeyondReach = false;  // it would show, but reaches beyond kMaxCoordinate
    RTCScene placedBvh = nullptr;
    RTCGeometry overlay = nullptr;
    unsigned overlayGeomId = 0;
  };
  struct InstancerRecord {
    MeshId prototype = 0;
    bool visible = true;
    PassVisibility pass;
    std::vector<std::unique_ptr<Placement>> copies;
    std::vector<Primvar> primvars;         // one value per copy
    std::vector<uint32_t> linkingClasses;  // one per copy, or none: all kLinkedToAll
    Box bounds;                            // in the world, of the copies shown
    size_t beyondReach = 0;                // copies that would show but reach beyond kMaxCoordinate
  };

  /// Replaces the mesh's shape (see setMeshGeometry).
  void setShape(MeshId id, std::shared_ptr<const Shape> shape);
  /// rtcIntersect1 through the top-level BVH, with the hit filters' context.
  RTCRayHit trace(const Ray& ray, RayKind kind) const;
  MeshRecord& record(MeshId id);
  const MeshRecord& record(MeshId id) const;
  InstancerRecord& instancer(InstancerId id);
  const InstancerRecord& instancer(InstancerId id) const;
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
  /// Whether the placement's world bounds are finite and within kMaxCoordinate.
  bool withinReach(const Placement& placement) const;
  /// Whether every step of the placement's transform has an inverse in single precision. One
  /// that has none (a scale of 0 on some axis: the object is flat, or a point, and shows
  /// nothing), or whose inverse scales by more than kMaxInverseScale (a scale below about
  /// 1e-12 on some axis, as flat to single precision), is not placed, silently: Embree would
  /// trace rays with coordinates beyond its range through it (and abort on them: Debian's
  /// build checks).
  static bool invertible(const Placement& placement);
  /// The largest entry of a placement's inverse linear part that invertible() accepts.
  static constexpr double kMaxInverseScale = 1e12;
  /// Installs the hit filters the mesh's sidedness and cut-outs call for and commits its BVH
  /// again; Embree then wants the instances placing it committed again (updateAllPlacements),
  /// and the top-level BVH rebuilt.
  void applyHitFilters(MeshRecord& mesh);
  /// The box of a committed Embree scene.
  static Box boundsOf(RTCScene committed);
  /// What the hit filters learn of a ray (geometry_trace.cpp).
  struct TraceContext;
  /// The overlay's pass of trace(), after top_'s; `context` as top_'s.
  void traceOverlay(TraceContext& context, RTCRayHit& rayHit) const;
  /// Whether the ray's segment may meet an instance in the overlay (its bounds).
  bool mayHitOverlay(const RTCRay& ray) const;
  /// Intersect-context filter of a trace that must pass some hits: in top_ while the overlay
  /// holds placements, their stale instances there; for the shadow rays of a shadow-linked
  /// light (TraceContext::shadowLinkSlot), the placements its shadow link excludes.
  static void skipPlacements(const RTCFilterFunctionNArguments* args);
  /// The pass visibility of a placement's owner: its instancer's, or its mesh's.
  const PassVisibility& passOf(const Placement& placement) const;
  /// Whether copies of a mesh render: it has geometry and not all of its materials cut it out.
  bool renderable(const MeshRecord& mesh) const;
  /// Sets the mesh's hit filters: back-face culling for single-sided meshes, cut-outs where
  /// opacity is textured and thresholded, or where some faces' material cuts them out whole.
  /// Returns whether they changed (the mesh's placements are then to be updated).
  bool updateHitFilters(MeshRecord& mesh);
  /// Whether `cuts` holds for some material of the mesh (its own, and its faces').
  template <typename Predicate>
  bool anyMaterialOf(const MeshRecord& mesh, Predicate cuts) const;
  /// The per-face binding slot of the mesh's `primitive` (0: the mesh's own material).
  static uint32_t faceSlotOf(const MeshRecord& mesh, uint32_t primitive);
  /// The material of the mesh's faces of slot `faceSlot`.
  static int materialOf(const MeshRecord& mesh, uint32_t faceSlot);
  /// The per-copy primvars of `placement`, if it is a copy of an instancer that has some.
  static const std::vector<Primvar>* copyPrimvars(const Placement& placement);
  /// Embree hit filter (any hit, intersection and occlusion rays).
  static void filterHits(const RTCFilterFunctionNArguments* args);
  void updateAllPlacements(MeshId id);
  /// Updates an instancer's copies (and their bounds).
  void updateCopies(InstancerRecord& copies, bool shown);

  RTCDevice device_;
  MaterialTable& materials_;
  LinkingTable linking_;
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
  float extent_ = 1;
  uint64_t meshBvhBuilds_ = 0;
  double meshBvhBuildSeconds_ = 0;
};

}  // namespace penumbra
