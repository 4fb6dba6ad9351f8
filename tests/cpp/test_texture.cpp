// TextureSystem: orientation, wrap modes, colour spaces, filtering, channel rules, UDIM, errors.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "penumbra/light.h"
#include "penumbra/texture.h"
#include "scratch_directory.h"

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

// The project's bundled OCIO config (it carries "sRGB - Texture").
const std::string kBundledConfig = (fs::path(__FILE__).parent_path().parent_path().parent_path() /
                                    "python" / "penumbra" / "ocio" / "config.ocio")
                                       .string();

// 188/255 decoded with the sRGB curve.
constexpr float kLinear188 = 0.50289f;

struct Color {
  float r = 0, g = 0, b = 0, a = 1;
};

class Texture : public penumbra::test::ScratchDirectoryTest {
 protected:
  void SetUp() override {
    ScratchDirectoryTest::SetUp();
    fs::create_directories(directory_ / "tmp");
    // Converted textures go to a temporary directory of our own, to be checked and cleaned up.
    if (const char* tmpdir = std::getenv("TMPDIR")) savedTmpdir_ = tmpdir, hadTmpdir_ = true;
    setenv("TMPDIR", (directory_ / "tmp").c_str(), 1);
  }
  void TearDown() override {
    if (hadTmpdir_)
      setenv("TMPDIR", savedTmpdir_.c_str(), 1);
    else
      unsetenv("TMPDIR");
    ScratchDirectoryTest::TearDown();
  }

  // Writes an image; `pixels` holds rows top (as a viewer sees it) to bottom, channels
  // interleaved, as floats in [0, 1] for integer formats.
  std::string write(const std::string& name, int width, int height, int channels,
                    OIIO::TypeDesc format, const std::vector<float>& pixels,
                    const std::function<void(OIIO::ImageSpec&)>& attributes = {}) const {
    const std::string file = path(name);
    OIIO::ImageSpec spec(width, height, channels, format);
    spec.attribute("oiio:UnassociatedAlpha", 1);  // store colour as given, not divided by alpha
    if (attributes) attributes(spec);
    auto output = OIIO::ImageOutput::create(file);
    EXPECT_TRUE(output) << OIIO::geterror();
    EXPECT_TRUE(output->open(file, spec)) << output->geterror();
    EXPECT_TRUE(output->write_image(OIIO::TypeFloat, pixels.data())) << output->geterror();
    output->close();
    return file;
  }
  std::string constant(const std::string& name, int channels, OIIO::TypeDesc format,
                       const std::vector<float>& value, int size = 4,
                       const std::function<void(OIIO::ImageSpec&)>& attributes = {}) const {
    std::vector<float> pixels;
    for (int i = 0; i < size * size; ++i) pixels.insert(pixels.end(), value.begin(), value.end());
    return write(name, size, size, channels, format, pixels, attributes);
  }
  // 8x8, quadrants as a viewer sees them: red top-left, green top-right, blue bottom-left,
  // white bottom-right.
  std::string quadrants(const std::string& name, OIIO::TypeDesc format) const {
    std::vector<float> pixels;
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const bool top = y < 4, left = x < 4;
        const Color c = top ? (left ? Color{1, 0, 0} : Color{0, 1, 0})
                            : (left ? Color{0, 0, 1} : Color{1, 1, 1});
        pixels.insert(pixels.end(), {c.r, c.g, c.b});
      }
    return write(name, 8, 8, 3, format, pixels);
  }
  // 16x16 float RGBA: R = s and G = t (USD's t, up) at texel centres.
  std::string ramps(const std::string& name,
                    const std::function<void(OIIO::ImageSpec&)>& attributes = {}) const {
    std::vector<float> pixels;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x)
        pixels.insert(pixels.end(), {(x + 0.5f) / 16, 1 - (y + 0.5f) / 16, 0, 1});
    return write(name, 16, 16, 4, OIIO::TypeFloat, pixels, attributes);
  }
  std::vector<fs::path> convertedDirectories() const {
    std::vector<fs::path> found;
    for (const auto& entry : fs::directory_iterator(directory_ / "tmp"))
      if (entry.path().filename().string().rfind("penumbra-textures-", 0) == 0)
        found.push_back(entry.path());
    return found;
  }

  // ramps() as a tiled, MIP-mapped texture (maketx's work), which is read as it is.
  std::string mipmapped(const std::string& name) const {
    const std::string file = path(name);
    OIIO::ImageBuf image(ramps("untiled-" + name));
    OIIO::ImageSpec config;
    config.tile_width = config.tile_height = 8;
    EXPECT_TRUE(
        OIIO::ImageBufAlgo::make_texture(OIIO::ImageBufAlgo::MakeTxTexture, image, file, config))
        << OIIO::geterror();
    return file;
  }

  std::string savedTmpdir_;
  bool hadTmpdir_ = false;
};

TextureFootprint at(float s, float t, float width = 1e-4f) {
  return {{s, t}, {width, 0}, {0, width}};
}

Color lookup(const TextureSystem& textures, TextureSystem::Handle handle, float s, float t,
             TextureWrap wrapS = TextureWrap::Clamp, TextureWrap wrapT = TextureWrap::Clamp,
             float width = 1e-4f) {
  float rgba[4] = {-1, -1, -1, -1};
  EXPECT_TRUE(textures.lookup(handle, wrapS, wrapT, at(s, t, width), rgba))
      << "st (" << s << ", " << t << ")";
  return {rgba[0], rgba[1], rgba[2], rgba[3]};
}

void expectColor(const Color& got, const Color& want, float tolerance, const char* what) {
  EXPECT_NEAR(got.r, want.r, tolerance) << what;
  EXPECT_NEAR(got.g, want.g, tolerance) << what;
  EXPECT_NEAR(got.b, want.b, tolerance) << what;
  EXPECT_NEAR(got.a, want.a, tolerance) << what;
}

}  // namespace

TEST_F(Texture, StOriginIsTheBottomLeftCornerAsAViewerSeesIt) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  for (const auto& [file, space] :
       {std::make_pair(quadrants("q.png", OIIO::TypeUInt8), SourceColorSpace::Raw),
        std::make_pair(quadrants("q.png", OIIO::TypeUInt8), SourceColorSpace::SRGB),
        std::make_pair(quadrants("q.exr", OIIO::TypeHalf), SourceColorSpace::Auto)}) {
    const auto handle = textures.open(file, space, &error);
    ASSERT_NE(handle, TextureSystem::kInvalid) << error;
    expectColor(lookup(textures, handle, 0.25f, 0.9f), {1, 0, 0}, 1e-3f, "upper left: red");
    expectColor(lookup(textures, handle, 0.75f, 0.9f), {0, 1, 0}, 1e-3f, "upper right: green");
    expectColor(lookup(textures, handle, 0.25f, 0.1f), {0, 0, 1}, 1e-3f, "lower left: blue");
    expectColor(lookup(textures, handle, 0.75f, 0.1f), {1, 1, 1}, 1e-3f, "lower right: white");
  }
}

