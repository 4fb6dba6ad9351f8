// Writes an image as a tiled, MIP-mapped OpenEXR texture in memory that does not grow with the
// image's height: level 0 is read one band of scanlines at a time, each coarser level is
// spooled to a temporary file while the level above it is written (docs/design.md §3,
// Resources).
#pragma once

#include <OpenImageIO/imageio.h>

#include <functional>
#include <string>

namespace penumbra::detail {

/// Rewrites one row of level 0 in place (`width` pixels of `channels` floats), e.g. to decode
/// sRGB; applied before any filtering.
using RowTransform = std::function<void(float* row, int width, int channels)>;

/// Texture tiles are this many texels square.
constexpr int kTextureTileSize = 64;

/// Reads subimage 0 of `input` (at most its first four channels) and writes `output`: tiles of
/// kTextureTileSize², every MIP level down to 1x1 (each level half the one above, rounded down,
/// as OpenEXR's ROUND_DOWN), each texel of a coarser level the area-weighted mean of the texels
/// it covers. `format`: the stored pixel type (half or float). `spool`: a path for temporary
/// level data, removed before returning. False with *error set (without the file names) on
/// failure: "cannot read the image: …" when `input` cannot be read (a truncated file among
/// them), else what could not be written.
bool writeMipmappedTexture(OIIO::ImageInput& input, const std::string& output,
                           OIIO::TypeDesc format, const RowTransform& transform,
                           const std::string& spool, std::string* error);

}  // namespace penumbra::detail
