// Accumulates camera samples per pixel. Samples are added in sample-index order within a pixel,
// so the sums, and hence the image, do not depend on how pixels are spread over threads.
#pragma once

#include <vector>

#include "penumbra/integrator.h"

namespace penumbra {

class Film {
 public:
  Film(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }
  /// Drops every sample and makes every pixel active again.
  void clear();
  /// Adds sample `sampleIndex` of pixel (x, y); samples must come in index order.
  void addSample(int x, int y, uint32_t sampleIndex, const CameraSample& sample);

  /// Averaged scene-linear RGBA, row-major from the top row, 4 floats per pixel.
  std::vector<float> resolveColor() const;
  /// Nearest view-axis depth per pixel (infinity where nothing was hit).
  std::vector<float> resolveDepth() const;

  /// Adaptive sampling: stops every active pixel whose estimated relative error is below
  /// `threshold`. A pixel's error is the difference between the means of its even- and
  /// odd-indexed samples (half of it estimates the standard error of the full mean), relative
  /// to its value as rRMSE weighs it (|x − ref| / sqrt(ref² + 0.01)), averaged in squares over
  /// its 3×3 neighbourhood so that one lucky estimate does not stop it. Call when every active
  /// pixel has the same, even number of samples.
  void updateConvergence(float threshold);
  bool isActive(int x, int y) const { return active_[size_t(y) * size_t(width_) + size_t(x)]; }
  size_t activePixels() const { return activePixels_; }
  /// Samples taken per pixel, on average over the image.
  double meanSamples() const;
  /// Rays traced for all the samples (CameraSample::rays).
  uint64_t raysTraced() const;

 private:
  struct Pixel {
    double red = 0, green = 0, blue = 0, alpha = 0;
    double evenRed = 0, evenGreen = 0, evenBlue = 0;  // samples with an even index
    float depth = kInfinity;
    uint32_t samples = 0;
    uint64_t rays = 0;
  };
  /// A pixel's squared relative error estimate (see updateConvergence).
  static double squaredRelativeError(const Pixel& pixel);

  int width_, height_;
  std::vector<Pixel> pixels_;
  std::vector<uint8_t> active_;
  size_t activePixels_ = 0;
};

}  // namespace penumbra
