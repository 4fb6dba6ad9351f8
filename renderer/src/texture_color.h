// The OCIO colour conversions of one TextureSystem: from a texture's colour space to the OCIO
// config's scene_linear role.
#pragma once

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>

#include <map>
#include <string>

#include "mipmap_writer.h"
#include "penumbra/texture.h"

namespace penumbra::detail {

/// The OCIO config at a path (empty: $OCIO), loaded when the first texture needs converting,
/// and the conversions made with it.
class TextureColorConversions {
 public:
  explicit TextureColorConversions(std::string configPath);

  /// The colour space a file in `space` is converted from (empty: none), or false with *error.
  /// sourceColorSpace auto is decided per file by the caller (it needs the file's metadata).
  bool conversionFrom(const TextureColorSpace& space, std::string* source, std::string* error);

  /// The conversion from colour space `source` to scene_linear, made once per colour space.
  bool processor(const std::string& source, OCIO_NAMESPACE::ConstCPUProcessorRcPtr* result,
                 std::string* error);

  /// The conversion of one row of `channels` floats: colour channels (all but alpha, at most
  /// three) to scene_linear; a grey channel becomes the converted grey's luminance.
  RowTransform decoder(const OIIO::ImageSpec& spec,
                       const OCIO_NAMESPACE::ConstCPUProcessorRcPtr& conversion) const;

 private:
  std::string configName() const;
  bool loadOcio();

  std::string configPath_;
  bool loaded_ = false;
  std::string loadError_;
  OCIO_NAMESPACE::ConstConfigRcPtr config_;
  std::string srgbSpace_;         // the config's sRGB texture colour space; empty if none
  std::string sceneLinearSpace_;  // the colour space of its scene_linear role
  float luma_[3] = {0.2126f, 0.7152f, 0.0722f};
  std::map<std::string, OCIO_NAMESPACE::ConstCPUProcessorRcPtr> toLinear_;  // by source space
};

}  // namespace penumbra::detail
