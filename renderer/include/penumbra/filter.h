// Importance-sampled pixel reconstruction filter. Instead of splatting weighted samples into
// neighbouring pixels, each sample's offset from the pixel centre is drawn with density
// proportional to the filter, and every sample has weight 1: pixels stay independent, which keeps
// rendering deterministic across threads and farm splits.
#pragma once

#include <vector>

#include "penumbra/math.h"

namespace penumbra {

/// A separable Gaussian filter, truncated at `radius` pixels and shifted to reach zero there.
class PixelFilter {
 public:
  explicit PixelFilter(float radius = 1.5f, float sigma = 0.5f);

  /// Offset from the pixel centre, in pixels, for a uniform 2D sample.
  Vec2f sampleOffset(Vec2f u) const { return {sample1D(u.x), sample1D(u.y)}; }
  /// An offset drawn as sampleOffset draws them but only within the box [lower, upper] (pixels
  /// from the pixel centre), with the share of the filter's weight that lies in that box: an
  /// estimate of the filter-weighted integral over the box is that share times what the offset
  /// sees.
  struct OffsetWithin {
    Vec2f offset;
    float share;
  };
  OffsetWithin sampleOffsetWithin(Vec2f lower, Vec2f upper, Vec2f u) const;
  /// sampleOffsetWithin along one axis: an offset within [lower, upper] and the share of the
  /// filter's weight along that axis that lies there (the 2D share is the product of the axes').
  struct CoordinateWithin {
    float offset;
    float share;
  };
  CoordinateWithin sampleCoordinateWithin(float lower, float upper, float u) const;
  float radius() const { return radius_; }
  /// The density (per pixel) with which sampleOffset draws offset `x` along one axis: the
  /// filter as camera samples weigh the image, for splatting light-traced paths alike
  /// (caustics.h). Piecewise constant between the inverse CDF's knots; 0 beyond the radius.
  float density1D(float x) const;
  /// The filter's 1D profile (unnormalised), exposed for tests.
  float evaluate1D(float x) const;

 private:
  float sample1D(float u) const;
  /// The probability that sample1D draws an offset below x (piecewise linear between the
  /// inverse CDF's knots, as sample1D interpolates them).
  float cdf1D(float x) const;

  float radius_, sigma_;
  std::vector<float> inverseCdf_;  // offsets at equally spaced probabilities 0 .. 1
};

}  // namespace penumbra
