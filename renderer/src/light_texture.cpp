// LightTexture: an emission texture with the distribution its texels are sampled by.
#include <stdexcept>

#include "penumbra/color.h"
#include "penumbra/light.h"

namespace penumbra {

namespace {

/// sin of the polar angle (from +Y) at the centre of lat-long row `row` of `height`.
float latLongRowSine(int row, int height) {
  return std::sin(kPi * (float(row) + 0.5f) / float(height));
}

std::vector<float> samplingWeights(const std::vector<Vec3f>& texels, int width, int height,
                                   bool latLong) {
  std::vector<float> weights(texels.size());
  for (int y = 0; y < height; ++y) {
    const float rowWeight = latLong ? latLongRowSine(y, height) : 1.0f;
    for (int x = 0; x < width; ++x) {
      const size_t i = size_t(y) * size_t(width) + size_t(x);
      weights[i] = std::max(0.0f, luminance(texels[i])) * rowWeight;
    }
  }
  return weights;
}

Vec3f weightedMean(const std::vector<Vec3f>& texels, int width, int height, bool latLong) {
  double sum[3] = {0, 0, 0}, weightSum = 0;
  for (int y = 0; y < height; ++y) {
    const double rowWeight = latLong ? latLongRowSine(y, height) : 1.0;
    for (int x = 0; x < width; ++x) {
      const Vec3f& t = texels[size_t(y) * size_t(width) + size_t(x)];
      sum[0] += t.x * rowWeight;
      sum[1] += t.y * rowWeight;
      sum[2] += t.z * rowWeight;
      weightSum += rowWeight;
    }
  }
  return {float(sum[0] / weightSum), float(sum[1] / weightSum), float(sum[2] / weightSum)};
}

}  // namespace

LightTexture::LightTexture(int width, int height, std::vector<Vec3f> texels, bool latLong)
    : width_(width),
      height_(height),
      texels_(std::move(texels)),
      distribution_(samplingWeights(texels_, width, height, latLong), width, height),
      average_(weightedMean(texels_, width, height, latLong)) {}

std::shared_ptr<const LightTexture> LightTexture::load(std::shared_ptr<TextureSystem> textures,
                                                       const std::string& path, bool latLong) {
  std::string error;
  const TextureSystem::Handle handle = textures->open(path, SourceColorSpace::Auto, &error);
  if (handle == TextureSystem::kInvalid) throw std::runtime_error(error);
  int width = 0, height = 0;
  std::vector<Vec3f> level;
  if (!textures->readLevel(handle, kDistributionTexels, &width, &height, &level))
    throw std::runtime_error(path + ": cannot read the texture's MIP levels");
  int fullWidth = 0, fullHeight = 0;
  textures->resolution(handle, &fullWidth, &fullHeight);
  auto texture = std::make_shared<LightTexture>(width, height, std::move(level), latLong);
  // A texture small enough to be its own distribution's level stays in memory (lookups there
  // are several times cheaper than through the cache); a larger one is read through the cache.
  if (width != fullWidth || height != fullHeight) {
    texture->texels_.clear();
    texture->texels_.shrink_to_fit();
    texture->textures_ = std::move(textures);
    texture->handle_ = handle;
  }
  return texture;
}

Vec3f LightTexture::lookup(Vec2f uv) const {
  if (textures_) return textures_->texel(handle_, uv);
  const int x = std::clamp(int(uv.x * float(width_)), 0, width_ - 1);
  const int y = std::clamp(int(uv.y * float(height_)), 0, height_ - 1);
  return texels_[size_t(y) * size_t(width_) + size_t(x)];
}

}  // namespace penumbra
