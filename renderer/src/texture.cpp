// UsdUVTexture lookups over a private OpenImageIO TextureSystem.
//
// Coordinates: USD's st has its origin at the image's bottom-left corner with t up; OIIO's st has
// its origin at the top-left corner with t down. A lookup passes t' = 1 - t and negates the t
// derivatives. The substitution commutes with every wrap mode (black/clamp: [0,1] maps to itself;
// periodic and mirror: 1 - t shifts by a whole period and reflects about an integer), so wrapping
// happens in OIIO.
//
// Memory: lookups read tiles of MIP levels through OIIO's cache, whose size is bounded
// (setCacheSize), so memory does not grow with a texture's resolution. OIIO can only do that
// for files that are tiled and MIP-mapped; its on-the-fly tiling and MIP-mapping ("autotile",
// "automip") keep whole images in the cache. Every other file is prepared once when opened: read
// one band of scanlines at a time and written as a tiled, MIP-mapped half/float OpenEXR texture
// into a private temporary directory (mipmap_writer.h), and that is what OIIO reads.
//
// Colour: textures in a colour space other than scene_linear (sRGB-encoded ones, and any colour
// space of the OCIO config named by MaterialX or USD metadata) are converted to the OCIO
// config's scene_linear role once, while they are prepared, before any filtering (averaging
// encoded values darkens MIP levels); lookups then read converted texels. A colour space that is
// scene_linear itself, or data, needs no conversion. Textures needing none that are tiled and
// MIP-mapped already are read from the original file.
//
// Alpha: values come back as stored in the file. PNG colour is not premultiplied by alpha (the
// ImageCache's "unassociatedalpha"), so a cut-out's diffuse colour is not darkened at its edges.
//
// UDIM: tiles 1001–1100 are found when the texture is opened (each one converted on its own by
// the colour-space rule); tile = 1001 + floor(s) + 10 floor(t) in USD st, and the lookup inside
// the tile uses the fractional parts, clamped to the tile.
#include "penumbra/texture.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imagecache.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/texture.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <utility>
#include <vector>

#include "mipmap_writer.h"

namespace OCIO = OCIO_NAMESPACE;
namespace fs = std::filesystem;

