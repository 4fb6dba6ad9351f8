// Image files through OpenImageIO; display transforms through OpenColorIO.
#pragma once

#include <array>
#include <map>
#include <string>
#include <variant>
#include <vector>

namespace penumbra {

/// A 4x4 matrix, row-major (as OIIO's `worldtocamera`, `worldtoscreen`: row vectors).
using Matrix44 = std::array<float, 16>;
using MetadataValue = std::variant<std::string, int, float, Matrix44>;
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
  /// Per channel, non-zero to store it as half floats (EXR only); empty: all float.
  std::vector<uint8_t> halfChannels;
  Metadata metadata;
  /// A crop of a larger frame (OpenEXR's data and display windows; other formats hold the crop
  /// alone): the crop's top-left pixel in the frame, which may lie outside it (overscan), and
  /// the frame's size. 0 × 0: the image is the whole frame.
  int x = 0, y = 0;
  int displayWidth = 0, displayHeight = 0;
};

/// Applies `display`'s transform to the first three channels of interleaved pixels, in place
/// (nothing for fewer channels). Throws std::runtime_error for OCIO failures.
void applyDisplayTransform(std::vector<float>& pixels, int width, int height, int channels,
                           const DisplaySettings& display);

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
