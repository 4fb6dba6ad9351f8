#include "penumbra/volume_set.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace penumbra {
namespace {

/// The box around `box` placed by `transform`.
Bounds3f placedBounds(const Bounds3f& box, const Transform& transform) {
  Bounds3f result;
  for (int corner = 0; corner < 8; ++corner)
    result.extend(transform.applyToPoint({corner & 1 ? box.upper.x : box.lower.x,
                                          corner & 2 ? box.upper.y : box.lower.y,
                                          corner & 4 ? box.upper.z : box.lower.z}));
  return result;
}

/// Whether `transform` maps a box onto a box of some volume: finite, and not flattening it.
bool placesAVolume(const Transform& transform) {
  for (const double value : transform.m)
    if (!std::isfinite(value)) return false;
  const double determinant = transform.linearDeterminant();
  return std::isfinite(determinant) && determinant != 0;
}

}  // namespace

VolumeSet::VolumeId VolumeSet::add() {
  VolumeId id;
  if (!freeIds_.empty()) {
    id = freeIds_.back();
    freeIds_.pop_back();
  } else {
    id = VolumeId(records_.size());
    records_.emplace_back();
  }
  records_[id] = Record();
  records_[id].registered = true;
  return id;
}

void VolumeSet::remove(VolumeId id) {
  if (id >= records_.size() || !records_[id].registered)
    throw std::out_of_range("no volume " + std::to_string(id));
  records_[id] = Record();
  freeIds_.push_back(id);
}

void VolumeSet::setData(VolumeId id, VolumeData data) {
  auto volume = std::make_shared<const Volume>(std::move(data));  // validates first
  records_.at(id).volume = std::move(volume);
}

void VolumeSet::clearData(VolumeId id) {
  records_.at(id).volume.reset();
}

void VolumeSet::setPlacement(VolumeId id, const MotionTransform& objectToWorld, bool visible) {
  Record& record = records_.at(id);
  record.objectToWorld = objectToWorld;
  record.visible = visible;
}

void VolumeSet::setLinkingClass(VolumeId id, uint32_t linkingClass) {
  records_.at(id).linkingClass = linkingClass;
}

void VolumeSet::commit() {
  shown_.clear();
  for (const Record& record : records_) {
    if (!record.registered || !record.volume || !record.visible) continue;
    // A volume scaled to nothing (at some step of the shutter) holds no medium worth tracking.
    const std::vector<Transform>& steps = record.objectToWorld.steps();
    if (!std::all_of(steps.begin(), steps.end(), placesAVolume)) continue;
    Placed placed;
    placed.volume = record.volume;
    placed.objectToWorld = record.objectToWorld;
    placed.worldToObject = record.objectToWorld.first().inverse();
    placed.linkingClass = record.linkingClass;
    // The box over the shutter: the steps' boxes (interpolation between steps stays close to
    // them; motion.h's decomposition keeps rotations short).
    for (const Transform& step : record.objectToWorld.steps())
      placed.worldBounds.extend(placedBounds(record.volume->objectBounds(), step));
    shown_.push_back(std::move(placed));
  }
}

size_t VolumeSet::memoryBytes() const {
  size_t bytes = 0;
  for (const Record& record : records_)
    if (record.volume) bytes += record.volume->memoryBytes();
  return bytes;
}

uint64_t VolumeSet::activeVoxels() const {
  uint64_t voxels = 0;
  for (const Record& record : records_)
    if (record.volume) voxels += record.volume->activeVoxels();
  return voxels;
}

}  // namespace penumbra
