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
  void clear();
  void addSample(int x, int y, const CameraSample& sample);

  /// Averaged scene-linear RGBA, row-major from the top row, 4 floats per pixel.
  std::vector<float> resolveColor() const;
  /// Nearest view-axis depth per pixel (infinity where nothing was hit).
  std::vector<float> resolveDepth() const;

 private:
  struct Pixel {
    double red = 0, green = 0, blue = 0, alpha = 0;
    float depth = kInfinity;
    uint32_t samples = 0;
  };
  int width_, height_;
  std::vector<Pixel> pixels_;
};

}  // namespace penumbra