namespace penumbra {

namespace {

using Wrap = OIIO::TextureOpt::Wrap;
using OiioHandle = OIIO::TextureSystem::TextureHandle;

constexpr const char* kUdimToken = "<UDIM>";
constexpr int kUdimFirst = 1001;
constexpr int kUdimTiles = 100;  // 1001–1100: 10 tiles across (s), 10 rows up (t)

// The largest texture taken (32k x 32k): the prepared copy on disk grows with the texel count,
// and a header can claim any size.
constexpr uint64_t kMaxTexels = uint64_t(1) << 30;

// Names under which configs carry the sRGB texture encoding (OCIO resolves aliases).
constexpr const char* kSrgbNames[] = {"sRGB - Texture", "srgb_texture", "sRGB",
                                      "Utility - sRGB - Texture"};

// MaterialX's colour-space names (docs/materialx.md) and the Color Interop Forum's identifiers
// for the same encodings, which recent configs (the ACES ones among them) carry as aliases.
// Penumbra's bundled config has MaterialX's names as aliases itself.
constexpr std::pair<const char*, const char*> kInteropNames[] = {
    {"srgb_texture", "srgb_rec709_scene"},
    {"lin_rec709", "lin_rec709_scene"},
    {"acescg", "lin_ap1_scene"},
    {"lin_ap1", "lin_ap1_scene"},
    {"g22_rec709", "g22_rec709_scene"},
    {"g18_rec709", "g18_rec709_scene"},
    {"g22_ap1", "g22_ap1_scene"},
    {"lin_displayp3", "lin_p3d65_scene"},
    {"srgb_displayp3", "srgb_p3d65_scene"},
    {"lin_adobergb", "lin_adobergb_scene"},
    {"adobergb", "g22_adobergb_scene"}};

OCIO::ConstConfigRcPtr loadConfig(const std::string& path) {
  return path.empty() ? OCIO::GetCurrentConfig() : OCIO::Config::CreateFromFile(path.c_str());
}

// The colour space `name` denotes in `config` (see findTextureColorSpace); null if none.
OCIO::ConstColorSpaceRcPtr colorSpaceNamed(const OCIO::Config& config, const std::string& name) {
  if (name.empty()) return nullptr;
  if (auto space = config.getColorSpace(name.c_str())) return space;
  for (const auto& [materialx, interop] : kInteropNames)
    if (name == materialx)
      if (auto space = config.getColorSpace(interop)) return space;
  return nullptr;
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return text;
}

std::string trimmed(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return text;
}

std::string replaceAll(std::string text, const std::string& token, const std::string& value) {
  for (size_t at = text.find(token); at != std::string::npos;
       at = text.find(token, at + value.size()))
    text.replace(at, token.size(), value);
  return text;
}

Wrap toOiio(TextureWrap wrap) {
  switch (wrap) {
    case TextureWrap::Black:
      return Wrap::WrapBlack;
    case TextureWrap::Clamp:
      return Wrap::WrapClamp;
    case TextureWrap::Repeat:
      return Wrap::WrapPeriodic;
    case TextureWrap::Mirror:
      return Wrap::WrapMirror;
    case TextureWrap::UseMetadata:
      break;
  }
  return Wrap::WrapBlack;
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
  // ColorSpace = 1 (JPEG) is.
  if (tag == ColorTag::SRGB && format == "png" && !pngHasSrgbChunk(file)) tag = ColorTag::None;
  if (tag == ColorTag::SRGB && format == "jpeg" && spec.get_int_attribute("Exif:ColorSpace") != 1)
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

// One image file as OIIO's TextureSystem reads it.
struct Tile {
  OiioHandle* handle = nullptr;
  std::string path;  // the file OIIO reads (the prepared copy, if any)
  int channels = 0;
  int x = 0, y = 0, width = 0, height = 0;  // level 0's data window
};

// rgb from a texel of `channels` values, by USD's channel rules.
Vec3f toRgb(const float* value, int channels) {
  return channels >= 3 ? Vec3f(value[0], value[1], value[2]) : Vec3f(value[0]);
}

struct File {
  Tile tile;
  Wrap metadataS = Wrap::WrapBlack, metadataT = Wrap::WrapBlack;
};

struct Texture {
  bool udim = false;
  int channels = 0;
  Wrap metadataS = Wrap::WrapBlack, metadataT = Wrap::WrapBlack;
  Tile single;
  std::array<Tile, kUdimTiles> tiles{};
};

}  // namespace

struct TextureSystem::Impl {
  std::string ocioConfigPath;
  OIIO::TextureSystem* oiio = nullptr;
  std::vector<Texture> textures;
  std::map<std::tuple<std::string, SourceColorSpace, std::string>, Handle> handles;
  // (file, the colour space it is converted from; empty: none)
  std::map<std::pair<std::string, std::string>, File> files;

  // The OCIO config, loaded when the first texture needs converting.
  bool ocioLoaded = false;
  std::string ocioError;
  OCIO::ConstConfigRcPtr config;
  std::string srgbSpace;         // the config's sRGB texture colour space; empty if none
  std::string sceneLinearSpace;  // the colour space of its scene_linear role
  float luma[3] = {0.2126f, 0.7152f, 0.0722f};
  std::map<std::string, OCIO::ConstCPUProcessorRcPtr> toLinear;  // by source colour space

  fs::path directory;  // converted textures; created on first need
  int preparedCount = 0;

  explicit Impl(const std::string& configPath) : ocioConfigPath(configPath) {
    oiio = OIIO::TextureSystem::create(/*shared=*/false);
    oiio->attribute("unassociatedalpha", 1);
    oiio->attribute("max_memory_MB", float(kDefaultCacheBytes >> 20));
  }

  ~Impl() {
    // Tearing the private ImageCache down too: without it, each scene's cache (and its tiles)
    // outlived the scene (found by LeakSanitizer, make sanitize). Closes the files before they
    // are removed.
    if (oiio) OIIO::TextureSystem::destroy(oiio, /*teardown_imagecache=*/true);
    if (!directory.empty()) {
      std::error_code ignored;
      fs::remove_all(directory, ignored);
    }
  }

  std::string configName() const {
    return ocioConfigPath.empty() ? std::string("$OCIO") : "\"" + ocioConfigPath + "\"";
  }

