// The volume fields read from OpenVDB files, shared between syncs, volumes and frames (one per
// render delegate, in the SyncContext): a grid is read again only when its file changed (size
// or modification time) or when no volume holds it any more, so that memory follows the
// volumes in the scene.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>

#include "penumbra/vdb_field.h"

namespace penumbra::plugin {

/// A grid of a file, as a volume's field slot asks for it.
struct FieldRequest {
  std::string path;      // the OpenVDB file, resolved
  std::string gridName;  // the grid's name in the file
  int index = 0;         // which of the grids of that name (0: the first)

  bool operator==(const FieldRequest& other) const {
    return path == other.path && gridName == other.gridName && index == other.index;
  }
};

class VolumeFieldCache {
 public:
  /// The field of `request`, read with readVdbField unless a field of the same file (same size
  /// and modification time) is still held; `fresh` is true when it was read now (its repairs
  /// are then news). Throws VolumeFieldError with the renderer's reason.
  struct Lookup {
    VdbFieldRead read;
    bool fresh = false;
  };
  Lookup get(const FieldRequest& request);
  /// Whether `request`'s field is held and its file unchanged (a sync would read nothing).
  bool holds(const FieldRequest& request) const;
  /// Grids read from files so far.
  uint64_t reads() const { return reads_; }

 private:
  // (path, grid, index, file size, modification time in the file clock's ticks)
  using Key = std::tuple<std::string, std::string, int, uintmax_t, int64_t>;
  struct Entry {
    std::weak_ptr<const VolumeField> field;
    VdbFieldRead metadata;  // the read's value type and repairs, without the field
  };
  /// The key of `request`'s file as it is now; none when the file cannot be looked at.
  static std::optional<Key> keyOf(const FieldRequest& request);

  std::map<Key, Entry> entries_;
  uint64_t reads_ = 0;
};

}  // namespace penumbra::plugin
