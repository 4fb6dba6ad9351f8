#include "penumbra/film.h"

#include <stdexcept>
#include <string>

namespace penumbra {

Film::Film(int width, int height) : Film(PixelRect{0, 0, width, height}) {}

Film::Film(const PixelRect& region) : region_(region) {
  if (region.width <= 0 || region.height <= 0)
    throw std::invalid_argument("film size must be positive, got " + std::to_string(region.width) +
                                "x" + std::to_string(region.height));
  if (region.x < 0 || region.y < 0)
    throw std::invalid_argument("a film's pixels start at (0, 0) or later, got (" +
                                std::to_string(region.x) + ", " + std::to_string(region.y) + ")");
  clear();
}

void Film::clear() {
  pixels_.assign(size_t(region_.width) * size_t(region_.height), Pixel{});
  active_.assign(pixels_.size(), 1);
  activePixels_ = pixels_.size();
}

void Film::addSample(int x, int y, uint32_t sampleIndex, const CameraSample& sample) {
  Pixel& pixel = pixels_[size_t(y) * size_t(region_.width) + size_t(x)];
  pixel.red += sample.radiance.x;
  pixel.green += sample.radiance.y;
  pixel.blue += sample.radiance.z;
  if (sampleIndex % 2 == 0) {
    pixel.evenRed += sample.radiance.x;
    pixel.evenGreen += sample.radiance.y;
    pixel.evenBlue += sample.radiance.z;
  }
  pixel.alpha += sample.alpha;
  pixel.depth = std::min(pixel.depth, sample.depth);
  pixel.rays += sample.rays;
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

double Film::squaredRelativeError(const Pixel& pixel) {
  if (pixel.samples < 2) return kInfinity;
  const double half = 0.5 * pixel.samples;
  double sum = 0;
  for (const auto& [all, even] :
       {std::pair{pixel.red, pixel.evenRed}, std::pair{pixel.green, pixel.evenGreen},
        std::pair{pixel.blue, pixel.evenBlue}}) {
    const double mean = all / pixel.samples;
    const double halfDifference = 0.5 * (even - (all - even)) / half;
    sum += halfDifference * halfDifference / (mean * mean + 0.01);
  }
  return sum / 3;
}

void Film::updateConvergence(float threshold) {
  std::vector<double> error(pixels_.size());
  for (size_t i = 0; i < pixels_.size(); ++i) error[i] = squaredRelativeError(pixels_[i]);
  const double limit = double(threshold) * double(threshold);
  const int width = region_.width, height = region_.height;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const size_t i = size_t(y) * size_t(region_.width) + size_t(x);
      if (!active_[i]) continue;
      double sum = 0;
      int count = 0;
      for (int ny = std::max(0, y - 1); ny <= std::min(height - 1, y + 1); ++ny)
        for (int nx = std::max(0, x - 1); nx <= std::min(width - 1, x + 1); ++nx, ++count)
          sum += error[size_t(ny) * size_t(width) + size_t(nx)];
      if (sum / count < limit) {
        active_[i] = 0;
        --activePixels_;
      }
    }
}

template <typename Visit>
void Film::forEachPixel(const std::optional<PixelRect>& within, Visit visit) const {
  const PixelRect rect = within.value_or(region_);
  if (!region_.contains(rect))
    throw std::invalid_argument("pixels (" + std::to_string(rect.x) + ", " +
                                std::to_string(rect.y) + ") " + std::to_string(rect.width) + "x" +
                                std::to_string(rect.height) + " are not all on the film");
  for (int y = rect.y - region_.y; y < rect.y - region_.y + rect.height; ++y)
    for (int x = rect.x - region_.x; x < rect.x - region_.x + rect.width; ++x)
      visit(pixels_[size_t(y) * size_t(region_.width) + size_t(x)]);
}

uint64_t Film::raysTraced(const std::optional<PixelRect>& within) const {
  uint64_t total = 0;
  forEachPixel(within, [&total](const Pixel& pixel) { total += pixel.rays; });
  return total;
}

uint64_t Film::samplesTaken(const std::optional<PixelRect>& within) const {
  uint64_t total = 0;
  forEachPixel(within, [&total](const Pixel& pixel) { total += pixel.samples; });
  return total;
}

double Film::meanSamples() const {
  return double(samplesTaken()) / double(pixels_.size());
}

std::vector<float> Film::resolveDepth() const {
  std::vector<float> depth(pixels_.size());
  for (size_t i = 0; i < pixels_.size(); ++i) depth[i] = pixels_[i].depth;
  return depth;
}

}  // namespace penumbra