  bool loadOcio() {
    if (ocioLoaded) return bool(config);
    ocioLoaded = true;
    try {
      config = loadConfig(ocioConfigPath);
      const auto sceneLinear = config->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
      if (!sceneLinear) {
        ocioError = "the OCIO config " + configName() + " has no scene_linear role";
        config.reset();
        return false;
      }
      sceneLinearSpace = sceneLinear->getName();
      for (const char* name : kSrgbNames)
        if (const auto space = config->getColorSpace(name)) {
          srgbSpace = space->getName();
          break;
        }
      double coefficients[3];
      config->getDefaultLumaCoefs(coefficients);
      for (int i = 0; i < 3; ++i) luma[i] = float(coefficients[i]);
    } catch (const OCIO::Exception& exception) {
      ocioError = "cannot read the OCIO config " + configName() + ": " + exception.what();
      config.reset();
    }
    return bool(config);
  }

  // The colour space a file in `space` is converted from (empty: none), or false with *error.
  // sourceColorSpace auto is decided per file by the caller (it needs the file's metadata).
  bool conversionFrom(const TextureColorSpace& space, std::string* source, std::string* error) {
    source->clear();
    if (space.name.empty() && space.source != SourceColorSpace::SRGB) return true;
    if (!loadOcio()) {
      *error = ocioError;
      return false;
    }
    if (space.name.empty()) {
      if (srgbSpace.empty()) {
        *error = "sourceColorSpace sRGB: the OCIO config " + configName() +
                 " has no sRGB texture colour space (tried \"sRGB - Texture\", "
                 "\"srgb_texture\", \"sRGB\", \"Utility - sRGB - Texture\")";
        return false;
      }
      *source = srgbSpace;
      return true;
    }
    const auto named = colorSpaceNamed(*config, space.name);
    if (!named) {
      *error = "the OCIO config " + configName() + " has no colour space \"" + space.name + "\"";
      return false;
    }
    if (!named->isData() && named->getName() != sceneLinearSpace) *source = named->getName();
    return true;
  }

  // The conversion from colour space `source` to scene_linear, made once per colour space.
  bool processor(const std::string& source, OCIO::ConstCPUProcessorRcPtr* result,
                 std::string* error) {
    auto& cached = toLinear[source];
    if (!cached) {
      try {
        cached =
            config->getProcessor(source.c_str(), OCIO::ROLE_SCENE_LINEAR)->getDefaultCPUProcessor();
      } catch (const OCIO::Exception& exception) {
        *error = "cannot convert \"" + source + "\" to scene_linear with the OCIO config " +
                 configName() + ": " + exception.what();
        return false;
      }
    }
    *result = cached;
    return true;
  }

  bool makeDirectory(std::string* error) {
    if (!directory.empty()) return true;
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
    directory = pattern;
    return true;
  }

  // The conversion of one row of `channels` floats: colour channels (all but alpha, at most
  // three) to scene_linear; a grey channel becomes the converted grey's luminance.
  detail::RowTransform decoder(const OIIO::ImageSpec& spec,
                               const OCIO::ConstCPUProcessorRcPtr& conversion) const {
    std::vector<int> color;
    for (int c = 0; c < std::min(spec.nchannels, 4) && color.size() < 3; ++c)
      if (c != spec.alpha_channel) color.push_back(c);
    if (color.empty()) return {};
    return [color, processor = conversion, luma = std::array<float, 3>{luma[0], luma[1], luma[2]}](
               float* row, int width, int channels) {
      std::vector<float> rgb(size_t(width) * 3);
      for (int x = 0; x < width; ++x)
        for (int k = 0; k < 3; ++k)
          rgb[3 * size_t(x) + k] = row[size_t(x) * channels + color[color.size() == 3 ? k : 0]];
      OCIO::PackedImageDesc description(rgb.data(), width, 1, 3);
      processor->apply(description);
      for (int x = 0; x < width; ++x) {
        const float* value = &rgb[3 * size_t(x)];
        if (color.size() == 3) {
          for (int k = 0; k < 3; ++k) row[size_t(x) * channels + color[k]] = value[k];
        } else {
          row[size_t(x) * channels + color[0]] =
              luma[0] * value[0] + luma[1] * value[1] + luma[2] * value[2];
        }
      }
    };
  }

