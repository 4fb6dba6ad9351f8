// Volume rprim (cf. HdVolume): a UsdVolVolume's fields (OpenVDB grids, one per slot: density,
// colour, temperature, emission) and its volume material, placed in the scene's volumes (not in
// the geometry) with its transform (motion too) and visibility.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/file_stamp.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/plugin/volume_field_cache.h"
#include "penumbra/volume.h"
#include "penumbra/volume_set.h"

namespace penumbra::plugin {

/// The grids a volume asks for, slot by slot (none: the slot has no field).
struct VolumeFieldRequests {
  std::optional<FieldRequest> density, color, temperature, emission;

  bool operator==(const VolumeFieldRequests& other) const {
    return density == other.density && color == other.color && temperature == other.temperature &&
           emission == other.emission;
  }
};

class Volume : public Prim {
 public:
  Volume(PrimId id, VolumeSet::VolumeId handle) : Prim(std::move(id)), handle_(handle) {}

  void setFields(VolumeFieldRequests fields);
  void setMaterial(const VolumeMaterial& material);
  void setTransform(const MotionTransform& objectToWorld) override;
  void setVisible(bool visible) override;
  /// Its light and shadow linking class (VolumeSet::setLinkingClass; 0: linked to every light).
  void setLinkingClass(uint32_t linkingClass);

  /// Syncs what its dirty bits say changed into the scene's volumes: its fields, read through
  /// the context's VolumeFieldCache, and material (an unreadable density field, or a volume the
  /// renderer refuses: one warning naming the prim, and it renders nothing until it changes;
  /// another unreadable field: one warning naming the prim, slot, file and grid, and the slot
  /// is dropped), then its placement.
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Removes it from the scene.
  void finalize(SyncContext& context) override;
  /// Bytes its next sync will allocate: for each grid not held by the cache, twice its size in
  /// memory as the file's metadata gives it (the OpenVDB grid read and its sparse copy;
  /// estimatedVdbFieldBytes), an estimate made before reading the voxels.
  size_t estimatedSyncBytes(const VolumeFieldCache& cache) const;
  /// Whether a file its fields were last read from has been written since (size or modification
  /// time), or has appeared or gone: the render delegate then syncs its fields again, as it
  /// reads repainted textures again.
  bool fieldFilesChanged() const;

  VolumeSet::VolumeId handle() const { return handle_; }
  const VolumeFieldRequests& fields() const { return fields_; }
  const VolumeMaterial& material() const { return material_; }
  const MotionTransform& transform() const { return objectToWorld_; }
  bool visible() const { return visible_; }

 private:
  /// The volume's data from its fields; none when it cannot render (warned).
  std::optional<VolumeData> readData(SyncContext& context);

  VolumeSet::VolumeId handle_;
  VolumeFieldRequests fields_;
  // Each file the last read of the fields looked at, and its stamp then (none: unreadable).
  StampedFiles readStamps_;
  VolumeMaterial material_;
  MotionTransform objectToWorld_;
  bool visible_ = true;
  uint32_t linkingClass_ = 0;
};

}  // namespace penumbra::plugin
