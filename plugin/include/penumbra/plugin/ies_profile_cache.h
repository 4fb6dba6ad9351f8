// IES profiles read from files, shared between the lights naming them: a lamp placed a thousand
// times reads (and integrates) its profile once, while the file's size and time are unchanged.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>

#include "penumbra/file_stamp.h"
#include "penumbra/ies_profile.h"

namespace penumbra::plugin {

class IesProfileCache {
 public:
  /// The profile in the file at `path`, read again when the file changed since it was read
  /// (or when no light holds it any more). Throws std::invalid_argument naming the file when it
  /// cannot be read or parsed (IesProfile::read).
  std::shared_ptr<const IesProfile> load(const std::string& path);

 private:
  struct Entry {
    std::optional<FileStamp> stamp;  // the file's, when it was read
    std::weak_ptr<const IesProfile> profile;
  };
  std::map<std::string, Entry> entries_;
};

}  // namespace penumbra::plugin
