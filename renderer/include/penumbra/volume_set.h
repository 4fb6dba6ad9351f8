// The volumes of a scene (volume.h), each placed in the world by a motion transform, and what
// light transport asks of them. Volumes are not in the geometry's BVH: rays test the few
// volumes' boxes directly, so a volume is a module beside the geometry, not a kind of Shape.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "penumbra/motion.h"
#include "penumbra/volume.h"

namespace penumbra {

class VolumeSet {
 public:
  using VolumeId = uint32_t;

  VolumeId add();
  void remove(VolumeId id);
  /// Builds the volume from `data` (std::invalid_argument as validateVolume; the volume is then
  /// left as it was).
  void setData(VolumeId id, VolumeData data);
  /// Drops the volume's medium (it stays registered but renders nothing).
  void clearData(VolumeId id);
  void setPlacement(VolumeId id, const MotionTransform& objectToWorld, bool visible);
  /// Its light and shadow linking class (linking.h; LinkingTable::kLinkedToAll by default): a
  /// medium outside a light's light link scatters none of its light, one outside its shadow
  /// link lets its shadow rays pass.
  void setLinkingClass(VolumeId id, uint32_t linkingClass);
  /// Brings the list of shown volumes up to date; call after edits and before tracing.
  void commit();

  /// A shown volume as rays see it.
  struct Placed {
    std::shared_ptr<const Volume> volume;
    MotionTransform objectToWorld;
    Transform worldToObject;  // of a static placement
    Bounds3f worldBounds;     // over the shutter
    uint32_t linkingClass = 0;
  };
  const std::vector<Placed>& shown() const { return shown_; }
  bool empty() const { return shown_.empty(); }
  /// Bytes held by the volumes' fields and majorants.
  size_t memoryBytes() const;
  /// Active voxels over all volumes.
  uint64_t activeVoxels() const;

 private:
  struct Record {
    bool registered = false;
    std::shared_ptr<const Volume> volume;
    MotionTransform objectToWorld;
    bool visible = true;
    uint32_t linkingClass = 0;
  };
  std::vector<Record> records_;
  std::vector<VolumeId> freeIds_;
  std::vector<Placed> shown_;
};

}  // namespace penumbra
