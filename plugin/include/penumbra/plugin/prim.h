// Base of every prim in the render index, with Hydra's change tracking and lifecycle: the scene
// delegate's setters store data and raise dirty bits; the first bit raised puts the prim on its
// change tracker's dirty list, so that the render delegate's sync visits only dirty prims. Each
// visited prim syncs itself into its part of the renderer (sync, as HdRprim::Sync and
// HdSprim::Sync) and is marked clean; a prim removed from the render index takes its part out
// (finalize, as HdRprim::Finalize) before it is dropped (see docs/architecture.md).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <variant>

#include "penumbra/math.h"
#include "penumbra/motion.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

/// Prim ids are USD path strings ("/World/floor").
using PrimId = std::string;

/// What has changed since the last sync (cf. HdChangeTracker's bits).
enum DirtyBits : uint32_t {
  Clean = 0,
  DirtyTopology = 1u << 0,
  DirtyPoints = 1u << 1,
  DirtyPrimvar = 1u << 2,
  DirtyDoubleSided = 1u << 3,
  DirtyMaterialId = 1u << 4,
  DirtyTransform = 1u << 5,
  DirtyVisibility = 1u << 6,
  DirtyParams = 1u << 7,
  AllDirty = ~0u,
};

/// A parameter value as schemas author them (cf. VtValue, restricted to what lights and
/// materials use; asset paths arrive resolved, as strings).
using ParamValue = std::variant<bool, int, float, Vec3f, std::string>;

struct SyncContext;

/// The ids of the prims with dirty bits raised since the last sync (cf. HdChangeTracker's
/// dirty list), in id order so that sync is deterministic.
class ChangeTracker {
 public:
  void markDirty(const PrimId& id) { dirty_.insert(id); }
  void forget(const PrimId& id) { dirty_.erase(id); }
  /// The dirty list, kept.
  const std::set<PrimId>& dirty() const { return dirty_; }
  /// The dirty list, emptied.
  std::set<PrimId> take() { return std::exchange(dirty_, {}); }

 private:
  std::set<PrimId> dirty_;
};

class Prim {
 public:
  explicit Prim(PrimId id) : id_(std::move(id)) {}
  virtual ~Prim() = default;
  Prim(const Prim&) = delete;
  Prim& operator=(const Prim&) = delete;

  const PrimId& id() const { return id_; }
  uint32_t dirtyBits() const { return dirtyBits_; }
  void markDirty(uint32_t bits) {
    if (tracker_ && bits != Clean) tracker_->markDirty(id_);
    dirtyBits_ |= bits;
  }
  /// Reports the prim's edits to `tracker` from now on (null: to nobody); a prim starts dirty.
  void track(ChangeTracker* tracker) {
    tracker_ = tracker;
    if (tracker_ && dirtyBits_ != Clean) tracker_->markDirty(id_);
  }
  /// How many times the prim has been synced (lets tests check incremental sync).
  int syncCount() const { return syncCount_; }

  /// Syncs what `dirtyBits` (the prim's own) say changed into its part of the renderer, through
  /// `context` (cf. HdRprim::Sync, HdSprim::Sync). Called by syncDirty only.
  virtual void sync(SyncContext& context, uint32_t dirtyBits) = 0;
  /// Takes the prim's part out of the renderer (cf. HdRprim::Finalize): the render delegate
  /// calls it when it removes the prim, which it then drops. Kinds that put nothing in the
  /// renderer (cameras, render buffers) have nothing to take out.
  virtual void finalize(SyncContext& context) { (void)context; }
  /// Syncs the prim from its dirty bits, then marks it clean: what the render delegate's sync
  /// does for each prim on its dirty list.
  void syncDirty(SyncContext& context) {
    sync(context, dirtyBits_);
    markClean();
  }

  /// Setters the scene delegate calls on a prim whatever its kind: the kinds that have a
  /// transform (meshes, points, volumes, cameras, lights), a visibility (meshes, points, volumes,
  /// instancers, lights), a render pass visibility (meshes, points, instancers) or a bound
  /// material (meshes, points) override them; on the others they throw std::invalid_argument
  /// naming the prim.
  virtual void setTransform(const MotionTransform& toWorld);
  virtual void setVisible(bool visible);
  /// How camera rays treat the prim (a render pass's cameraVisibility and matte collections).
  virtual void setPassVisibility(PassVisibility pass);
  /// The material sprim it is bound to (empty: none, displayColor shades it).
  virtual void setMaterialId(PrimId materialId);

 private:
  void markClean() {
    dirtyBits_ = Clean;
    ++syncCount_;
  }

  PrimId id_;
  uint32_t dirtyBits_ = AllDirty;
  int syncCount_ = 0;
  ChangeTracker* tracker_ = nullptr;
};

}  // namespace penumbra::plugin
