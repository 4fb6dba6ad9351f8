// Piecewise-constant distributions for importance sampling tabulated functions (light textures,
// mesh lights' triangles by area).
#pragma once

#include <vector>

#include "penumbra/math.h"

namespace penumbra {

/// Samples an index with probability proportional to its non-negative weight, and a continuous
/// position within it.
class Distribution1D {
 public:
  /// All-zero or empty weights fall back to uniform.
  explicit Distribution1D(std::vector<float> weights);

  size_t size() const { return weights_.size(); }
  /// Index for a uniform sample u in [0, 1); `remapped` receives u rescaled to [0, 1) within
  /// the chosen bin (so one random number serves both choices).
  size_t sampleIndex(float u, float* remapped = nullptr) const;
  /// Probability of choosing index i.
  float probability(size_t i) const { return probabilities_[i]; }
  /// Sum of the weights (before normalisation).
  double total() const { return total_; }

 private:
  std::vector<float> weights_;
  std::vector<float> probabilities_;
  std::vector<double> cdf_;  // size + 1 entries, cdf_.back() == 1
  double total_ = 0;
};

/// A 2D piecewise-constant density on [0, 1)²: a marginal over rows, a conditional per row.
class Distribution2D {
 public:
  /// `values` row-major, width x height, non-negative.
  Distribution2D(const std::vector<float>& values, int width, int height);

  /// A point in [0, 1)² and its density with respect to area in [0, 1)².
  Vec2f sample(Vec2f u, float* density) const;
  float density(Vec2f point) const;

 private:
  int width_, height_;
  Distribution1D marginal_;
  std::vector<Distribution1D> conditional_;
};

}  // namespace penumbra
