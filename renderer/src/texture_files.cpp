#include "texture_files.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "mipmap_writer.h"

namespace OCIO = OCIO_NAMESPACE;
namespace fs = std::filesystem;

namespace penumbra::detail {

namespace {

using Wrap = OIIO::TextureOpt::Wrap;

// The largest texture taken (32k x 32k): the prepared copy on disk grows with the texel count,
// and a header can claim any size.
constexpr uint64_t kMaxTexels = uint64_t(1) << 30;

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return text;
}

std::string trimmed(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return text;
}

// The first line of `text`: OIIO's errors may repeat themselves a line per row or library.
std::string firstLine(const std::string& text) {
  return text.substr(0, text.find('\n'));
}

// A wrap mode named in file metadata, in USD's words or OIIO's ("periodic"); false if unknown.
bool parseWrap(const std::string& name, Wrap* wrap) {
  const std::string mode = lower(trimmed(name));
  if (mode == "black")
    *wrap = Wrap::WrapBlack;
  else if (mode == "clamp")
    *wrap = Wrap::WrapClamp;
  else if (mode == "repeat" || mode == "periodic")
    *wrap = Wrap::WrapPeriodic;
  else if (mode == "mirror")
    *wrap = Wrap::WrapMirror;
  else
    return false;
  return true;
}

// The wrap modes for wrapS/wrapT = useMetadata. UsdPreviewSurface spec, UsdUVTexture wrapS:
// "useMetadata: look for wrapS and wrapT metadata in the texture file itself, that are expected
// to be string-valued fields whose value is one of black, clamp, repeat, or mirror. If the
// texture contains no such metadata, then fall back to black." OIIO's own convention (maketx,
// "wrapmodes" = "periodic,clamp" or a single mode for both) is read too; USD's names win.
void metadataWraps(const OIIO::ImageSpec& spec, Wrap* s, Wrap* t) {
  *s = *t = Wrap::WrapBlack;
  const std::string modes = spec.get_string_attribute("wrapmodes");
  if (!modes.empty()) {
    const size_t comma = modes.find(',');
    parseWrap(modes.substr(0, comma), s);
    if (!parseWrap(comma == std::string::npos ? modes : modes.substr(comma + 1), t)) *t = *s;
  }
  parseWrap(spec.get_string_attribute("wrapS"), s);
  parseWrap(spec.get_string_attribute("wrapT"), t);
}

enum class ColorTag { None, Linear, SRGB };

ColorTag colorTag(const std::string& colorSpace) {
  const std::string name = lower(colorSpace);
  if (name.empty()) return ColorTag::None;
  if (name.find("linear") != std::string::npos || name.rfind("lin_", 0) == 0 || name == "raw" ||
      name == "acescg" || name == "aces2065-1")
    return ColorTag::Linear;
  if (name.find("srgb") != std::string::npos) return ColorTag::SRGB;
  return ColorTag::None;
}

// Whether a PNG file carries an sRGB chunk (it precedes the image data).
bool pngHasSrgbChunk(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  char header[8];
  if (!in.read(header, 8)) return false;
  for (int chunk = 0; chunk < 256; ++chunk) {
    unsigned char head[8];
    if (!in.read(reinterpret_cast<char*>(head), 8)) return false;
    const uint32_t length = uint32_t(head[0]) << 24 | uint32_t(head[1]) << 16 |
                            uint32_t(head[2]) << 8 | uint32_t(head[3]);
    const std::string type(reinterpret_cast<const char*>(head + 4), 4);
    if (type == "sRGB") return true;
    if (type == "IDAT" || type == "IEND") return false;
    in.seekg(std::streamoff(length) + 4, std::ios::cur);  // data and CRC
  }
  return false;
}

// sourceColorSpace = auto. UsdPreviewSurface spec, UsdUVTexture sourceColorSpace: "auto: Check
// for gamma/color space metadata in the texture file itself; if metadata is indicative of sRGB,
// mark texture as sRGB. If no relevant metadata is found, mark texture as sRGB if it is either
// 8-bit and has 3 channels or if it is 8-bit and has 4 channels. Otherwise, do not mark texture
// as sRGB and use texture data as it was read from the texture."
bool autoIsSrgb(const OIIO::ImageSpec& spec, const std::string& format, const std::string& file) {
  ColorTag tag = colorTag(spec.get_string_attribute("oiio:ColorSpace"));
  // OIIO 2.4's PNG and JPEG readers say "sRGB" for every file, whatever it holds (16-bit and
  // grey-scale too): that is a default, not metadata. Only an sRGB chunk (PNG) or EXIF
  // ColorSpace = 1 (JPEG) is. maketx copies that default into the .tx (TIFF) it makes of such
  // a file, so an "sRGB" label elsewhere is no evidence either (a grey roughness map turned
  // .tx was decoded as sRGB: 0.50 where 0.74); Storm goes by bits and channels alone.
  if (tag == ColorTag::SRGB &&
      !((format == "png" && pngHasSrgbChunk(file)) ||
        (format == "jpeg" && spec.get_int_attribute("Exif:ColorSpace") == 1)))
    tag = ColorTag::None;
  const float gamma = spec.get_float_attribute("oiio:Gamma", 0.0f);  // PNG gAMA chunk
  if (tag == ColorTag::None && gamma > 0.0f) {
    if (std::abs(gamma - 1.0f) < 0.01f)
      tag = ColorTag::Linear;
    else if (gamma > 2.0f && gamma < 2.6f)
      tag = ColorTag::SRGB;
  }
  if (tag != ColorTag::None) return tag == ColorTag::SRGB;
  return spec.format == OIIO::TypeDesc::UINT8 && (spec.nchannels == 3 || spec.nchannels == 4);
}

}  // namespace

