// Colour of textures: textures in a colour space other than scene_linear (sRGB-encoded ones, and
// any colour space of the OCIO config named by MaterialX or USD metadata) are converted to the
// OCIO config's scene_linear role once, while they are prepared (texture_files.h), before any
// filtering (averaging encoded values darkens MIP levels); lookups then read converted texels. A
// colour space that is scene_linear itself, or data, needs no conversion.
#include "texture_color.h"

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

namespace OCIO = OCIO_NAMESPACE;

namespace penumbra {

namespace {

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

}  // namespace

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
  const std::string spaceName = findTextureColorSpace(ocioConfig, name, error);
  if (spaceName.empty()) return false;
  try {
    loadConfig(ocioConfig)
        ->getProcessor(spaceName.c_str(), OCIO::ROLE_SCENE_LINEAR)
        ->getDefaultCPUProcessor()
        ->applyRGB(rgb);
    return true;
  } catch (const OCIO::Exception& exception) {
    *error = "cannot convert \"" + name + "\" to scene-linear: " + exception.what();
    return false;
  }
}

namespace detail {

TextureColorConversions::TextureColorConversions(std::string configPath)
    : configPath_(std::move(configPath)) {}

std::string TextureColorConversions::configName() const {
  return configPath_.empty() ? std::string("$OCIO") : "\"" + configPath_ + "\"";
}

bool TextureColorConversions::loadOcio() {
  if (loaded_) return bool(config_);
  loaded_ = true;
  try {
    config_ = loadConfig(configPath_);
    const auto sceneLinear = config_->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
    if (!sceneLinear) {
      loadError_ = "the OCIO config " + configName() + " has no scene_linear role";
      config_.reset();
      return false;
    }
    sceneLinearSpace_ = sceneLinear->getName();
    for (const char* name : kSrgbNames)
      if (const auto space = config_->getColorSpace(name)) {
        srgbSpace_ = space->getName();
        break;
      }
    double coefficients[3];
    config_->getDefaultLumaCoefs(coefficients);
    for (int i = 0; i < 3; ++i) luma_[i] = float(coefficients[i]);
  } catch (const OCIO::Exception& exception) {
    loadError_ = "cannot read the OCIO config " + configName() + ": " + exception.what();
    config_.reset();
  }
  return bool(config_);
}

bool TextureColorConversions::conversionFrom(const TextureColorSpace& space, std::string* source,
                                             std::string* error) {
  source->clear();
  if (space.name.empty() && space.source != SourceColorSpace::SRGB) return true;
  if (!loadOcio()) {
    *error = loadError_;
    return false;
  }
  if (space.name.empty()) {
    if (srgbSpace_.empty()) {
      *error = "sourceColorSpace sRGB: the OCIO config " + configName() +
               " has no sRGB texture colour space (tried \"sRGB - Texture\", "
               "\"srgb_texture\", \"sRGB\", \"Utility - sRGB - Texture\")";
      return false;
    }
    *source = srgbSpace_;
    return true;
  }
  const auto named = colorSpaceNamed(*config_, space.name);
  if (!named) {
    *error = "the OCIO config " + configName() + " has no colour space \"" + space.name + "\"";
    return false;
  }
  if (!named->isData() && named->getName() != sceneLinearSpace_) *source = named->getName();
  return true;
}

bool TextureColorConversions::processor(const std::string& source,
                                        OCIO::ConstCPUProcessorRcPtr* result, std::string* error) {
  auto& cached = toLinear_[source];
  if (!cached) {
    try {
      cached =
          config_->getProcessor(source.c_str(), OCIO::ROLE_SCENE_LINEAR)->getDefaultCPUProcessor();
    } catch (const OCIO::Exception& exception) {
      *error = "cannot convert \"" + source + "\" to scene_linear with the OCIO config " +
               configName() + ": " + exception.what();
      return false;
    }
  }
  *result = cached;
  return true;
}

RowTransform TextureColorConversions::decoder(
    const OIIO::ImageSpec& spec, const OCIO::ConstCPUProcessorRcPtr& conversion) const {
  std::vector<int> color;
  for (int c = 0; c < std::min(spec.nchannels, 4) && color.size() < 3; ++c)
    if (c != spec.alpha_channel) color.push_back(c);
  if (color.empty()) return {};
  return [color, processor = conversion, luma = std::array<float, 3>{luma_[0], luma_[1], luma_[2]}](
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

}  // namespace detail

}  // namespace penumbra
