#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "penumbra/image_io.h"
#include "scratch_directory.h"

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

class ImageIO : public penumbra::test::ScratchDirectoryTest {
 protected:
  size_t fileCount() const {
    return size_t(std::distance(fs::directory_iterator(directory_), fs::directory_iterator()));
  }
};

ImageData gradient() {
  ImageData image;
  image.width = 5;
  image.height = 3;
  image.channelNames = {"R", "G", "B", "A", "Z"};
  for (int i = 0; i < 15; ++i)
    for (float value : {i * 0.1f, 0.5f, 1.7f, 1.0f, 3.25f + i}) image.pixels.push_back(value);
  image.metadata = {{"penumbra:camera", std::string("/cam")},
                    {"penumbra:samples", 64},
                    {"penumbra:renderTime", 1.5f}};
  return image;
}

}  // namespace

TEST_F(ImageIO, ExrRoundTripsFloatsAndMetadataExactly) {
  const ImageData written = gradient();
  writeImage(path("out.exr"), written, {});
  const ImageData read = readImage(path("out.exr"));
  EXPECT_EQ(read.width, 5);
  EXPECT_EQ(read.height, 3);
  EXPECT_EQ(read.channelNames, written.channelNames);
  EXPECT_EQ(read.pixels, written.pixels);
  EXPECT_EQ(std::get<std::string>(read.metadata.at("penumbra:camera")), "/cam");
  EXPECT_EQ(std::get<int>(read.metadata.at("penumbra:samples")), 64);
  EXPECT_EQ(std::get<float>(read.metadata.at("penumbra:renderTime")), 1.5f);
  EXPECT_EQ(fileCount(), 1u);  // no temporary left behind
}

TEST_F(ImageIO, PngGoesThroughTheDisplayTransform) {
  ImageData image;
  image.width = image.height = 1;
  image.channelNames = {"R", "G", "B", "A"};
  image.pixels = {0.5f, 0.0f, 0.0031308f, 1.0f};
  writeImage(path("srgb.png"), image, {ColorCorrection::SRGB, "", "", ""});
  const ImageData srgb = readImage(path("srgb.png"));
  // sRGB encodes 0.5 as 0.7354 → 188/255; 0.0031308 as 0.04045 → 10/255.
  EXPECT_NEAR(srgb.pixels[0] * 255, 188, 0.01);
  EXPECT_NEAR(srgb.pixels[1] * 255, 0, 0.01);
  EXPECT_NEAR(srgb.pixels[2] * 255, 10, 0.01);
  EXPECT_NEAR(srgb.pixels[3], 1.0f, 1e-6);
  writeImage(path("raw.png"), image, {ColorCorrection::Disabled, "", "", ""});
  EXPECT_NEAR(readImage(path("raw.png")).pixels[0] * 255, 128, 0.01);
}

TEST_F(ImageIO, OpenColorIOConfigDrivesTheDisplayTransform) {
  // A minimal config whose default view is a plain 2.0 gamma.
  const std::string config = path("config.ocio");
  std::ofstream(config) << R"(ocio_profile_version: 2
roles:
  default: linear
  scene_linear: linear
displays:
  test:
    - !<View> {name: gamma, colorspace: gamma2}
colorspaces:
  - !<ColorSpace>
    name: linear
  - !<ColorSpace>
    name: gamma2
    from_scene_reference: !<ExponentTransform> {value: 2.0, direction: inverse}
)";
  ImageData image;
  image.width = image.height = 1;
  image.channelNames = {"R", "G", "B"};
  image.pixels = {0.25f, 0.64f, 1.0f};
  writeImage(path("ocio.png"), image, {ColorCorrection::OpenColorIO, config, "", ""});
  const ImageData read = readImage(path("ocio.png"));
  EXPECT_NEAR(read.pixels[0] * 255, 128, 0.01);  // sqrt(0.25) = 0.5
  EXPECT_NEAR(read.pixels[1] * 255, 204, 0.01);  // sqrt(0.64) = 0.8
}

TEST_F(ImageIO, FailuresNameTheFileAndLeaveNothingBehind) {
  const ImageData image = gradient();
  try {
    writeImage(path("missing/out.exr"), image, {});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("missing/out.exr"), std::string::npos);
  }
  EXPECT_THROW(writeImage(path("out.unknownformat"), image, {}), std::runtime_error);
  EXPECT_THROW(
      writeImage(path("bad.png"), image, {ColorCorrection::OpenColorIO, path("nope.ocio"), "", ""}),
      std::runtime_error);
  EXPECT_EQ(fileCount(), 0u);
  EXPECT_THROW(readImage(path("nothing.exr")), std::runtime_error);
}

TEST_F(ImageIO, AnExistingImageIsReplacedOnlyWhenTheNewOneIsComplete) {
  writeImage(path("out.exr"), gradient(), {});
  ImageData bad = gradient();
  bad.pixels.pop_back();
  EXPECT_THROW(writeImage(path("out.exr"), bad, {}), std::runtime_error);
  EXPECT_EQ(readImage(path("out.exr")).pixels, gradient().pixels);
}