TextureFiles::TextureFiles(OIIO::TextureSystem* oiio, std::string ocioConfig)
    : oiio_(oiio), colors_(std::move(ocioConfig)) {}

TextureFiles::~TextureFiles() {
  if (!directory_.empty()) {
    std::error_code ignored;
    fs::remove_all(directory_, ignored);
  }
}

void TextureFiles::forget(const std::string& file) {
  for (auto entry = files_.begin(); entry != files_.end();) {
    if (std::get<0>(entry->first) == file) {
      oiio_->invalidate(OIIO::ustring(entry->second.tile.path));
      entry = files_.erase(entry);
    } else {
      ++entry;
    }
  }
}

bool TextureFiles::makeDirectory(std::string* error) {
  if (!directory_.empty()) return true;
  std::error_code code;
  const fs::path base = fs::temp_directory_path(code);
  if (code) {
    *error = "no temporary directory for converted textures: " + code.message();
    return false;
  }
  std::string pattern = (base / "penumbra-textures-XXXXXX").string();
  if (!mkdtemp(pattern.data())) {
    *error =
        "cannot create a temporary directory in " + base.string() + ": " + std::strerror(errno);
    return false;
  }
  directory_ = pattern;
  return true;
}

bool TextureFiles::prepare(const std::string& file, const OIIO::ImageSpec& fileSpec,
                           const std::string& source, bool premultiply, std::string* texture,
                           std::string* error) {
  OCIO::ConstCPUProcessorRcPtr toScene;
  if (!source.empty() && !colors_.processor(source, &toScene, error)) {
    *error = file + ": " + *error;
    return false;
  }
  if (!makeDirectory(error)) {
    *error = file + ": " + *error;
    return false;
  }
  OIIO::ImageSpec readConfig;
  readConfig.attribute("oiio:UnassociatedAlpha", 1);  // decode colour, not colour × alpha
  auto input = OIIO::ImageInput::open(file, &readConfig);
  if (!input) {
    *error = file + ": cannot read the image: " + firstLine(trimmed(OIIO::geterror()));
    return false;
  }
  const OIIO::TypeDesc::BASETYPE base = OIIO::TypeDesc::BASETYPE(fileSpec.format.basetype);
  const bool half = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8 ||
                    base == OIIO::TypeDesc::HALF;  // half keeps 8-bit data exactly enough
  const std::string name = "texture-" + std::to_string(preparedCount_++);
  const std::string output = (directory_ / (name + ".exr")).string();
  RowTransform transform = toScene ? colors_.decoder(fileSpec, toScene) : RowTransform{};
  if (premultiply)
    transform = [decode = std::move(transform)](float* row, int width, int channels) {
      if (decode) decode(row, width, channels);  // colour is converted before it is weighted
      const int alpha = channels - 1;            // 2 channels: grey, alpha; 4: RGB, alpha
      for (int x = 0; x < width; ++x) {
        float* texel = row + size_t(x) * size_t(channels);
        for (int c = 0; c < alpha; ++c) texel[c] *= texel[alpha];
      }
    };
  if (!writeMipmappedTexture(*input, output, half ? OIIO::TypeHalf : OIIO::TypeFloat, transform,
                             (directory_ / (name + ".spool")).string(), error)) {
    // A file that cannot be read is the user's to mend; one that cannot be written, ours.
    const bool unreadable = error->rfind("cannot read the image", 0) == 0;
    *error = file + ": " +
             (unreadable ? firstLine(*error)
                         : "cannot prepare the texture " + output + ": " + trimmed(*error));
    return false;
  }
  *texture = output;
  return true;
}