  // Writes `file` as a tiled, MIP-mapped OpenEXR texture (converted from colour space `source`
  // to scene-linear first, unless `source` is empty), streaming it so that memory does not grow
  // with its height; *texture is its path.
  bool prepare(const std::string& file, const OIIO::ImageSpec& fileSpec, const std::string& source,
               std::string* texture, std::string* error) {
    OCIO::ConstCPUProcessorRcPtr toScene;
    if (!source.empty() && !processor(source, &toScene, error)) {
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
      *error = file + ": cannot read the image: " + trimmed(OIIO::geterror());
      return false;
    }
    const OIIO::TypeDesc::BASETYPE base = OIIO::TypeDesc::BASETYPE(fileSpec.format.basetype);
    const bool half = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8 ||
                      base == OIIO::TypeDesc::HALF;  // half keeps 8-bit data exactly enough
    const std::string name = "texture-" + std::to_string(preparedCount++);
    const std::string output = (directory / (name + ".exr")).string();
    if (!detail::writeMipmappedTexture(
            *input, output, half ? OIIO::TypeHalf : OIIO::TypeFloat,
            toScene ? decoder(fileSpec, toScene) : detail::RowTransform{},
            (directory / (name + ".spool")).string(), error)) {
      *error = file + ": cannot prepare the texture " + output + ": " + trimmed(*error);
      return false;
    }
    *texture = output;
    return true;
  }

