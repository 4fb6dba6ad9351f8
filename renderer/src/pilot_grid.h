// What the render's pilots (dome_sampling.h, branching.h) share: a sparse grid of pixels over
// the whole image, traced with a seed of the pilot's own, and the relative variance they measure.
#pragma once

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "on_threads.h"
#include "penumbra/integrator.h"
#include "penumbra/math.h"

namespace penumbra {

/// Which pilot a seed is for: each draws numbers of its own.
enum class Pilot : uint32_t { DomeSampling = 0, Branching = 1 };

/// A pilot's seed: apart from the render's own samples and from the other pilots', so that the
/// choice it makes is independent of them.
inline uint32_t pilotSeed(uint32_t seed, Pilot pilot) {
  return seed * 0x9E3779B1u + 0x7F4A7C15u + uint32_t(pilot) * 0x2545F491u;
}

/// The render's integrator settings for a pilot's samples: its seed `seed`, and none of what
/// only the render's own samples use (guiding, the lights seen directly, the ray log).
inline IntegratorSettings pilotIntegrator(const IntegratorSettings& render, uint32_t seed) {
  IntegratorSettings settings = render;
  settings.seed = seed;
  settings.guidingField = nullptr;
  settings.guidingRecorder = nullptr;
  settings.lightImages = nullptr;
  settings.rayLog = nullptr;
  settings.regionBranches = nullptr;
  return settings;
}

/// Half the product of two samples' differences (an unbiased estimate of the covariance of what
/// they sample; of the variance where `a` and `b` are the same), over the squared pixel value
/// `mean` + 0.01 (as bench/quality.py weighs error), summed over the channels.
inline double relativeCovariance(const Vec3f& a1, const Vec3f& a2, const Vec3f& b1, const Vec3f& b2,
                                 const Vec3f& mean) {
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    const double value = mean[c];
    sum += 0.5 * (double(a1[c]) - double(a2[c])) * (double(b1[c]) - double(b2[c])) /
           (value * value + 0.01);
  }
  return sum;
}

/// The pilot grid over a `width` x `height` image with at most about `maxPixels` pixels: one
/// pixel (at its centre) per square cell `stride` pixels across, at least every other pixel.
struct PilotGridShape {
  int stride, columns, rows;
};
inline PilotGridShape pilotGridShape(int width, int height, uint32_t maxPixels) {
  const double pixels = double(width) * double(height);
  const int stride = std::max(2, int(std::ceil(std::sqrt(pixels / double(maxPixels)))));
  return {stride, (width + stride - 1) / stride, (height + stride - 1) / stride};
}

/// Calls `tracePixel(x, y)` at each pixel of the grid `shape` over a `width` x `height` image
/// (pilotGridShape), on `threads` threads (0: all cores), and returns what it returned in the
/// grid's order (row by row), so that sums over it do not depend on the threads.
template <class PixelResult, class TracePixel>
std::vector<PixelResult> tracePilotGrid(const PilotGridShape& shape, int width, int height,
                                        int threads, const TracePixel& tracePixel) {
  const auto [stride, columns, rows] = shape;
  std::vector<PixelResult> grid(size_t(columns) * size_t(rows));
  onThreads(threads, [&] {
    tbb::parallel_for(0, rows, [&](int row) {
      for (int column = 0; column < columns; ++column) {
        const int x = std::min(width - 1, column * stride + stride / 2);
        const int y = std::min(height - 1, row * stride + stride / 2);
        grid[size_t(row) * size_t(columns) + size_t(column)] = tracePixel(x, y);
      }
    });
  });
  return grid;
}

}  // namespace penumbra
