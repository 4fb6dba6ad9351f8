#include "penumbra/dome_sampling.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "penumbra/filter.h"
#include "penumbra/integrator.h"

namespace penumbra {
namespace {

/// The pilot's seed: apart from the render's own samples, so that the choice it makes is
/// independent of them.
uint32_t pilotSeed(uint32_t seed) {
  return seed * 0x9E3779B1u + 0x7F4A7C15u;
}

bool hasConstantDome(const Scene& scene) {
  const std::vector<Light>& lights = scene.lights().all();
  return std::any_of(scene.lights().infiniteLights().begin(), scene.lights().infiniteLights().end(),
                     [&](uint32_t index) { return lights[index].isConstantDome(); });
}

/// Half the squared difference of two samples (an unbiased estimate of their variance), over
/// the squared pixel value `mean` + 0.01, summed over the channels.
double relativeVariance(const Vec3f& a, const Vec3f& b, const Vec3f& mean) {
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    const double difference = double(a[c]) - double(b[c]), value = mean[c];
    sum += 0.5 * difference * difference / (value * value + 0.01);
  }
  return sum;
}

/// One grid pixel's two samples, under both strategies.
struct PilotPixel {
  double varianceSampled = 0, varianceUnsampled = 0;
  uint32_t rays = 0, domeShadowRays = 0;
};

}  // namespace

DomeSamplingPilot runDomeSamplingPilot(const Scene& scene, const Camera& camera, int width,
                                       int height, const RenderSettings& settings) {
  DomeSamplingPilot pilot;
  if (width <= 0 || height <= 0 || !hasConstantDome(scene) ||
      settings.integrator.directLighting != DirectLighting::MultipleImportance)
    return pilot;
  IntegratorSettings integrator = settings.integrator;
  integrator.seed = pilotSeed(settings.integrator.seed);
  integrator.sampleConstantDomesAtFirstSurface = false;
  integrator.measureConstantDomeSampling = true;
  integrator.indirectSamples = 1;
  integrator.guidingField = nullptr;
  integrator.guidingRecorder = nullptr;
  integrator.lightImages = nullptr;
  integrator.rayLog = nullptr;
  // At least every other pixel along each axis: at most a quarter of the pixels, two samples.
  const double pixels = double(width) * double(height);
  const int stride =
      std::max(2, int(std::ceil(std::sqrt(pixels / double(kDomeSamplingPilotPixels)))));
  const int columns = (width + stride - 1) / stride, rows = (height + stride - 1) / stride;
  std::vector<PilotPixel> grid(size_t(columns) * size_t(rows));
  const PixelFilter filter;
  const auto tracePixels = [&] {
    tbb::parallel_for(0, rows, [&](int row) {
      for (int column = 0; column < columns; ++column) {
        const int x = std::min(width - 1, column * stride + stride / 2);
        const int y = std::min(height - 1, row * stride + stride / 2);
        const CameraSample a = renderCameraSample(scene, camera, filter, x, y, 0, integrator);
        const CameraSample b = renderCameraSample(scene, camera, filter, x, y, 1, integrator);
        const Vec3f sampledA = a.radiance + a.domeSamplingShift;
        const Vec3f sampledB = b.radiance + b.domeSamplingShift;
        // The pixel's value, from all four estimates of it.
        const Vec3f mean = (a.radiance + b.radiance + sampledA + sampledB) * 0.25f;
        PilotPixel& pixel = grid[size_t(row) * size_t(columns) + size_t(column)];
        pixel.varianceUnsampled = relativeVariance(a.radiance, b.radiance, mean);
        pixel.varianceSampled = relativeVariance(sampledA, sampledB, mean);
        pixel.rays = a.rays + b.rays;
        pixel.domeShadowRays = a.domeSamplingShadowRays + b.domeSamplingShadowRays;
      }
    });
  };
  if (settings.threads > 0) {
    tbb::task_arena arena(settings.threads);
    arena.execute(tracePixels);
  } else {
    tracePixels();
  }
  // Summed in the grid's order, so that the sums do not depend on the threads.
  for (const PilotPixel& pixel : grid) {
    pilot.varianceSampled += pixel.varianceSampled;
    pilot.varianceUnsampled += pixel.varianceUnsampled;
    pilot.rays += pixel.rays;
    pilot.domeShadowRays += pixel.domeShadowRays;
  }
  pilot.pixels = uint32_t(grid.size());
  return pilot;
}

}  // namespace penumbra
