#include "penumbra/distribution.h"

#include <algorithm>
#include <cstddef>

namespace penumbra {

Distribution1D::Distribution1D(std::vector<float> weights) : weights_(std::move(weights)) {
  if (weights_.empty()) weights_.push_back(1);
  for (float w : weights_) total_ += std::max(0.0f, w);
  const bool uniform = !(total_ > 0);
  probabilities_.resize(weights_.size());
  cdf_.resize(weights_.size() + 1, 0.0);
  for (size_t i = 0; i < weights_.size(); ++i) {
    const double p = uniform ? 1.0 / double(weights_.size()) : std::max(0.0f, weights_[i]) / total_;
    probabilities_[i] = float(p);
    cdf_[i + 1] = cdf_[i] + p;
  }
  cdf_.back() = 1;
}

size_t Distribution1D::sampleIndex(float u, float* remapped) const {
  // The last bin whose cdf start is <= u, skipping empty bins.
  const auto upper = std::upper_bound(cdf_.begin(), cdf_.end(), double(u));
  size_t index = size_t(std::max<std::ptrdiff_t>(0, (upper - cdf_.begin()) - 1));
  index = std::min(index, weights_.size() - 1);
  while (probabilities_[index] == 0 && index > 0) --index;
  if (remapped) {
    const double width = cdf_[index + 1] - cdf_[index];
    *remapped = width > 0 ? float(std::clamp((u - cdf_[index]) / width, 0.0, 0x1.fffffep-1)) : 0.5f;
  }
  return index;
}

Distribution2D::Distribution2D(const std::vector<float>& values, int width, int height)
    : width_(width), height_(height), marginal_([&] {
        std::vector<float> rows(size_t(height), 0.0f);
        for (int y = 0; y < height; ++y)
          for (int x = 0; x < width; ++x)
            rows[size_t(y)] += values[size_t(y) * size_t(width) + size_t(x)];
        return rows;
      }()) {
  conditional_.reserve(size_t(height));
  for (int y = 0; y < height; ++y)
    conditional_.emplace_back(std::vector<float>(values.begin() + std::ptrdiff_t(y) * width,
                                                 values.begin() + std::ptrdiff_t(y + 1) * width));
}

Vec2f Distribution2D::sample(Vec2f u, float* density) const {
  float withinRow = 0, withinColumn = 0;
  const size_t row = marginal_.sampleIndex(u.y, &withinRow);
  const size_t column = conditional_[row].sampleIndex(u.x, &withinColumn);
  if (density)
    *density = marginal_.probability(row) * conditional_[row].probability(column) * float(width_) *
               float(height_);
  return {(float(column) + withinColumn) / float(width_),
          (float(row) + withinRow) / float(height_)};
}

float Distribution2D::density(Vec2f point) const {
  const size_t column =
      std::min(size_t(std::max(0.0f, point.x) * float(width_)), size_t(width_ - 1));
  const size_t row =
      std::min(size_t(std::max(0.0f, point.y) * float(height_)), size_t(height_ - 1));
  return marginal_.probability(row) * conditional_[row].probability(column) * float(width_) *
         float(height_);
}

}  // namespace penumbra
