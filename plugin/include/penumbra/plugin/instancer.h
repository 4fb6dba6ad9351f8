// Instancer rprim (cf. HdInstancer): copies of one prototype (a mesh, points or curves), each
// with its own transform, sharing the prototype's geometry. USD's point instancers and native
// instancing flatten to one of these per prototype (Embree instances one level deep). Its sync
// places the copies; its finalize removes them; a prototype mesh knows its instancers, so that
// its own removal drops their copies (the render delegate finds those of points and curves).
#pragma once

#include <cstddef>
#include <vector>

#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

class Instancer : public Prim {
 public:
  Instancer(PrimId id, Geometry::InstancerId handle) : Prim(std::move(id)), handle_(handle) {}

  /// `transforms`: one (possibly animated) prototype-to-world transform per copy.
  void setInstances(PrimId prototype, std::vector<MotionTransform> transforms) {
    prototype_ = std::move(prototype);
    transforms_ = std::move(transforms);
    markDirty(DirtyTransform);
  }
  void setVisible(bool visible) override {
    visible_ = visible;
    markDirty(DirtyVisibility);
  }
  /// How camera rays treat the copies (a render pass's cameraVisibility and matte collections).
  void setPassVisibility(PassVisibility pass) override {
    pass_ = pass;
    markDirty(DirtyVisibility);
  }
  /// Per-copy primvars (one value per copy, in the order of the transforms), overriding the
  /// prototype's.
  void setPrimvars(std::vector<Primvar> primvars) {
    primvars_ = std::move(primvars);
    markDirty(DirtyPrimvar);
  }

  /// Each copy's light and shadow linking class (LinkingTable), in the order of the transforms;
  /// empty: all linked to every light.
  void setLinkingClasses(std::vector<uint32_t> classes) {
    linkingClasses_ = std::move(classes);
    markDirty(DirtyPrimvar);
  }

  /// Places its copies of its prototype in the scene, and registers with a prototype mesh; when
  /// the prototype is not a mesh, points or curves in the render index there are none (with a
  /// warning). The render delegate syncs instancers after every kind of geometry: the copies
  /// follow their prototype's geometry.
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Removes its copies from the scene, and itself from its prototype's instancers (and from
  /// SyncContext::instancersByPrototype).
  void finalize(SyncContext& context) override;
  /// Its prototype left the render index: the copies go, and are placed again at the next sync
  /// (when a prototype with its id is back).
  void dropCopies(SyncContext& context);
  /// Bytes its next sync will allocate (penumbra::estimatedInstanceBytes).
  size_t estimatedSyncBytes() const;

  const PrimId& prototype() const { return prototype_; }
  const std::vector<MotionTransform>& transforms() const { return transforms_; }
  bool visible() const { return visible_; }
  PassVisibility passVisibility() const { return pass_; }
  const std::vector<Primvar>& primvars() const { return primvars_; }

 private:
  Geometry::InstancerId handle_;
  PrimId prototype_;
  PrimId listedUnder_;  // its entry of SyncContext::instancersByPrototype (empty: none)
  std::vector<MotionTransform> transforms_;
  bool visible_ = true;
  PassVisibility pass_;
  std::vector<Primvar> primvars_;
  std::vector<uint32_t> linkingClasses_;
};

}  // namespace penumbra::plugin
