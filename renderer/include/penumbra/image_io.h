// Image files through OpenImageIO; display transforms through OpenColorIO.
#pragma once

#include <map>
#include <string>
#include <variant>
#include <vector>

namespace penumbra {

using MetadataValue = std::variant<std::string, int, float>;
using Metadata = std::map<std::string, MetadataValue>;

/// How display-referred formats (PNG, JPEG, TIFF, ...) encode scene-linear pixels.
enum class ColorCorrection {
  Disabled,     // values written as they are (clamped by quantisation)
  SRGB,         // the sRGB transfer function
  OpenColorIO,  // the OCIO config's display/view transform from scene_linear
};

struct DisplaySettings {
  ColorCorrection mode = ColorCorrection::Disabled;
  std::string ocioConfig;  // path; empty: $OCIO
  std::string display;     // empty: the config's default display
  std::string view;        // empty: the display's default view
};

struct ImageData {
  int width = 0, height = 0;
  std::vector<std::string> channelNames;
  std::vector<float> pixels;  // interleaved, row-major from the top row
  Metadata metadata;
};

/// True for formats that store floats in scene-linear (EXR, HDR); others are display-referred.
bool isSceneLinearFormat(const std::string& path);

/// Writes `image` to `path`, the extension picking the format. Display-referred formats get
/// their first three channels transformed by `display`; other channels pass through. The file
/// appears atomically (written under a temporary name next to it, then renamed). Throws
/// std::runtime_error naming the file on failure, leaving nothing behind.
void writeImage(const std::string& path, const ImageData& image, const DisplaySettings& display);

/// Reads any format OIIO supports as floats. Throws std::runtime_error naming the file.
ImageData readImage(const std::string& path);
/// Reads only the header: size, channel names and metadata (`pixels` stays empty). Throws
/// std::runtime_error naming the file.
ImageData readImageHeader(const std::string& path);

}  // namespace penumbra
