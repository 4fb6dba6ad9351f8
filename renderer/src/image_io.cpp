#include "penumbra/image_io.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace OCIO = OCIO_NAMESPACE;
namespace fs = std::filesystem;

namespace penumbra {
namespace {

std::string lowerExtension(const std::string& path) {
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return extension;
}

float srgbEncode(float linear) {
  if (!(linear > 0)) return 0;
  return linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1 / 2.4f) - 0.055f;
}

/// Formats whose files hold colour not premultiplied by alpha (OIIO divides premultiplied
/// input by alpha when it writes them).
bool storesUnassociatedAlpha(const std::string& path) {
  const std::string extension = lowerExtension(path);
  return extension == ".png" || extension == ".tga" || extension == ".tpic" ||
         extension == ".webp" || extension == ".gif";
}

/// Formats that keep no alpha: their pixels are the image over black, in linear light.
bool dropsAlpha(const std::string& path) {
  const std::string extension = lowerExtension(path);
  return extension == ".jpg" || extension == ".jpeg" || extension == ".jpe" || extension == ".jfif";
}

/// Divides (premultiplied = false) or multiplies the colour channels (the first three, those
/// the display transform converts) of pixels with alpha in (0, 1) by their alpha; pixels of
/// alpha 0 or 1 are left as they are.
void setPremultiplied(std::vector<float>& pixels, int channels, int alpha, bool premultiplied) {
  for (size_t i = 0; i < pixels.size(); i += size_t(channels)) {
    const float a = pixels[i + size_t(alpha)];
    if (!(a > 0 && a < 1)) continue;
    for (int c = 0; c < std::min(channels, 3); ++c) {
      if (c == alpha) continue;
      if (premultiplied)
        pixels[i + size_t(c)] *= a;
      else
        pixels[i + size_t(c)] /= a;
    }
  }
}

// The most values (floats) readImage loads: 4 GiB, e.g. a 16k x 16k RGB image; larger ones
// (or headers claiming so) are refused before anything is allocated.
constexpr size_t kMaxReadValues = size_t(1) << 30;

std::string temporaryPathFor(const fs::path& target) {
  static std::atomic<unsigned> counter{0};
  // Keep the extension last: OIIO picks the format from it.
  const std::string name = "." + target.stem().string() + ".tmp" + std::to_string(getpid()) + "-" +
                           std::to_string(counter++) + target.extension().string();
  return (target.parent_path() / name).string();
}

/// An image's size, channel names and metadata (string, int, float and matrix attributes).
ImageData headerOf(const OIIO::ImageSpec& spec) {
  ImageData image;
  image.width = spec.width;
  image.height = spec.height;
  image.channelNames = spec.channelnames;
  for (const OIIO::ParamValue& attribute : spec.extra_attribs) {
    const OIIO::TypeDesc type = attribute.type();
    if (type == OIIO::TypeDesc::STRING)
      image.metadata[attribute.name().string()] = std::string(attribute.get_string());
    else if (type == OIIO::TypeDesc::INT)
      image.metadata[attribute.name().string()] = attribute.get_int();
    else if (type == OIIO::TypeDesc::FLOAT)
      image.metadata[attribute.name().string()] = attribute.get_float();
    else if (type == OIIO::TypeMatrix44) {
      Matrix44 matrix;
      std::copy_n(static_cast<const float*>(attribute.data()), 16, matrix.begin());
      image.metadata[attribute.name().string()] = matrix;
    }
  }
  return image;
}

}  // namespace

void applyDisplayTransform(std::vector<float>& pixels, int width, int height, int channels,
                           const DisplaySettings& display) {
  if (channels < 3 || display.mode == ColorCorrection::Disabled) return;
  if (display.mode == ColorCorrection::SRGB) {
    for (size_t i = 0; i < pixels.size(); i += size_t(channels))
      for (int c = 0; c < 3; ++c) pixels[i + size_t(c)] = srgbEncode(pixels[i + size_t(c)]);
    return;
  }
  try {
    const OCIO::ConstConfigRcPtr config =
        display.ocioConfig.empty() ? OCIO::GetCurrentConfig()
                                   : OCIO::Config::CreateFromFile(display.ocioConfig.c_str());
    const std::string displayName =
        display.display.empty() ? config->getDefaultDisplay() : display.display;
    const std::string viewName =
        display.view.empty() ? config->getDefaultView(displayName.c_str()) : display.view;
    const OCIO::ConstProcessorRcPtr processor =
        config->getProcessor(OCIO::ROLE_SCENE_LINEAR, displayName.c_str(), viewName.c_str(),
                             OCIO::TRANSFORM_DIR_FORWARD);
    const OCIO::ConstCPUProcessorRcPtr cpu = processor->getDefaultCPUProcessor();
    // Only R, G, B are transformed: describe them as strided channels of the interleaved image.
    const ptrdiff_t channelStride = sizeof(float);
    const ptrdiff_t pixelStride = ptrdiff_t(channels) * ptrdiff_t(sizeof(float));
    OCIO::PackedImageDesc description(pixels.data(), width, height, 3, OCIO::BIT_DEPTH_F32,
                                      channelStride, pixelStride, pixelStride * width);
    cpu->apply(description);
  } catch (const OCIO::Exception& error) {
    throw std::runtime_error(std::string("OpenColorIO: ") + error.what());
  }
}