TEST_F(Texture, WrapModesMapToOpenImageIOs) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const auto handle = textures.open(ramps("ramps.exr"), SourceColorSpace::Raw, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  using W = TextureWrap;
  EXPECT_NEAR(lookup(textures, handle, 0.25f, 0.5f).r, 0.25f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 0.25f).g, 0.25f, 1e-4f);
  // s
  EXPECT_NEAR(lookup(textures, handle, 1.25f, 0.5f, W::Repeat).r, 0.25f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, -0.75f, 0.5f, W::Repeat).r, 0.25f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 1.25f, 0.5f, W::Mirror).r, 0.75f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 1.25f, 0.5f, W::Clamp).r, 15.5f / 16, 1e-4f);
  expectColor(lookup(textures, handle, 1.25f, 0.5f, W::Black), {0, 0, 0, 0}, 1e-6f, "black s");
  // t, through the flip to OIIO's t
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 1.25f, W::Clamp, W::Repeat).g, 0.25f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 1.25f, W::Clamp, W::Mirror).g, 0.75f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 0.5f, -0.25f, W::Clamp, W::Mirror).g, 0.25f, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 0.5f, -0.5f, W::Clamp, W::Clamp).g, 0.5f / 16, 1e-4f);
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 1.5f, W::Clamp, W::Clamp).g, 15.5f / 16, 1e-4f);
  expectColor(lookup(textures, handle, 0.5f, 1.25f, W::Clamp, W::Black), {0, 0, 0, 0}, 1e-6f,
              "black t");
}

TEST_F(Texture, UseMetadataReadsTheFilesWrapModesAndFallsBackToBlack) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  using W = TextureWrap;
  const auto oiioModes = textures.open(
      ramps("oiio.exr",
            [](OIIO::ImageSpec& spec) { spec.attribute("wrapmodes", "periodic,mirror"); }),
      SourceColorSpace::Raw, &error);
  ASSERT_NE(oiioModes, TextureSystem::kInvalid) << error;
  const auto usdModes = textures.open(ramps("usd.exr",
                                            [](OIIO::ImageSpec& spec) {
                                              spec.attribute("wrapS", "mirror");
                                              spec.attribute("wrapT", "repeat");
                                            }),
                                      SourceColorSpace::Raw, &error);
  ASSERT_NE(usdModes, TextureSystem::kInvalid) << error;
  const auto none = textures.open(ramps("none.exr"), SourceColorSpace::Raw, &error);
  ASSERT_NE(none, TextureSystem::kInvalid) << error;

  const Color oiio = lookup(textures, oiioModes, 1.25f, 1.25f, W::UseMetadata, W::UseMetadata);
  EXPECT_NEAR(oiio.r, 0.25f, 1e-4f);  // periodic
  EXPECT_NEAR(oiio.g, 0.75f, 1e-4f);  // mirror
  const Color usd = lookup(textures, usdModes, 1.25f, 1.25f, W::UseMetadata, W::UseMetadata);
  EXPECT_NEAR(usd.r, 0.75f, 1e-4f);  // mirror
  EXPECT_NEAR(usd.g, 0.25f, 1e-4f);  // repeat
  // An explicit mode still overrides the metadata.
  EXPECT_NEAR(lookup(textures, oiioModes, 1.25f, 0.5f, W::Clamp, W::UseMetadata).r, 15.5f / 16,
              1e-4f);
  // No metadata: black (UsdPreviewSurface spec), inside the image as is.
  expectColor(lookup(textures, none, 1.25f, 0.5f, W::UseMetadata, W::UseMetadata), {0, 0, 0, 0},
              1e-6f, "no metadata, outside");
  EXPECT_NEAR(lookup(textures, none, 0.25f, 0.5f, W::UseMetadata, W::UseMetadata).r, 0.25f, 1e-4f);
}

TEST_F(Texture, SrgbTexturesAreLinearisedThroughTheConfig) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const float v = 188.0f / 255;
  const std::string rgb = constant("rgb188.png", 3, OIIO::TypeUInt8, {v, v, v});
  const std::string rgba = constant("rgba188.png", 4, OIIO::TypeUInt8, {v, v, v, v});
  for (const auto& [file, space, want] : {std::make_tuple(rgb, SourceColorSpace::SRGB, kLinear188),
                                          std::make_tuple(rgb, SourceColorSpace::Auto, kLinear188),
                                          std::make_tuple(rgb, SourceColorSpace::Raw, v),
                                          std::make_tuple(rgba, SourceColorSpace::Auto, kLinear188),
                                          std::make_tuple(rgba, SourceColorSpace::Raw, v)}) {
    const auto handle = textures.open(file, space, &error);
    ASSERT_NE(handle, TextureSystem::kInvalid) << error;
    const Color c = lookup(textures, handle, 0.5f, 0.5f);
    EXPECT_NEAR(c.r, want, 1e-3f) << file << " " << int(space);
    EXPECT_NEAR(c.g, want, 1e-3f);
    EXPECT_NEAR(c.b, want, 1e-3f);
    // Alpha is never decoded, and colour is not multiplied by it.
    EXPECT_NEAR(c.a, file == rgba ? v : 1.0f, 1e-3f);
  }
}