  // Prepares one image file for lookups (shared between handles that read it the same way).
  bool openFile(const std::string& file, const TextureColorSpace& colorSpace, File* result,
                std::string* error) {
    std::error_code code;
    if (!fs::exists(file, code)) {
      *error = file + ": no such file";
      return false;
    }
    OIIO::ImageSpec spec;
    std::string format;
    bool mipmapped = false;
    {
      auto input = OIIO::ImageInput::open(file);
      if (!input) {
        *error = file + ": cannot read the image: " + trimmed(OIIO::geterror());
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
    if (!conversionFrom(autoSrgb ? TextureColorSpace(SourceColorSpace::SRGB) : colorSpace, &source,
                        error)) {
      *error = file + ": " + *error;
      return false;
    }
    const auto key = std::make_pair(file, source);
    if (auto found = files.find(key); found != files.end()) {
      *result = found->second;
      return true;
    }
    File opened;
    metadataWraps(spec, &opened.metadataS, &opened.metadataT);
    // Files that are tiled and MIP-mapped already (e.g. by maketx) are read as they are, unless
    // they must be converted; every other file is prepared once, since OIIO's on-the-fly tiling
    // and MIP-mapping ("autotile", "automip") keeps whole images in its cache.
    std::string texture = file;
    const bool ready = spec.tile_width > 0 && mipmapped && spec.nchannels <= 4;
    if ((!source.empty() || !ready) && !prepare(file, spec, source, &texture, error)) return false;
    opened.tile.handle = oiio->get_texture_handle(OIIO::ustring(texture));
    opened.tile.path = texture;
    OIIO::ImageSpec textureSpec;
    if (!opened.tile.handle || !oiio->good(opened.tile.handle) ||
        !oiio->get_imagespec(opened.tile.handle, nullptr, 0, textureSpec)) {
      *error = file + ": cannot open as a texture: " + trimmed(oiio->geterror());
      return false;
    }
    opened.tile.channels = std::min(textureSpec.nchannels, 4);
    opened.tile.x = textureSpec.x;
    opened.tile.y = textureSpec.y;
    opened.tile.width = textureSpec.width;
    opened.tile.height = textureSpec.height;
    files.emplace(key, opened);
    *result = opened;
    return true;
  }
};

TextureSystem::TextureSystem(const std::string& ocioConfig)
    : impl_(std::make_unique<Impl>(ocioConfig)) {}

TextureSystem::~TextureSystem() = default;

std::string findTextureColorSpace(const std::string& ocioConfig, const std::string& name,
                                  std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  const std::string configName = ocioConfig.empty() ? "$OCIO" : "\"" + ocioConfig + "\"";
  try {
    const auto config = loadConfig(ocioConfig);
    if (const auto space = colorSpaceNamed(*config, name)) return space->getName();
    *error = "the OCIO config " + configName + " has no colour space \"" + name + "\"";
  } catch (const OCIO::Exception& exception) {
    *error = "cannot read the OCIO config " + configName + ": " + exception.what();
  }
  return {};
}

bool convertToSceneLinear(const std::string& ocioConfig, const std::string& name, float rgb[3],
                          std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  const std::string configName = ocioConfig.empty() ? "$OCIO" : "\"" + ocioConfig + "\"";
  try {
    const auto config = loadConfig(ocioConfig);
    const auto space = colorSpaceNamed(*config, name);
    if (!space) {
      *error = "the OCIO config " + configName + " has no colour space \"" + name + "\"";
      return false;
    }
    config->getProcessor(space->getName(), OCIO::ROLE_SCENE_LINEAR)
        ->getDefaultCPUProcessor()
        ->applyRGB(rgb);
    return true;
  } catch (const OCIO::Exception& exception) {
    *error = "cannot convert \"" + name + "\" with the OCIO config " + configName + ": " +
             exception.what();
    return false;
  }
}

TextureSystem::Handle TextureSystem::open(const std::string& path,
                                          const TextureColorSpace& colorSpace, std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  const auto key = std::make_tuple(path, colorSpace.source, colorSpace.name);
  if (auto found = impl_->handles.find(key); found != impl_->handles.end()) return found->second;

  Texture texture;
  if (path.find(kUdimToken) != std::string::npos) {
    texture.udim = true;
    int tiles = 0;
    for (int i = 0; i < kUdimTiles; ++i) {
      const std::string file = replaceAll(path, kUdimToken, std::to_string(kUdimFirst + i));
      std::error_code code;
      if (!fs::exists(file, code)) continue;
      File opened;
      if (!impl_->openFile(file, colorSpace, &opened, error)) return kInvalid;
      texture.tiles[i] = opened.tile;
      texture.channels = std::max(texture.channels, opened.tile.channels);
      ++tiles;
    }
    if (tiles == 0) {
      *error = path + ": no UDIM tiles (looked for 1001 to 1100)";
      return kInvalid;
    }
  } else {
    File opened;
    if (!impl_->openFile(path, colorSpace, &opened, error)) return kInvalid;
    texture.single = opened.tile;
    texture.channels = opened.tile.channels;
    texture.metadataS = opened.metadataS;
    texture.metadataT = opened.metadataT;
  }
  const Handle handle = Handle(impl_->textures.size());
  impl_->textures.push_back(texture);
  impl_->handles.emplace(key, handle);
  return handle;
}

int TextureSystem::channels(Handle handle) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return 0;
  return impl_->textures[size_t(handle)].channels;
}

void TextureSystem::setCacheSize(size_t bytes) {
  constexpr size_t kMinimum = size_t(16) << 20;
  impl_->oiio->attribute("max_memory_MB", float(std::max(bytes, kMinimum) >> 20));
}

size_t TextureSystem::cacheSize() const {
  float megabytes = 0;
  impl_->oiio->getattribute("max_memory_MB", megabytes);
  return size_t(megabytes) << 20;
}

bool TextureSystem::resolution(Handle handle, int* width, int* height) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return false;
  const Texture& texture = impl_->textures[size_t(handle)];
  if (texture.udim) return false;
  *width = texture.single.width;
  *height = texture.single.height;
  return true;
}

bool TextureSystem::readLevel(Handle handle, size_t maxTexels, int* width, int* height,
                              std::vector<Vec3f>* rgb) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return false;
  const Texture& texture = impl_->textures[size_t(handle)];
  if (texture.udim) return false;
  OIIO::ImageCache* cache = impl_->oiio->imagecache();
  const OIIO::ustring path(texture.single.path);
  OIIO::ImageSpec spec;
  int level = 0;
  if (!cache->get_imagespec(path, spec, 0, level)) return false;
  for (OIIO::ImageSpec coarser; size_t(spec.width) * size_t(spec.height) > maxTexels &&
                                cache->get_imagespec(path, coarser, 0, level + 1);) {
    spec = coarser;
    ++level;
  }
  const int channels = texture.single.channels;
  std::vector<float> values(size_t(spec.width) * size_t(spec.height) * size_t(channels));
  OIIO::TextureOpt options;
  if (!impl_->oiio->get_texels(texture.single.handle, nullptr, options, level, spec.x,
                               spec.x + spec.width, spec.y, spec.y + spec.height, 0, 1, 0, channels,
                               OIIO::TypeFloat, values.data()))
    return false;
  rgb->resize(size_t(spec.width) * size_t(spec.height));
  for (size_t i = 0; i < rgb->size(); ++i)
    (*rgb)[i] = toRgb(&values[i * size_t(channels)], channels);
  *width = spec.width;
  *height = spec.height;
  return true;
}

Vec3f TextureSystem::texel(Handle handle, Vec2f uv) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return Vec3f(0.0f);
  const Texture& texture = impl_->textures[size_t(handle)];
  if (texture.udim) return Vec3f(0.0f);
  const Tile& tile = texture.single;
  const int x = tile.x + std::clamp(int(uv.x * float(tile.width)), 0, tile.width - 1);
  const int y = tile.y + std::clamp(int(uv.y * float(tile.height)), 0, tile.height - 1);
  float value[4] = {0, 0, 0, 0};
  OIIO::TextureOpt options;
  OIIO::TextureSystem* oiio = impl_->oiio;
  if (!oiio->get_texels(tile.handle, oiio->get_perthread_info(), options, 0, x, x + 1, y, y + 1, 0,
                        1, 0, tile.channels, OIIO::TypeFloat, value))
    return Vec3f(0.0f);
  return toRgb(value, tile.channels);
}

