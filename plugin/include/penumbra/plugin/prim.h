// Base of every prim in the render index, with Hydra's change tracking: the scene delegate's
// setters store data and raise dirty bits; the render delegate syncs a prim only when any are
// set, then clears them.
#pragma once

#include <cstdint>
#include <string>
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

class Prim {
 public:
  explicit Prim(PrimId id) : id_(std::move(id)) {}
  virtual ~Prim() = default;
  Prim(const Prim&) = delete;
  Prim& operator=(const Prim&) = delete;

  const PrimId& id() const { return id_; }
  uint32_t dirtyBits() const { return dirtyBits_; }
  void markDirty(uint32_t bits) { dirtyBits_ |= bits; }
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
};

}  // namespace penumbra::plugin
