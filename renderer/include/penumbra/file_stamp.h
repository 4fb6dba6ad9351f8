// What changes when a file is written again: its size and modification time. Texture and volume
// caches compare stamps to read again what was repainted or re-cached between two renders.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace penumbra {

struct FileStamp {
  uintmax_t size = 0;
  int64_t modified = 0;  // the file clock's ticks

  bool operator==(const FileStamp& other) const {
    return size == other.size && modified == other.modified;
  }
  bool operator!=(const FileStamp& other) const { return !(*this == other); }
};

/// `file`'s stamp now; none when it cannot be looked at.
inline std::optional<FileStamp> fileStamp(const std::string& file) {
  std::error_code error;
  const uintmax_t size = std::filesystem::file_size(file, error);
  if (error) return std::nullopt;
  const auto modified = std::filesystem::last_write_time(file, error);
  if (error) return std::nullopt;
  return FileStamp{size, int64_t(modified.time_since_epoch().count())};
}

/// Files with the stamps they had when they were read (none: they could not be looked at).
using StampedFiles = std::vector<std::pair<std::string, std::optional<FileStamp>>>;

/// Whether one of `files` was written, removed or made since its stamp was taken.
inline bool anyChanged(const StampedFiles& files) {
  for (const auto& [file, stamp] : files)
    if (fileStamp(file) != stamp) return true;
  return false;
}

}  // namespace penumbra