TEST_F(Texture, AutoFollowsMetadataThenBitDepthAndChannelCount) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const float v = 188.0f / 255;
  auto red = [&](const std::string& file) {
    const auto handle = textures.open(file, SourceColorSpace::Auto, &error);
    EXPECT_NE(handle, TextureSystem::kInvalid) << error;
    return lookup(textures, handle, 0.5f, 0.5f).r;
  };
  // No colour-space metadata: 16-bit, half and float data and 8-bit grey are raw.
  EXPECT_NEAR(red(constant("rgb16.png", 3, OIIO::TypeUInt16, {v, v, v})), v, 1e-4f);
  EXPECT_NEAR(red(constant("rgb16.tif", 3, OIIO::TypeUInt16, {v, v, v})), v, 1e-4f);
  EXPECT_NEAR(red(constant("rgb.exr", 3, OIIO::TypeFloat, {0.5f, 0.5f, 0.5f})), 0.5f, 1e-6f);
  EXPECT_NEAR(red(constant("half.exr", 3, OIIO::TypeHalf, {0.5f, 0.5f, 0.5f})), 0.5f, 1e-6f);
  EXPECT_NEAR(red(constant("grey8.png", 1, OIIO::TypeUInt8, {v})), v, 1e-4f);
  EXPECT_NEAR(red(constant("rgb8.tif", 3, OIIO::TypeUInt8, {v, v, v})), kLinear188, 1e-3f);
  // Metadata wins: an sRGB-tagged grey PNG (sRGB chunk) and a linear-tagged 8-bit RGB PNG.
  EXPECT_NEAR(red(constant("grey8srgb.png", 1, OIIO::TypeUInt8, {v}, 4,
                           [](OIIO::ImageSpec& s) { s.attribute("oiio:ColorSpace", "sRGB"); })),
              kLinear188, 1e-3f);
  EXPECT_NEAR(red(constant("rgb8linear.png", 3, OIIO::TypeUInt8, {v, v, v}, 4,
                           [](OIIO::ImageSpec& s) { s.attribute("oiio:ColorSpace", "linear"); })),
              v, 1e-4f);
  // OpenImageIO's "sRGB" label outside a PNG chunk or JPEG EXIF is no evidence (maketx copies
  // a PNG's default label into every .tx it makes): bits and channels decide, as for Storm.
  EXPECT_NEAR(red(constant("rgb16srgb.tif", 3, OIIO::TypeUInt16, {v, v, v}, 4,
                           [](OIIO::ImageSpec& s) { s.attribute("oiio:ColorSpace", "sRGB"); })),
              v, 1e-4f);
  EXPECT_NEAR(red(constant("grey8srgb.tif", 1, OIIO::TypeUInt8, {v}, 4,
                           [](OIIO::ImageSpec& s) { s.attribute("oiio:ColorSpace", "sRGB"); })),
              v, 1e-4f);
}

TEST_F(Texture, FilteringAveragesTheFootprintInLinearSpace) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  // 256x256 checkerboard of one-texel black and white cells.
  std::vector<float> pixels;
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) {
      const float c = (x + y) % 2 == 0 ? 1.0f : 0.0f;
      pixels.insert(pixels.end(), {c, c, c});
    }
  const std::string file = write("checker.png", 256, 256, 3, OIIO::TypeUInt8, pixels);
  for (const SourceColorSpace space : {SourceColorSpace::SRGB, SourceColorSpace::Raw}) {
    const auto handle = textures.open(file, space, &error);
    ASSERT_NE(handle, TextureSystem::kInvalid) << error;
    // A ~64-texel footprint. Averaging sRGB-encoded values first would give decode(0.5) = 0.214.
    const Color wide =
        lookup(textures, handle, 0.4f, 0.6f, TextureWrap::Repeat, TextureWrap::Repeat, 64.0f / 256);
    EXPECT_NEAR(wide.r, 0.5f, 0.02f) << int(space);
    // A tiny footprint at texel centres gives the texels themselves.
    for (const auto& [x, y] : {std::make_pair(10, 10), std::make_pair(11, 10),
                               std::make_pair(200, 57), std::make_pair(0, 255)}) {
      const float want = (x + y) % 2 == 0 ? 1.0f : 0.0f;
      const Color texel = lookup(textures, handle, (x + 0.5f) / 256, 1 - (y + 0.5f) / 256,
                                 TextureWrap::Repeat, TextureWrap::Repeat, 0.01f / 256);
      EXPECT_NEAR(texel.r, want, 1e-3f) << "texel " << x << "," << y << " space " << int(space);
    }
  }
}

TEST_F(Texture, ChannelsFollowUsdRules) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const auto f = OIIO::TypeFloat;
  const struct {
    int channels;
    std::vector<float> value;
    Color want;
  } cases[] = {{1, {0.3f}, {0.3f, 0.3f, 0.3f, 1}},
               {2, {0.3f, 0.6f}, {0.3f, 0.3f, 0.3f, 0.6f}},
               {3, {0.1f, 0.2f, 0.3f}, {0.1f, 0.2f, 0.3f, 1}},
               {4, {0.1f, 0.2f, 0.3f, 0.4f}, {0.1f, 0.2f, 0.3f, 0.4f}}};
  for (const auto& c : cases) {
    const auto handle =
        textures.open(constant("c" + std::to_string(c.channels) + ".exr", c.channels, f, c.value),
                      SourceColorSpace::Auto, &error);
    ASSERT_NE(handle, TextureSystem::kInvalid) << error;
    EXPECT_EQ(textures.channels(handle), c.channels);
    expectColor(lookup(textures, handle, 0.5f, 0.5f), c.want, 1e-6f, "channel rule");
  }
  // Grey + alpha marked sRGB: the grey is decoded, alpha is not.
  const float v = 188.0f / 255;
  const auto ya =
      textures.open(constant("ya.png", 2, OIIO::TypeUInt8, {v, v}), SourceColorSpace::SRGB, &error);
  ASSERT_NE(ya, TextureSystem::kInvalid) << error;
  EXPECT_EQ(textures.channels(ya), 2);
  expectColor(lookup(textures, ya, 0.5f, 0.5f), {kLinear188, kLinear188, kLinear188, v}, 1e-3f,
              "sRGB grey + alpha");
}

