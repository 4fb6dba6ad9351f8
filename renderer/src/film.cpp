#include "penumbra/film.h"

#include <stdexcept>
#include <string>

namespace penumbra {

Film::Film(int width, int height) : width_(width), height_(height) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("film size must be positive, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  pixels_.resize(size_t(width) * size_t(height));
}

void Film::clear() {
  std::fill(pixels_.begin(), pixels_.end(), Pixel{});
}

void Film::addSample(int x, int y, const CameraSample& sample) {
  Pixel& pixel = pixels_[size_t(y) * size_t(width_) + size_t(x)];
  pixel.red += sample.radiance.x;
  pixel.green += sample.radiance.y;
  pixel.blue += sample.radiance.z;
  pixel.alpha += sample.alpha;
  pixel.depth = std::min(pixel.depth, sample.depth);
  ++pixel.samples;
}

std::vector<float> Film::resolveColor() const {
  std::vector<float> rgba(pixels_.size() * 4, 0.0f);
  for (size_t i = 0; i < pixels_.size(); ++i) {
    const Pixel& pixel = pixels_[i];
    if (pixel.samples == 0) continue;
    const double scale = 1.0 / pixel.samples;
    rgba[4 * i] = float(pixel.red * scale);
    rgba[4 * i + 1] = float(pixel.green * scale);
    rgba[4 * i + 2] = float(pixel.blue * scale);
    rgba[4 * i + 3] = float(pixel.alpha * scale);
  }
  return rgba;
}

std::vector<float> Film::resolveDepth() const {
  std::vector<float> depth(pixels_.size());
  for (size_t i = 0; i < pixels_.size(); ++i) depth[i] = pixels_[i].depth;
  return depth;
}

}  // namespace penumbra
