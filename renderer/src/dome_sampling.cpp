#include "penumbra/dome_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "on_threads.h"
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

/// Half the product of two samples' differences (an unbiased estimate of the covariance of what
/// they sample; of the variance where `a` and `b` are the same), over the squared pixel value
/// `mean` + 0.01, summed over the channels.
double relativeCovariance(const Vec3f& a1, const Vec3f& a2, const Vec3f& b1, const Vec3f& b2,
                          const Vec3f& mean) {
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    const double value = mean[c];
    sum += 0.5 * (double(a1[c]) - double(a2[c])) * (double(b1[c]) - double(b2[c])) /
           (value * value + 0.01);
  }
  return sum;
}

/// One grid pixel's two samples: DomeSamplingPilot's terms.
struct PilotPixel {
  double varianceUnsampled = 0, varianceShift = 0, covariance = 0;
  uint32_t rays = 0, domeShadowRays = 0;
};

}  // namespace

float DomeSamplingPilot::firstSurfaceShare() const {
  if (pixels == 0) return 1;
  // The least of the quadratic over (0, 1], on the grid of shares.
  const double least =
      varianceShift > 0 ? std::clamp(-covariance / varianceShift, kShareStep, 1.0) : 1.0;
  const double share = std::round(least / kShareStep) * kShareStep;
  const double costShared = double(rays) + kDomeShadowRayCost * double(domeShadowRays);
  return variance(share) * costShared < variance(0) * double(rays) ? float(share) : 0.0f;
}

DomeSamplingPilot runDomeSamplingPilot(const Scene& scene, const Camera& camera, int width,
                                       int height, const RenderSettings& settings) {
  DomeSamplingPilot pilot;
  if (width <= 0 || height <= 0 || !hasConstantDome(scene) ||
      settings.integrator.directLighting != DirectLighting::MultipleImportance)
    return pilot;
  IntegratorSettings integrator = settings.integrator;
  integrator.seed = pilotSeed(settings.integrator.seed);
  integrator.firstSurfaceConstantDomeShare = 0;
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
        // The pixel's value, from the estimates of both ends (a share of 0 and of 1).
        const Vec3f mean =
            (a.radiance + b.radiance) * 0.5f + (a.domeSamplingShift + b.domeSamplingShift) * 0.25f;
        const Vec3f &ua = a.radiance, &ub = b.radiance;
        const Vec3f &da = a.domeSamplingShift, &db = b.domeSamplingShift;
        PilotPixel& pixel = grid[size_t(row) * size_t(columns) + size_t(column)];
        pixel.varianceUnsampled = relativeCovariance(ua, ub, ua, ub, mean);
        pixel.varianceShift = relativeCovariance(da, db, da, db, mean);
        pixel.covariance = relativeCovariance(ua, ub, da, db, mean);
        pixel.rays = a.rays + b.rays;
        pixel.domeShadowRays = a.domeSamplingShadowRays + b.domeSamplingShadowRays;
      }
    });
  };
  onThreads(settings.threads, tracePixels);
  // Summed in the grid's order, so that the sums do not depend on the threads.
  for (const PilotPixel& pixel : grid) {
    pilot.varianceUnsampled += pixel.varianceUnsampled;
    pilot.varianceShift += pixel.varianceShift;
    pilot.covariance += pixel.covariance;
    pilot.rays += pixel.rays;
    pilot.domeShadowRays += pixel.domeShadowRays;
  }
  pilot.pixels = uint32_t(grid.size());
  return pilot;
}

}  // namespace penumbra
