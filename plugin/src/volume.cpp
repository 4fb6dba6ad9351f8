#include "penumbra/plugin/volume.h"

#include <stdexcept>
#include <string>

#include "penumbra/vdb_field.h"

namespace penumbra::plugin {
namespace {

// Each field slot: its name in warnings, its request, where VolumeData takes it, whether it
// must be a scalar, and whether the volume is nothing without it.
struct Slot {
  const char* name;
  std::optional<FieldRequest> VolumeFieldRequests::* request;
  std::shared_ptr<const VolumeField> VolumeData::* field;
  bool scalar;
  bool required;
};
constexpr std::array<Slot, 4> kSlots{{
    {"density", &VolumeFieldRequests::density, &VolumeData::density, true, true},
    {"color", &VolumeFieldRequests::color, &VolumeData::color, false, false},
    {"temperature", &VolumeFieldRequests::temperature, &VolumeData::temperature, true, false},
    {"emission", &VolumeFieldRequests::emission, &VolumeData::emission, false, false},
}};

std::string describe(const PrimId& id, const Slot& slot, const FieldRequest& request) {
  return id + ": field slot '" + slot.name + "' (file " + request.path + ", grid '" +
         request.gridName + "' #" + std::to_string(request.index) + ")";
}

}  // namespace

void Volume::setFields(VolumeFieldRequests fields) {
  fields_ = std::move(fields);
  markDirty(DirtyParams);
}

void Volume::setMaterial(const VolumeMaterial& material) {
  material_ = material;
  markDirty(DirtyParams);
}

void Volume::setTransform(const MotionTransform& objectToWorld) {
  objectToWorld_ = objectToWorld;
  markDirty(DirtyTransform);
}

void Volume::setVisible(bool visible) {
  visible_ = visible;
  markDirty(DirtyVisibility);
}

void Volume::setLinkingClass(uint32_t linkingClass) {
  linkingClass_ = linkingClass;
  markDirty(DirtyVisibility);
}

std::optional<VolumeData> Volume::readData(SyncContext& context) {
  VolumeData data;
  data.material = material_;
  readStamps_.clear();
  for (const Slot& slot : kSlots) {
    const std::optional<FieldRequest>& request = fields_.*slot.request;
    if (!request) continue;
    readStamps_.emplace_back(request->path, fileStamp(request->path));
    const char* outcome = slot.required ? "; the volume is skipped" : "; the slot is dropped";
    try {
      VolumeFieldCache::Lookup found = context.volumeFields.get(*request);
      const VdbFieldRead& read = found.read;
      if (found.fresh && (read.nonFiniteVoxels || read.negativeVoxels))
        context.warn(describe(id(), slot, *request) + ": " + std::to_string(read.nonFiniteVoxels) +
                     " non-finite and " + std::to_string(read.negativeVoxels) +
                     " negative voxels read as 0");
      if (slot.scalar && read.field->components() != 1) {
        context.warn(describe(id(), slot, *request) + ": a grid of " + read.valueType +
                     " where a scalar is needed" + outcome);
        if (slot.required) return std::nullopt;
        continue;
      }
      data.*slot.field = read.field;
    } catch (const VolumeFieldError& error) {
      context.warn(describe(id(), slot, *request) + ": " + error.what() + outcome);
      if (slot.required) return std::nullopt;
    }
  }
  return data;
}

void Volume::sync(SyncContext& context, uint32_t bits) {
  context.sceneChanged = true;
  VolumeSet& volumes = context.scene.volumes();
  if (bits & DirtyParams) {
    std::optional<VolumeData> data = readData(context);
    try {
      if (data) volumes.setData(handle_, std::move(*data));
    } catch (const std::invalid_argument& error) {
      context.warn(id() + ": " + error.what() + "; skipped");
      data.reset();
    }
    if (!data) volumes.clearData(handle_);
  }
  if (bits & (DirtyTransform | DirtyVisibility)) {
    volumes.setPlacement(handle_, objectToWorld_, visible_);
    volumes.setLinkingClass(handle_, linkingClass_);
  }
}

void Volume::finalize(SyncContext& context) {
  context.sceneChanged = true;
  context.scene.volumes().remove(handle_);
}

bool Volume::fieldFilesChanged() const {
  return anyChanged(readStamps_);
}

size_t Volume::estimatedSyncBytes(const VolumeFieldCache& cache) const {
  if (!(dirtyBits() & DirtyParams) && !fieldFilesChanged()) return 0;
  size_t bytes = 0;
  for (const Slot& slot : kSlots) {
    const std::optional<FieldRequest>& request = fields_.*slot.request;
    if (!request || cache.holds(*request)) continue;
    bytes += size_t(estimatedVdbFieldBytes(request->path, request->gridName, request->index));
  }
  return bytes;
}

}  // namespace penumbra::plugin