bool TextureSystem::lookup(Handle handle, TextureWrap wrapS, TextureWrap wrapT,
                           const TextureFootprint& at, float rgba[4]) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return false;
  const Texture& texture = impl_->textures[size_t(handle)];
  float s = at.st.x, t = at.st.y;
  if (!std::isfinite(s) || !std::isfinite(t)) return false;

  OIIO::TextureOpt options;
  options.mipmode = OIIO::TextureOpt::MipModeAniso;
  // Bilinear within a level: interpolating (texel centres give texel values, as in USD's own
  // Storm), where OIIO's bicubic is an approximating B-spline that blurs under magnification.
  options.interpmode = OIIO::TextureOpt::InterpBilinear;
  const Tile* tile = &texture.single;
  if (texture.udim) {
    const float tileS = std::floor(s), tileT = std::floor(t);
    if (tileS < 0.0f || tileS > 9.0f || tileT < 0.0f || tileT > 9.0f) return false;
    tile = &texture.tiles[size_t(tileS) + 10 * size_t(tileT)];
    if (!tile->handle) return false;
    s -= tileS;
    t -= tileT;
    options.swrap = options.twrap = Wrap::WrapClamp;  // no bleeding across tile borders
  } else {
    options.swrap = wrapS == TextureWrap::UseMetadata ? texture.metadataS : toOiio(wrapS);
    options.twrap = wrapT == TextureWrap::UseMetadata ? texture.metadataT : toOiio(wrapT);
  }
  auto finite = [](float value) { return std::isfinite(value) ? value : 0.0f; };
  const float dsdx = finite(at.dstdx.x), dtdx = -finite(at.dstdx.y);
  const float dsdy = finite(at.dstdy.x), dtdy = -finite(at.dstdy.y);

  OIIO::TextureSystem* oiio = impl_->oiio;
  float value[4];
  if (!oiio->texture(tile->handle, oiio->get_perthread_info(), options, s, 1.0f - t, dsdx, dtdx,
                     dsdy, dtdy, tile->channels, value))
    return false;
  switch (tile->channels) {
    case 1:
      rgba[0] = rgba[1] = rgba[2] = value[0];
      rgba[3] = 1.0f;
      break;
    case 2:
      rgba[0] = rgba[1] = rgba[2] = value[0];
      rgba[3] = value[1];
      break;
    case 3:
      rgba[0] = value[0];
      rgba[1] = value[1];
      rgba[2] = value[2];
      rgba[3] = 1.0f;
      break;
    default:
      std::copy(value, value + 4, rgba);
      break;
  }
  return true;
}

}  // namespace penumbra
