// Base of every prim in the render index, with Hydra's change tracking: the scene delegate's
// setters store data and raise dirty bits; the first bit raised puts the prim on its change
// tracker's dirty list, so that the render delegate's sync visits only dirty prims (see
// docs/architecture.md).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <variant>

#include "penumbra/math.h"

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

/// The ids of the prims with dirty bits raised since the last sync (cf. HdChangeTracker's
/// dirty list), in id order so that sync is deterministic.
class ChangeTracker {
 public:
  void markDirty(const PrimId& id) { dirty_.insert(id); }
  void forget(const PrimId& id) { dirty_.erase(id); }
  bool empty() const { return dirty_.empty(); }
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
  void markClean() {
    dirtyBits_ = Clean;
    ++syncCount_;
  }
  /// How many times the prim has been synced (lets tests check incremental sync).
  int syncCount() const { return syncCount_; }

 private:
  PrimId id_;
  uint32_t dirtyBits_ = AllDirty;
  int syncCount_ = 0;
  ChangeTracker* tracker_ = nullptr;
};

}  // namespace penumbra::plugin
