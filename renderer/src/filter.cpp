#include "penumbra/filter.h"

#include <algorithm>
#include <stdexcept>

namespace penumbra {
namespace {
constexpr int kBins = 1024;        // resolution of the tabulated profile
constexpr int kInverseSize = 256;  // knots of the inverse CDF, equally spaced in probability
}  // namespace

PixelFilter::PixelFilter(float radius, float sigma) : radius_(radius), sigma_(sigma) {
  if (!(radius > 0) || !(sigma > 0))
    throw std::invalid_argument("pixel filter: radius and sigma must be > 0");
  std::vector<double> cdf(kBins + 1, 0.0);
  const double binWidth = 2.0 * radius_ / kBins;
  for (int i = 0; i < kBins; ++i)  // midpoint rule per bin
    cdf[size_t(i) + 1] = cdf[size_t(i)] + evaluate1D(float(-radius_ + (i + 0.5) * binWidth));
  // The inverse of the (piecewise-linear) CDF at equally spaced probabilities: sampling is then a
  // table lookup and a lerp instead of a search.
  inverseCdf_.resize(kInverseSize + 1);
  size_t bin = 0;
  for (int k = 0; k <= kInverseSize; ++k) {
    const double target = cdf.back() * k / kInverseSize;
    while (bin + 1 < kBins && cdf[bin + 1] < target) ++bin;
    const double mass = cdf[bin + 1] - cdf[bin];
    const double within = mass > 0 ? std::clamp((target - cdf[bin]) / mass, 0.0, 1.0) : 0.5;
    inverseCdf_[size_t(k)] = float(-radius_ + (double(bin) + within) * binWidth);
  }
}

float PixelFilter::evaluate1D(float x) const {
  const auto gaussian = [this](float v) { return std::exp(-v * v / (2 * sigma_ * sigma_)); };
  return std::max(0.0f, gaussian(x) - gaussian(radius_));
}

float PixelFilter::sample1D(float u) const {
  const float position = u * kInverseSize;
  const int knot = std::clamp(int(position), 0, kInverseSize - 1);
  const float within = position - float(knot);
  return inverseCdf_[size_t(knot)] * (1 - within) + inverseCdf_[size_t(knot) + 1] * within;
}

float PixelFilter::cdf1D(float x) const {
  if (!(x > inverseCdf_.front())) return 0;
  if (!(x < inverseCdf_.back())) return 1;
  // The knot interval holding x; each holds probability 1 / kInverseSize.
  const size_t knot =
      size_t(std::upper_bound(inverseCdf_.begin(), inverseCdf_.end(), x) - inverseCdf_.begin()) - 1;
  const float width = inverseCdf_[knot + 1] - inverseCdf_[knot];
  const float within = width > 0 ? (x - inverseCdf_[knot]) / width : 0.0f;
  return std::min((float(knot) + within) / kInverseSize, 1.0f);
}

float PixelFilter::density1D(float x) const {
  if (!(x > inverseCdf_.front()) || !(x < inverseCdf_.back())) return 0;
  const size_t knot =
      size_t(std::upper_bound(inverseCdf_.begin(), inverseCdf_.end(), x) - inverseCdf_.begin()) - 1;
  const float width = inverseCdf_[knot + 1] - inverseCdf_[knot];
  return width > 0 ? 1 / (width * kInverseSize) : 0.0f;
}

PixelFilter::CoordinateWithin PixelFilter::sampleCoordinateWithin(float lower, float upper,
                                                                  float u) const {
  const float low = cdf1D(lower), high = cdf1D(upper);
  return {sample1D(low + u * (high - low)), std::max(0.0f, high - low)};
}

PixelFilter::OffsetWithin PixelFilter::sampleOffsetWithin(Vec2f lower, Vec2f upper, Vec2f u) const {
  const CoordinateWithin x = sampleCoordinateWithin(lower.x, upper.x, u.x);
  const CoordinateWithin y = sampleCoordinateWithin(lower.y, upper.y, u.y);
  return {{x.offset, y.offset}, x.share * y.share};
}

}  // namespace penumbra