// A cut-out's edge: an opaque texel beside a transparent black one. Read as coverage, colour is
// filtered weighted by alpha, so halfway between them it is the opaque texel's colour at alpha
// one half (read as data: half that colour), magnified and minified, whether the file stores
// colour premultiplied (OpenEXR) or not (PNG, premultiplied when it is prepared).
TEST_F(Texture, CoverageAlphaFiltersColourWeightedByAlpha) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const std::vector<float> edge = {0.8f, 0.4f, 0.2f, 1.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  const std::string png = write("edge.png", 2, 1, 4, OIIO::TypeUInt8, edge);
  const std::string exr = write("edge.exr", 2, 1, 4, OIIO::TypeFloat, edge);
  const std::string greyAlpha = write("edge-ya.png", 2, 1, 2, OIIO::TypeUInt8, {0.8f, 1, 0, 0});
  for (const std::string& file : {png, exr}) {
    const auto data = textures.open(file, SourceColorSpace::Raw, &error);
    const auto coverage =
        textures.open(file, SourceColorSpace::Raw, &error, TextureAlpha::Coverage);
    ASSERT_NE(coverage, TextureSystem::kInvalid) << error;
    EXPECT_NE(data, coverage) << file;
    for (const float width : {1e-4f, 4.0f}) {  // between the texels' centres; the 1x1 level
      expectColor(lookup(textures, data, 0.5f, 0.5f, TextureWrap::Clamp, TextureWrap::Clamp, width),
                  {0.4f, 0.2f, 0.1f, 0.5f}, 2e-3f, "data");
      expectColor(
          lookup(textures, coverage, 0.5f, 0.5f, TextureWrap::Clamp, TextureWrap::Clamp, width),
          {0.8f, 0.4f, 0.2f, 0.5f}, 2e-3f, "coverage");
    }
    // Where only the transparent texel is seen there is no colour: it stays black.
    expectColor(lookup(textures, coverage, 0.9f, 0.5f), {0, 0, 0, 0}, 1e-6f, "transparent");
  }
  const auto ya = textures.open(greyAlpha, SourceColorSpace::Raw, &error, TextureAlpha::Coverage);
  ASSERT_NE(ya, TextureSystem::kInvalid) << error;
  expectColor(lookup(textures, ya, 0.5f, 0.5f), {0.8f, 0.8f, 0.8f, 0.5f}, 2e-3f, "grey + alpha");
  // sRGB colour is decoded before it is weighted: 188/255 at the edge, not its weighted code.
  const std::string srgb =
      write("edge-srgb.png", 2, 1, 4, OIIO::TypeUInt8, {188.0f / 255, 0, 0, 1, 0, 0, 0, 0});
  const auto decoded = textures.open(srgb, SourceColorSpace::SRGB, &error, TextureAlpha::Coverage);
  ASSERT_NE(decoded, TextureSystem::kInvalid) << error;
  EXPECT_NEAR(lookup(textures, decoded, 0.5f, 0.5f).r, kLinear188, 2e-3f);
  // Without alpha, coverage changes nothing.
  const std::string opaque = constant("opaque.exr", 3, OIIO::TypeFloat, {0.3f, 0.2f, 0.1f});
  const auto plain = textures.open(opaque, SourceColorSpace::Raw, &error, TextureAlpha::Coverage);
  expectColor(lookup(textures, plain, 0.5f, 0.5f), {0.3f, 0.2f, 0.1f, 1.0f}, 1e-6f, "no alpha");
}

// A texture repainted between two renders is read again, under the same handle; one removed
// gives no texel (its fallback) and names its file.
TEST_F(Texture, RepaintedFilesAreReadAgain) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const std::string file = constant("paint.png", 3, OIIO::TypeUInt8, {0.2f, 0.2f, 0.2f});
  const auto handle = textures.open(file, SourceColorSpace::Raw, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  std::vector<std::string> errors;
  EXPECT_EQ(textures.reloadChangedFiles(&errors), 0u);  // nothing changed
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 0.5f).r, 0.2f, 2e-3f);
  constant("paint.png", 3, OIIO::TypeUInt8, {0.8f, 0.8f, 0.8f});
  // A later time than the first write's, whatever the file system's clock resolution.
  fs::last_write_time(file, fs::last_write_time(file) + std::chrono::seconds(2));
  EXPECT_EQ(textures.reloadChangedFiles(&errors), 1u);
  EXPECT_TRUE(errors.empty());
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 0.5f).r, 0.8f, 2e-3f);
  EXPECT_EQ(textures.open(file, SourceColorSpace::Raw, &error), handle);
  fs::remove(file);
  EXPECT_EQ(textures.reloadChangedFiles(&errors), 1u);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find(file), std::string::npos) << errors[0];
  float rgba[4];
  EXPECT_FALSE(
      textures.lookup(handle, TextureWrap::Clamp, TextureWrap::Clamp, at(0.5f, 0.5f, 1e-4f), rgba));
  EXPECT_EQ(textures.reloadChangedFiles(&errors), 0u);  // not retried until it changes again
}

TEST_F(Texture, UdimTilesAreChosenByStAndMissingTilesHaveNoTexel) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  quadrants("tile.1001.png", OIIO::TypeUInt8);  // 8-bit RGB: sRGB under auto, converted
  constant("tile.1002.exr", 3, OIIO::TypeFloat, {0, 1, 0});
  constant("tile.1011.exr", 3, OIIO::TypeFloat, {0, 0, 1});
  constant("tile.1011.png", 3, OIIO::TypeUInt8, {0.5f, 0.5f, 0.5f});
  const auto pngs = textures.open(path("tile.<UDIM>.png"), SourceColorSpace::Auto, &error);
  ASSERT_NE(pngs, TextureSystem::kInvalid) << error;
  const auto exrs = textures.open(path("tile.<UDIM>.exr"), SourceColorSpace::Auto, &error);
  ASSERT_NE(exrs, TextureSystem::kInvalid) << error;
  EXPECT_EQ(textures.channels(exrs), 3);

  // Inside tile 1001 the usual orientation holds.
  expectColor(lookup(textures, pngs, 0.25f, 0.9f), {1, 0, 0}, 1e-3f, "1001 upper left");
  expectColor(lookup(textures, pngs, 0.75f, 0.1f), {1, 1, 1}, 1e-3f, "1001 lower right");
  // 1011 is one row up (t in [1, 2)); its 8-bit 0.5 is decoded per tile.
  const float linearHalf = std::pow((128.0f / 255 + 0.055f) / 1.055f, 2.4f);
  EXPECT_NEAR(lookup(textures, pngs, 0.5f, 1.5f).r, linearHalf, 1e-3f);

  expectColor(lookup(textures, exrs, 1.5f, 0.5f), {0, 1, 0}, 1e-6f, "1002");
  expectColor(lookup(textures, exrs, 0.5f, 1.5f), {0, 0, 1}, 1e-6f, "1011");
  expectColor(lookup(textures, exrs, 1.99f, 0.01f), {0, 1, 0}, 1e-6f, "1002 corner");
  for (const auto& [s, t] :
       {std::make_pair(2.5f, 0.5f), std::make_pair(1.5f, 1.5f), std::make_pair(-0.5f, 0.5f),
        std::make_pair(0.5f, -0.5f), std::make_pair(10.5f, 0.5f), std::make_pair(0.5f, 10.5f)}) {
    float rgba[4] = {7, 7, 7, 7};
    EXPECT_FALSE(textures.lookup(exrs, TextureWrap::Repeat, TextureWrap::Repeat, at(s, t), rgba))
        << s << ", " << t;
    EXPECT_EQ(rgba[0], 7.0f);
    EXPECT_EQ(rgba[3], 7.0f);
  }

  const std::string pattern = path("nothing.<UDIM>.exr");
  EXPECT_EQ(textures.open(pattern, SourceColorSpace::Auto, &error), TextureSystem::kInvalid);
  EXPECT_NE(error.find(pattern), std::string::npos) << error;
}

