// The prims of one kind in the render index (cf. HdRenderIndex's per-type prim maps), owned by
// id, with the change tracker their setters report to: the render delegate keeps one collection
// per kind, so that it reaches each prim with its own type and syncs the kinds in a fixed order.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "penumbra/plugin/prim.h"

namespace penumbra::plugin {

template <typename T>
class PrimCollection {
 public:
  /// Takes `prim`, which reports its edits to this collection's dirty list from now on (it
  /// starts dirty, so that its first sync builds it).
  T& insert(std::unique_ptr<T> prim) {
    T& inserted = *prim;
    prims_[inserted.id()] = std::move(prim);
    inserted.track(&tracker_);
    return inserted;
  }
  /// Drops prim `id` (its finalize has run); false if it is not of this kind.
  bool erase(const PrimId& id) {
    tracker_.forget(id);
    return prims_.erase(id) != 0;
  }

  /// The prim `id`, or null when no prim of this kind has that id.
  T* find(const PrimId& id) const {
    const auto found = prims_.find(id);
    return found == prims_.end() ? nullptr : found->second.get();
  }
  /// Throws std::out_of_range naming the id and `kindName` when there is no such prim.
  T& at(const PrimId& id, const char* kindName) const {
    if (T* prim = find(id)) return *prim;
    throw std::out_of_range(id + ": no " + kindName + " with this id in the render index");
  }
  void appendIds(std::vector<PrimId>& ids) const {
    for (const auto& entry : prims_) ids.push_back(entry.first);
  }
  /// Calls `visit(prim)` for each prim, in id order.
  template <typename Visit>
  void forEach(Visit visit) const {
    for (const auto& entry : prims_) visit(*entry.second);
  }

  /// The ids of the prims edited since the last sync, in id order.
  const std::set<PrimId>& dirty() const { return tracker_.dirty(); }
  /// Syncs each prim on the dirty list, in id order, from its own dirty bits (Prim::syncDirty);
  /// the list is then empty.
  void syncDirty(SyncContext& context) {
    for (const PrimId& id : tracker_.take()) prims_.at(id)->syncDirty(context);
  }
  void clear() { prims_.clear(); }

 private:
  std::map<PrimId, std::unique_ptr<T>> prims_;
  ChangeTracker tracker_;
};

}  // namespace penumbra::plugin