bool TextureFiles::open(const std::string& file, const TextureColorSpace& colorSpace,
                        TextureAlpha alpha, OIIO::TextureSystem::Perthread* threadInfo,
                        TextureFile* result, std::string* error) {
  std::error_code code;
  if (!fs::exists(file, code)) {
    *error = file + ": no such file";
    // Tile patterns of other tools, which USD does not define: say why nothing was found.
    for (const char* token : {"<UVTILE>", "<uvtile>", "_MAPID_", "<U>", "<V>"})
      if (file.find(token) != std::string::npos)
        *error += std::string(" (the tile token ") + token + " is not supported: USD's is <UDIM>)";
    return false;
  }
  OIIO::ImageSpec spec;
  std::string format;
  bool mipmapped = false;
  {
    // As lookups read it: PNG or TIFF colour not multiplied by alpha, which the spec then says.
    OIIO::ImageSpec readConfig;
    readConfig.attribute("oiio:UnassociatedAlpha", 1);
    auto input = OIIO::ImageInput::open(file, &readConfig);
    if (!input) {
      *error = file + ": cannot read the image: " + firstLine(trimmed(OIIO::geterror()));
      return false;
    }
    spec = input->spec();
    format = input->format_name();
    OIIO::ImageSpec level1;
    mipmapped = input->seek_subimage(0, 1, level1);
  }
  if (spec.nchannels < 1 || spec.width < 1 || spec.height < 1) {
    *error = file + ": the image has no pixels";
    return false;
  }
  if (uint64_t(spec.width) * uint64_t(spec.height) > kMaxTexels) {
    *error = file + ": the image claims " + std::to_string(spec.width) + "x" +
             std::to_string(spec.height) + " texels, more than the " +
             std::to_string(kMaxTexels >> 20) + " Mi texels Penumbra takes as a texture";
    return false;
  }
  const bool autoSrgb = colorSpace.name.empty() && colorSpace.source == SourceColorSpace::Auto &&
                        autoIsSrgb(spec, format, file);
  std::string source;
  if (!colors_.conversionFrom(autoSrgb ? TextureColorSpace(SourceColorSpace::SRGB) : colorSpace,
                              &source, error)) {
    *error = file + ": " + *error;
    return false;
  }
  // USD's channel rules: alpha is the second of two channels, the fourth of four.
  const bool coverage =
      alpha == TextureAlpha::Coverage && (spec.nchannels == 2 || spec.nchannels >= 4);
  // Files whose colour is premultiplied already (OpenEXR's convention) are filtered as they are.
  const bool premultiply = coverage && spec.get_int_attribute("oiio:UnassociatedAlpha") != 0;
  const auto key = std::make_tuple(file, source, coverage);
  if (auto found = files_.find(key); found != files_.end()) {
    *result = found->second;
    return true;
  }
  TextureFile opened;
  metadataWraps(spec, &opened.metadataS, &opened.metadataT);
  // Files that are tiled and MIP-mapped already (e.g. by maketx) are read as they are, unless
  // they must be converted or premultiplied; every other file is prepared once, since OIIO's
  // on-the-fly tiling and MIP-mapping ("autotile", "automip") keeps whole images in its cache.
  std::string texture = file;
  const bool ready = spec.tile_width > 0 && mipmapped && spec.nchannels <= 4;
  if ((!source.empty() || !ready || premultiply) &&
      !prepare(file, spec, source, premultiply, &texture, error))
    return false;
  opened.tile.handle = oiio_->get_texture_handle(OIIO::ustring(texture), threadInfo);
  opened.tile.path = texture;
  OIIO::ImageSpec textureSpec;
  if (!opened.tile.handle || !oiio_->good(opened.tile.handle) ||
      !oiio_->get_imagespec(opened.tile.handle, threadInfo, 0, textureSpec)) {
    *error = file + ": cannot open as a texture: " + firstLine(trimmed(oiio_->geterror()));
    return false;
  }
  opened.tile.channels = std::min(textureSpec.nchannels, 4);
  opened.tile.x = textureSpec.x;
  opened.tile.y = textureSpec.y;
  opened.tile.width = textureSpec.width;
  opened.tile.height = textureSpec.height;
  opened.tile.coverageAlpha = coverage;
  files_.emplace(key, opened);
  *result = opened;
  return true;
}

}  // namespace penumbra::detail