TEST_F(Texture, FailuresReturnInvalidAndNameTheFile) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const std::string missing = path("missing.png");
  EXPECT_EQ(textures.open(missing, SourceColorSpace::Auto, &error), TextureSystem::kInvalid);
  EXPECT_NE(error.find(missing), std::string::npos) << error;

  const std::string garbage = path("garbage.png");
  std::ofstream(garbage) << "this is not a PNG file";
  error.clear();
  EXPECT_EQ(textures.open(garbage, SourceColorSpace::Raw, &error), TextureSystem::kInvalid);
  EXPECT_NE(error.find(garbage), std::string::npos) << error;

  float rgba[4] = {7, 7, 7, 7};
  EXPECT_FALSE(textures.lookup(TextureSystem::kInvalid, TextureWrap::Clamp, TextureWrap::Clamp,
                               at(0.5f, 0.5f), rgba));
  EXPECT_FALSE(textures.lookup(42, TextureWrap::Clamp, TextureWrap::Clamp, at(0.5f, 0.5f), rgba));
  EXPECT_EQ(rgba[0], 7.0f);
  EXPECT_EQ(textures.channels(TextureSystem::kInvalid), 0);

  // A config without an sRGB texture space cannot linearise: named file, no crash; raw still works.
  const std::string config = path("config.ocio");
  std::ofstream(config) << R"(ocio_profile_version: 2
roles:
  default: linear
  scene_linear: linear
displays:
  d:
    - !<View> {name: v, colorspace: linear}
colorspaces:
  - !<ColorSpace>
    name: linear
)";
  TextureSystem noSrgb(config);
  const std::string png = constant("rgb.png", 3, OIIO::TypeUInt8, {0.5f, 0.5f, 0.5f});
  error.clear();
  EXPECT_EQ(noSrgb.open(png, SourceColorSpace::SRGB, &error), TextureSystem::kInvalid);
  EXPECT_NE(error.find(png), std::string::npos) << error;
  EXPECT_NE(error.find("sRGB"), std::string::npos) << error;
  EXPECT_NE(noSrgb.open(png, SourceColorSpace::Raw, &error), TextureSystem::kInvalid) << error;
}

TEST_F(Texture, TheSamePathAndColorSpaceGiveTheSameHandle) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const std::string file = constant("rgb.png", 3, OIIO::TypeUInt8, {0.5f, 0.5f, 0.5f});
  const auto first = textures.open(file, SourceColorSpace::SRGB, &error);
  ASSERT_NE(first, TextureSystem::kInvalid) << error;
  EXPECT_EQ(textures.open(file, SourceColorSpace::SRGB, &error), first);
  const auto raw = textures.open(file, SourceColorSpace::Raw, &error);
  EXPECT_NE(raw, first);
  EXPECT_EQ(textures.open(file, SourceColorSpace::Raw, &error), raw);
}

// MaterialX's AP1 → linear Rec.709 matrix (cmlib's ND_acescg_to_lin_rec709), for column vectors.
constexpr float kAp1ToRec709[3][3] = {{1.705050992658f, -0.621792120657f, -0.083258872001f},
                                      {-0.130256417507f, 1.140804736575f, -0.010548319068f},
                                      {-0.024003356805f, -0.128968976065f, 1.15297233287f}};

Color fromAp1(float r, float g, float b) {
  const float in[3] = {r, g, b};
  float out[3];
  for (int i = 0; i < 3; ++i)
    out[i] = kAp1ToRec709[i][0] * in[0] + kAp1ToRec709[i][1] * in[1] + kAp1ToRec709[i][2] * in[2];
  return {out[0], out[1], out[2], 1.0f};
}

TEST_F(Texture, NamedColourSpacesAreConvertedToSceneLinearOnce) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  // ACEScg under MaterialX's name, its alias and the Color Interop Forum's: the matrix.
  const std::string ap1 = constant("ap1.exr", 3, OIIO::TypeFloat, {0.2f, 0.5f, 0.8f});
  const Color want = fromAp1(0.2f, 0.5f, 0.8f);
  TextureSystem::Handle acescg = TextureSystem::kInvalid;
  for (const char* name : {"acescg", "lin_ap1", "lin_ap1_scene", "ACEScg"}) {
    const auto handle = textures.open(ap1, TextureColorSpace::named(name), &error);
    ASSERT_NE(handle, TextureSystem::kInvalid) << error;
    expectColor(lookup(textures, handle, 0.5f, 0.5f), want, 1e-5f, name);
    if (acescg == TextureSystem::kInvalid) acescg = handle;
  }
  // The same file raw is another texture, unconverted.
  const auto raw = textures.open(ap1, SourceColorSpace::Raw, &error);
  EXPECT_NE(raw, acescg);
  expectColor(lookup(textures, raw, 0.5f, 0.5f), {0.2f, 0.5f, 0.8f, 1.0f}, 1e-6f, "raw");

  // Pure power encodings on 8-bit data (prepared as half: 1e-3), colour and grey; alpha kept.
  const float v = 188.0f / 255;
  const std::string rgba = constant("g22.png", 4, OIIO::TypeUInt8, {v, v, v, v});
  const std::string grey = constant("g18.png", 1, OIIO::TypeUInt8, {v});
  const auto g22 = textures.open(rgba, TextureColorSpace::named("g22_rec709"), &error);
  ASSERT_NE(g22, TextureSystem::kInvalid) << error;
  const float p22 = std::pow(v, 2.2f);
  expectColor(lookup(textures, g22, 0.5f, 0.5f), {p22, p22, p22, v}, 1e-3f, "g22_rec709");
  const auto g18 = textures.open(grey, TextureColorSpace::named("g18_rec709"), &error);
  ASSERT_NE(g18, TextureSystem::kInvalid) << error;
  const float p18 = std::pow(v, 1.8f);
  expectColor(lookup(textures, g18, 0.5f, 0.5f), {p18, p18, p18, 1.0f}, 1e-3f, "g18_rec709");
  // A power encoding in AP1: the power, then the matrix.
  const auto g22ap1 = textures.open(rgba, TextureColorSpace::named("g22_ap1"), &error);
  ASSERT_NE(g22ap1, TextureSystem::kInvalid) << error;
  Color ap1Want = fromAp1(p22, p22, p22);
  ap1Want.a = v;
  expectColor(lookup(textures, g22ap1, 0.5f, 0.5f), ap1Want, 2e-3f, "g22_ap1");
  // srgb_texture by name is sourceColorSpace sRGB, bit for bit.
  const auto named = textures.open(rgba, TextureColorSpace::named("srgb_texture"), &error);
  const auto srgb = textures.open(rgba, SourceColorSpace::SRGB, &error);
  const Color a = lookup(textures, named, 0.5f, 0.5f), b = lookup(textures, srgb, 0.5f, 0.5f);
  EXPECT_EQ(std::memcmp(&a, &b, sizeof a), 0);
  EXPECT_NEAR(a.r, kLinear188, 1e-3f);
}

