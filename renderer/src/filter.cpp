#include "penumbra/filter.h"

#include <algorithm>
#include <stdexcept>

namespace penumbra {
namespace {
constexpr int kBins = 1024;
}

PixelFilter::PixelFilter(float radius, float sigma) : radius_(radius), sigma_(sigma) {
  if (!(radius > 0) || !(sigma > 0))
    throw std::invalid_argument("pixel filter: radius and sigma must be > 0");
  cdf_.resize(kBins + 1);
  cdf_[0] = 0;
  const float binWidth = 2 * radius_ / kBins;
  double total = 0;
  for (int i = 0; i < kBins; ++i) {
    // Midpoint rule per bin; the distribution sampled is the piecewise-constant one tabulated here.
    total += evaluate1D(-radius_ + (i + 0.5f) * binWidth);
    cdf_[i + 1] = float(total);
  }
  for (float& value : cdf_) value = float(value / total);
  cdf_.back() = 1;
}

float PixelFilter::evaluate1D(float x) const {
  const auto gaussian = [this](float v) { return std::exp(-v * v / (2 * sigma_ * sigma_)); };
  return std::max(0.0f, gaussian(x) - gaussian(radius_));
}

float PixelFilter::sample1D(float u) const {
  const auto upper = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  const int bin = std::clamp(int(upper - cdf_.begin()) - 1, 0, kBins - 1);
  const float binStart = cdf_[bin], binMass = cdf_[bin + 1] - cdf_[bin];
  const float withinBin = binMass > 0 ? (u - binStart) / binMass : 0.5f;
  return -radius_ + (bin + withinBin) * (2 * radius_ / kBins);
}

}  // namespace penumbra
