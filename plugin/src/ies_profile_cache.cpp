#include "penumbra/plugin/ies_profile_cache.h"

namespace penumbra::plugin {

std::shared_ptr<const IesProfile> IesProfileCache::load(const std::string& path) {
  const std::optional<FileStamp> stamp = fileStamp(path);
  Entry& entry = entries_[path];
  if (std::shared_ptr<const IesProfile> held = entry.profile.lock(); held && entry.stamp == stamp)
    return held;
  auto profile = std::make_shared<const IesProfile>(IesProfile::read(path));
  entry = Entry{stamp, profile};
  return profile;
}

}  // namespace penumbra::plugin