TEST_F(Texture, SceneLinearAndDataColourSpacesNeedNoConversion) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const std::string file = mipmapped("ready.exr");
  for (const char* name : {"lin_rec709", "scene_linear", "raw", "data"})
    EXPECT_NE(textures.open(file, TextureColorSpace::named(name), &error), TextureSystem::kInvalid)
        << error;
  EXPECT_TRUE(convertedDirectories().empty()) << "a tiled, MIP-mapped file was copied";
  // Converting one reads its tiles (into a prepared copy).
  const auto acescg = textures.open(file, TextureColorSpace::named("acescg"), &error);
  ASSERT_NE(acescg, TextureSystem::kInvalid) << error;
  EXPECT_EQ(convertedDirectories().size(), 1u);
  const Vec3f texel = textures.texel(acescg, {3.5f / 16, 5.5f / 16});  // ramps(): x 3, y 5
  const Color want = fromAp1(3.5f / 16, 1 - 5.5f / 16, 0);
  EXPECT_NEAR(texel.x, want.r, 1e-5f);
  EXPECT_NEAR(texel.y, want.g, 1e-5f);
  EXPECT_NEAR(texel.z, want.b, 1e-5f);
}

TEST_F(Texture, AnUnknownColourSpaceNameIsAnErrorNamingFileAndName) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const std::string file = constant("rgb.exr", 3, OIIO::TypeFloat, {0.5f, 0.5f, 0.5f});
  EXPECT_EQ(textures.open(file, TextureColorSpace::named("no_such_space"), &error),
            TextureSystem::kInvalid);
  EXPECT_NE(error.find(file), std::string::npos) << error;
  EXPECT_NE(error.find("no_such_space"), std::string::npos) << error;
  EXPECT_EQ(findTextureColorSpace(kBundledConfig, "no_such_space", &error), "");
  EXPECT_NE(error.find("no_such_space"), std::string::npos) << error;
  float rgb[3] = {0.5f, 0.5f, 0.5f};
  EXPECT_FALSE(convertToSceneLinear(kBundledConfig, "no_such_space", rgb));
  EXPECT_EQ(rgb[0], 0.5f);
}

TEST_F(Texture, MaterialxNamesAreFoundInTheBundledConfigAndThroughInteropAliases) {
  // Every colour space of MaterialX's specification (cmlib) is in the bundled config.
  for (const char* name : {"srgb_texture", "lin_rec709", "g22_rec709", "g18_rec709",
                           "rec709_display", "acescg", "lin_ap1", "g22_ap1", "g18_ap1",
                           "lin_adobergb", "adobergb", "lin_displayp3", "srgb_displayp3"})
    EXPECT_NE(findTextureColorSpace(kBundledConfig, name), "") << name;
  // Constants convert like textures: Display P3 white stays white, lin_rec709 is unchanged.
  float white[3] = {1, 1, 1};
  ASSERT_TRUE(convertToSceneLinear(kBundledConfig, "srgb_displayp3", white));
  for (float c : white) EXPECT_NEAR(c, 1.0f, 1e-4f);
  float same[3] = {0.25f, 0.5f, 0.75f};
  ASSERT_TRUE(convertToSceneLinear(kBundledConfig, "lin_rec709", same));
  EXPECT_EQ(same[2], 0.75f);
  // A config with only the Color Interop Forum's identifiers (as recent ACES configs carry)
  // still serves MaterialX's names.
  const std::string config = path("interop.ocio");
  std::ofstream(config) << R"(ocio_profile_version: 2.1
roles:
  default: Linear Rec.709 (sRGB)
  scene_linear: Linear Rec.709 (sRGB)
displays:
  d:
    - !<View> {name: v, colorspace: Linear Rec.709 (sRGB)}
colorspaces:
  - !<ColorSpace>
    name: Linear Rec.709 (sRGB)
    aliases: [lin_rec709_scene]
  - !<ColorSpace>
    name: ACEScg
    aliases: [lin_ap1_scene]
    to_scene_reference: !<MatrixTransform> {matrix: [1.705050992658, -0.621792120657, -0.083258872001, 0, -0.130256417507, 1.140804736575, -0.010548319068, 0, -0.024003356805, -0.128968976065, 1.15297233287, 0, 0, 0, 0, 1]}
)";
  EXPECT_EQ(findTextureColorSpace(config, "acescg"), "ACEScg");
  EXPECT_EQ(findTextureColorSpace(config, "lin_rec709"), "Linear Rec.709 (sRGB)");
  EXPECT_EQ(findTextureColorSpace(config, "g22_rec709"), "");
  TextureSystem textures(config);
  std::string error;
  const auto handle = textures.open(constant("ap1.exr", 3, OIIO::TypeFloat, {0.2f, 0.5f, 0.8f}),
                                    TextureColorSpace::named("lin_ap1"), &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  expectColor(lookup(textures, handle, 0.5f, 0.5f), fromAp1(0.2f, 0.5f, 0.8f), 1e-5f, "interop");
}

TEST_F(Texture, TheDestructorRemovesTheConvertedTextures) {
  {
    TextureSystem textures(kBundledConfig);
    std::string error;
    ASSERT_NE(textures.open(mipmapped("raw.exr"), SourceColorSpace::Raw, &error),
              TextureSystem::kInvalid)
        << error;
    EXPECT_TRUE(convertedDirectories().empty());  // created on first need only
  }
  std::vector<fs::path> directories;
  {
    TextureSystem textures(kBundledConfig);
    std::string error;
    const auto handle =
        textures.open(quadrants("q.png", OIIO::TypeUInt8), SourceColorSpace::SRGB, &error);
    ASSERT_NE(handle, TextureSystem::kInvalid) << error;
    lookup(textures, handle, 0.5f, 0.5f);
    directories = convertedDirectories();
    ASSERT_EQ(directories.size(), 1u);
    EXPECT_FALSE(fs::is_empty(directories[0]));
  }
  EXPECT_FALSE(fs::exists(directories[0]));
}

