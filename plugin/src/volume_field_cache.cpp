#include "penumbra/plugin/volume_field_cache.h"

#include "penumbra/file_stamp.h"

namespace penumbra::plugin {

std::optional<VolumeFieldCache::Key> VolumeFieldCache::keyOf(const FieldRequest& request) {
  const std::optional<FileStamp> stamp = fileStamp(request.path);
  if (!stamp) return std::nullopt;
  return Key{request.path, request.gridName, request.index, stamp->size, stamp->modified};
}

bool VolumeFieldCache::holds(const FieldRequest& request) const {
  const std::optional<Key> key = keyOf(request);
  if (!key) return false;
  const auto found = entries_.find(*key);
  return found != entries_.end() && !found->second.field.expired();
}

VolumeFieldCache::Lookup VolumeFieldCache::get(const FieldRequest& request) {
  // Fields no volume holds any more are not kept: forget their entries.
  for (auto entry = entries_.begin(); entry != entries_.end();)
    entry = entry->second.field.expired() ? entries_.erase(entry) : std::next(entry);
  const std::optional<Key> key = keyOf(request);
  if (key) {
    const auto found = entries_.find(*key);
    if (found != entries_.end()) {
      Lookup held{found->second.metadata, false};
      held.read.field = found->second.field.lock();
      return held;
    }
  }
  // Unreadable files are read all the same, so that the error is the renderer's.
  VdbFieldRead read = readVdbField(request.path, request.gridName, request.index);
  ++reads_;
  if (key) {
    Entry& entry = entries_[*key];
    entry.field = read.field;
    entry.metadata = read;
    entry.metadata.field.reset();
  }
  return {std::move(read), true};
}

}  // namespace penumbra::plugin