bool isSceneLinearFormat(const std::string& path) {
  const std::string extension = lowerExtension(path);
  return extension == ".exr" || extension == ".hdr";
}

void writeImage(const std::string& path, const ImageData& image, const DisplaySettings& display) {
  const int channels = int(image.channelNames.size());
  if (image.width <= 0 || image.height <= 0 || channels == 0 ||
      image.pixels.size() != size_t(image.width) * size_t(image.height) * size_t(channels))
    throw std::runtime_error(path + ": image data does not match its size and channels");
  if (!image.halfChannels.empty() && image.halfChannels.size() != size_t(channels))
    throw std::runtime_error(path + ": one half/float choice per channel is needed");
  const fs::path target(path);
  if (!target.parent_path().empty() && !fs::is_directory(target.parent_path()))
    throw std::runtime_error(path + ": directory " + target.parent_path().string() +
                             " does not exist");

  const bool linear = isSceneLinearFormat(path);
  std::vector<float> pixels = image.pixels;
  const std::vector<std::string>& names = image.channelNames;
  const auto alphaChannel = std::find(names.begin(), names.end(), "A");
  const int alpha = alphaChannel == names.end() ? -1 : int(alphaChannel - names.begin());
  const bool unassociated = !linear && alpha >= 0 && storesUnassociatedAlpha(path);
  // The display transform applies to colour, not to colour premultiplied by coverage; unless
  // the format drops alpha, whose pixels show the premultiplied colour (the image over black).
  const bool coverageKept = alpha >= 0 && !dropsAlpha(path);
  if (!linear) {
    if (coverageKept) setPremultiplied(pixels, channels, alpha, false);
    try {
      applyDisplayTransform(pixels, image.width, image.height, channels, display);
    } catch (const std::exception& error) {
      throw std::runtime_error(path + ": " + error.what());
    }
    if (coverageKept && !unassociated) setPremultiplied(pixels, channels, alpha, true);
  }
  OIIO::ImageSpec spec(image.width, image.height, channels,
                       linear ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
  spec.channelnames = image.channelNames;
  for (int c = 0; c < channels; ++c) {
    const std::string& name = image.channelNames[size_t(c)];
    if (name == "A") spec.alpha_channel = c;
    if (name == "Z") spec.z_channel = c;
  }
  const bool anyHalf = std::any_of(image.halfChannels.begin(), image.halfChannels.end(),
                                   [](uint8_t half) { return half != 0; });
  if (linear && anyHalf)
    for (const uint8_t half : image.halfChannels)
      spec.channelformats.push_back(half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
  for (const auto& [key, value] : image.metadata) {
    if (const auto* text = std::get_if<std::string>(&value))
      spec.attribute(key, *text);
    else if (const auto* integer = std::get_if<int>(&value))
      spec.attribute(key, *integer);
    else if (const auto* matrix = std::get_if<Matrix44>(&value))
      spec.attribute(key, OIIO::TypeMatrix44, matrix->data());
    else
      spec.attribute(key, std::get<float>(value));
  }
  if (linear) spec.attribute("compression", "zip");
  if (linear && image.displayWidth > 0 && image.displayHeight > 0) {
    spec.x = image.x;
    spec.y = image.y;
    spec.full_x = spec.full_y = 0;
    spec.full_width = image.displayWidth;
    spec.full_height = image.displayHeight;
  }
  // Already un-premultiplied: OIIO must not divide by alpha again (after quantizing).
  if (unassociated) spec.attribute("oiio:UnassociatedAlpha", 1);

  const std::string temporary = temporaryPathFor(target);
  std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path);
  if (!output)
    throw std::runtime_error(path + ": no image format for this extension (" + OIIO::geterror() +
                             ")");
  const auto fail = [&](const std::string& what) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw std::runtime_error(path + ": " + what + ": " + output->geterror());
  };
  if (!output->open(temporary, spec)) fail("cannot open for writing");
  if (!output->write_image(OIIO::TypeDesc::FLOAT, pixels.data())) fail("cannot write pixels");
  if (!output->close()) fail("cannot finish writing");
  std::error_code error;
  fs::rename(temporary, target, error);
  if (error) {
    fs::remove(temporary, error);
    throw std::runtime_error(path + ": cannot rename the finished image into place");
  }
}

ImageData readImageHeader(const std::string& path) {
  std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path);
  if (!input) throw std::runtime_error(path + ": cannot read image: " + OIIO::geterror());
  ImageData header = headerOf(input->spec());
  input->close();
  return header;
}

ImageData readImage(const std::string& path) {
  std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path);
  if (!input) throw std::runtime_error(path + ": cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = input->spec();
  const size_t values = size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels);
  if (values > kMaxReadValues)
    throw std::runtime_error(path + ": the image claims " + std::to_string(spec.width) + "x" +
                             std::to_string(spec.height) + "x" + std::to_string(spec.nchannels) +
                             " values, more than the " + std::to_string(kMaxReadValues >> 30) +
                             " Gi floats Penumbra reads whole");
  ImageData image = headerOf(spec);
  image.pixels.resize(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
  if (!input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data()))
    throw std::runtime_error(path + ": cannot read pixels: " + input->geterror());
  input->close();
  return image;
}

}  // namespace penumbra