TEST_F(Texture, LookupsAreDeterministicAcrossCallsAndThreads) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  std::vector<float> pixels;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      pixels.insert(pixels.end(),
                    {float((x * 7 + y * 13) % 256) / 255, float(x) / 63, float(y) / 63});
  const auto handle = textures.open(write("noise.png", 64, 64, 3, OIIO::TypeUInt8, pixels),
                                    SourceColorSpace::Auto, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  auto run = [&](std::vector<float>* out) {
    for (int i = 0; i < 2000; ++i) {
      const float s = 0.37f * i - std::floor(0.37f * i), t = 0.61f * i - std::floor(0.61f * i);
      const float width = 1e-3f * float(1 + i % 50);
      const TextureFootprint footprint{{s, t}, {width, 0.3f * width}, {-0.2f * width, width}};
      float rgba[4];
      EXPECT_TRUE(
          textures.lookup(handle, TextureWrap::Repeat, TextureWrap::Mirror, footprint, rgba));
      out->insert(out->end(), rgba, rgba + 4);
    }
  };
  std::vector<float> once, twice, threadA, threadB;
  run(&once);
  run(&twice);
  std::thread a(run, &threadA), b(run, &threadB);
  a.join();
  b.join();
  ASSERT_EQ(once.size(), twice.size());
  EXPECT_EQ(std::memcmp(once.data(), twice.data(), once.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(once.data(), threadA.data(), once.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(once.data(), threadB.data(), once.size() * sizeof(float)), 0);
}

TEST_F(Texture, APoolThreadLooksUpInOneSystemAfterAnotherWasDestroyed) {
  // A render's pool threads outlive the scenes they render. OIIO 2.4 keeps the per-thread
  // records it makes itself under the address of the cache; a system made where a destroyed
  // one was would give a pool thread its stale record, whose tiles are freed. Each system here
  // is made right after the last one is destroyed, and one long-lived thread looks up in each.
  std::vector<float> pixels;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) pixels.insert(pixels.end(), {float(x) / 31, float(y) / 31, 0.5f});
  const std::string file = write("ramp.png", 32, 32, 3, OIIO::TypeUInt8, pixels);
  std::mutex mutex;
  std::condition_variable changed;
  const TextureSystem* textures = nullptr;
  TextureSystem::Handle handle = TextureSystem::kInvalid;
  int posted = 0, finished = 0;
  std::vector<float> pooled;
  const auto lookUp = [&](const TextureSystem& system, std::vector<float>* out) {
    out->clear();
    for (int i = 0; i < 200; ++i) {
      const float s = 0.37f * float(i) - std::floor(0.37f * float(i));
      const TextureFootprint footprint{{s, 1 - s}, {0.01f, 0}, {0, 0.01f}};
      float rgba[4] = {};
      system.lookup(handle, TextureWrap::Repeat, TextureWrap::Repeat, footprint, rgba);
      out->insert(out->end(), rgba, rgba + 4);
    }
  };
  std::thread pool([&] {
    for (int done = 0;; ++done) {
      std::unique_lock<std::mutex> lock(mutex);
      changed.wait(lock, [&] { return posted > done; });
      if (!textures) return;
      lock.unlock();
      lookUp(*textures, &pooled);
      lock.lock();
      finished = done + 1;
      changed.notify_all();
    }
  });
  // Failures are recorded, not asserted: the pool thread must be joined whatever happens.
  for (int round = 0; round < 12; ++round) {
    auto system = std::make_unique<TextureSystem>(kBundledConfig);
    std::string error;
    handle = system->open(file, SourceColorSpace::Raw, &error);
    if (handle == TextureSystem::kInvalid) {
      ADD_FAILURE() << error;
      break;
    }
    std::vector<float> own;
    lookUp(*system, &own);
    {
      std::unique_lock<std::mutex> lock(mutex);
      textures = system.get();
      ++posted;
      changed.notify_all();
      changed.wait(lock, [&] { return finished == posted; });
    }
    EXPECT_TRUE(pooled.size() == own.size() &&
                std::memcmp(pooled.data(), own.data(), own.size() * sizeof(float)) == 0)
        << "round " << round;
  }
  {
    std::lock_guard<std::mutex> lock(mutex);
    textures = nullptr;
    ++posted;
  }
  changed.notify_all();
  pool.join();
}

TEST_F(Texture, TheSrgbSpaceIsFoundUnderOtherConfigsNames) {
  // An ACES-style config: the sRGB texture space under its ACES 1.x name only.
  const std::string config = path("aces.ocio");
  std::ofstream(config) << R"(ocio_profile_version: 2
roles:
  default: lin
  scene_linear: lin
displays:
  d:
    - !<View> {name: v, colorspace: lin}
colorspaces:
  - !<ColorSpace>
    name: lin
  - !<ColorSpace>
    name: Utility - sRGB - Texture
    from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, direction: inverse}
)";
  TextureSystem textures(config);
  std::string error;
  const float v = 188.0f / 255;
  const auto handle = textures.open(constant("rgb.png", 3, OIIO::TypeUInt8, {v, v, v}),
                                    SourceColorSpace::SRGB, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  EXPECT_NEAR(lookup(textures, handle, 0.5f, 0.5f).g, kLinear188, 1e-3f);
}

// A 5x3 image (odd sizes: every coarser texel straddles input texels) is prepared into levels
// 2x1 and 1x1, each texel the area-weighted mean of the texels under it; level 0 is unchanged.
TEST_F(Texture, PreparedMipLevelsAreAreaWeightedMeans) {
  std::vector<float> pixels;
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) pixels.push_back(float(x + 5 * y));
  TextureSystem textures(kBundledConfig);
  std::string error;
  const auto handle = textures.open(write("odd.exr", 5, 3, 1, OIIO::TypeFloat, pixels),
                                    SourceColorSpace::Raw, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  int width = 0, height = 0;
  ASSERT_TRUE(textures.resolution(handle, &width, &height));
  EXPECT_EQ(width, 5);
  EXPECT_EQ(height, 3);

  std::vector<Vec3f> level;
  ASSERT_TRUE(textures.readLevel(handle, 15, &width, &height, &level));
  ASSERT_EQ(width * height, 15);
  for (size_t i = 0; i < level.size(); ++i) EXPECT_EQ(level[i].x, float(i));

  // Level 1 is 2x1: columns [0, 2.5) and [2.5, 5) of all three rows.
  ASSERT_TRUE(textures.readLevel(handle, 2, &width, &height, &level));
  ASSERT_EQ(width, 2);
  ASSERT_EQ(height, 1);
  const auto mean = [&](float x0, float x1) {
    double sum = 0, area = 0;
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 5; ++x) {
        const double overlap = std::max(0.0, std::min<double>(x + 1, x1) - std::max<double>(x, x0));
        sum += overlap * pixels[size_t(x + 5 * y)];
        area += overlap;
      }
    return float(sum / area);
  };
  EXPECT_NEAR(level[0].x, mean(0, 2.5f), 1e-5f);
  EXPECT_NEAR(level[1].x, mean(2.5f, 5), 1e-5f);
  ASSERT_TRUE(textures.readLevel(handle, 1, &width, &height, &level));
  ASSERT_EQ(width * height, 1);
  EXPECT_NEAR(level[0].x, 7.0f, 1e-5f);  // the mean of 0..14
}

// texel(): the nearest full-resolution texel, uv from the top-left corner, clamped; sRGB files
// come back decoded.
TEST_F(Texture, TexelReadsTheNearestFullResolutionTexel) {
  TextureSystem textures(kBundledConfig);
  std::string error;
  const auto handle =
      textures.open(quadrants("q.png", OIIO::TypeUInt8), SourceColorSpace::Raw, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  const Vec3f topLeft = textures.texel(handle, {0.1f, 0.1f});
  const Vec3f bottomLeft = textures.texel(handle, {0.49f, 0.51f});
  const Vec3f outside = textures.texel(handle, {2.0f, -1.0f});  // clamped: the top-right texel
  EXPECT_EQ(topLeft.x, 1.0f);
  EXPECT_EQ(topLeft.y, 0.0f);
  EXPECT_EQ(bottomLeft.z, 1.0f);
  EXPECT_EQ(bottomLeft.x, 0.0f);
  EXPECT_EQ(outside.y, 1.0f);
  EXPECT_EQ(outside.x, 0.0f);

  const auto srgb =
      textures.open(constant("grey.png", 3, OIIO::TypeUInt8, std::vector<float>(3, 188.0f / 255)),
                    SourceColorSpace::SRGB, &error);
  ASSERT_NE(srgb, TextureSystem::kInvalid) << error;
  EXPECT_NEAR(textures.texel(srgb, {0.5f, 0.5f}).y, kLinear188, 1e-3f);
}

TEST_F(Texture, TheCacheSizeIsASettingWithAFloor) {
  TextureSystem textures(kBundledConfig);
  EXPECT_EQ(textures.cacheSize(), TextureSystem::kDefaultCacheBytes);
  textures.setCacheSize(size_t(64) << 20);
  EXPECT_EQ(textures.cacheSize(), size_t(64) << 20);
  textures.setCacheSize(1);
  EXPECT_EQ(textures.cacheSize(), size_t(16) << 20);
}

// A lat-long texture larger than a light's distribution keeps only a MIP level in memory; its
// lookups still see every full-resolution texel, and its average and sampling follow the image.
TEST_F(Texture, LargeLightTexturesAreSampledFromAMipLevelAndLookedUpInFull) {
  const int width = 4096, height = 1024;  // 4 Mi texels: the distribution is the 2048x512 level
  std::vector<float> pixels(size_t(width) * height * 3, 0.25f);
  const int spotX = 1001, spotY = 301;  // one bright texel
  for (int c = 0; c < 3; ++c) pixels[(size_t(spotY) * width + spotX) * 3 + c] = 4096.0f;
  auto textures = std::make_shared<TextureSystem>(kBundledConfig);
  const auto light = LightTexture::load(
      textures, write("sky.exr", width, height, 3, OIIO::TypeFloat, pixels), /*latLong=*/true);

  const Vec2f spot{(spotX + 0.5f) / width, (spotY + 0.5f) / height};
  EXPECT_EQ(light->lookup(spot).x, 4096.0f);
  EXPECT_EQ(light->lookup({spot.x + 1.0f / width, spot.y}).x, 0.25f);
  // The bright texel's coarse cell is sampled (4096 / 4 + 0.25 * 3 / 4) / 0.25 times as often
  // as a dim cell of its row.
  const float ratio =
      light->distribution().density(spot) / light->distribution().density({spot.x + 0.25f, spot.y});
  EXPECT_NEAR(ratio, (4096.0f / 4 + 0.75f * 0.25f) / 0.25f, 1.0f);
  // The mean over solid angle: the background plus the spot's share of it (its row's weight).
  const double rowSine = std::sin(M_PI * (spotY / 2 + 0.5) / (height / 2));
  const double weights = [&] {
    double sum = 0;
    for (int y = 0; y < height / 2; ++y) sum += std::sin(M_PI * (y + 0.5) / (height / 2));
    return sum * (width / 2);
  }();
  const double expected = 0.25 + (4096.0 - 0.25) / 4 * rowSine / weights;
  EXPECT_NEAR(light->average().x, expected, 1e-4 * expected);
}

TEST_F(Texture, LookupsOfAFileBrokenPastItsHeaderFailAndAreReportedOnce) {
  // A tiled, MIP-mapped file is read as it is, tile by tile as lookups need them: one cut short
  // opens, and only its lookups find what is missing.
  const std::string file = mipmapped("cut.exr");
  const auto size = fs::file_size(file);
  fs::resize_file(file, size / 2);
  TextureSystem textures(kBundledConfig);
  std::string error;
  const auto handle = textures.open(file, SourceColorSpace::Raw, &error);
  ASSERT_NE(handle, TextureSystem::kInvalid) << error;
  EXPECT_TRUE(textures.takeLookupFailures().empty());
  bool failed = false;
  for (float s = 0.05f; s < 1; s += 0.1f)
    for (float t = 0.05f; t < 1; t += 0.1f) {
      float rgba[4];
      failed = failed ||
               !textures.lookup(handle, TextureWrap::Clamp, TextureWrap::Clamp, at(s, t), rgba);
    }
  ASSERT_TRUE(failed);
  const std::vector<std::string> reported = textures.takeLookupFailures();
  ASSERT_EQ(reported.size(), 1u);
  EXPECT_EQ(reported[0].rfind(file + ": the texture cannot be read (", 0), 0u) << reported[0];
  EXPECT_EQ(reported[0].find('\n'), std::string::npos) << reported[0];
  float rgba[4];
  textures.lookup(handle, TextureWrap::Clamp, TextureWrap::Clamp, at(0.95f, 0.05f), rgba);
  EXPECT_TRUE(textures.takeLookupFailures().empty());  // once per file
}
