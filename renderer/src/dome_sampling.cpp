#include "penumbra/dome_sampling.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "pilot_grid.h"

namespace penumbra {
namespace {

bool hasConstantDome(const Scene& scene) {
  const std::vector<Light>& lights = scene.lights().all();
  return std::any_of(scene.lights().infiniteLights().begin(), scene.lights().infiniteLights().end(),
                     [&](uint32_t index) { return lights[index].isConstantDome(); });
}

/// Grid pixels of the pilot at most (two samples each).
constexpr uint32_t kPilotPixels = 4096;

/// One grid pixel's two samples: DomeSamplingPilot's terms.
struct DomePilotPixel {
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
  IntegratorSettings integrator = pilotIntegrator(
      settings.integrator, pilotSeed(settings.integrator.seed, Pilot::DomeSampling));
  integrator.firstSurfaceConstantDomeShare = 0;
  integrator.measureConstantDomeSampling = true;
  integrator.indirectSamples = 1;
  const PixelFilter filter;
  const std::vector<DomePilotPixel> grid = tracePilotGrid<DomePilotPixel>(
      pilotGridShape(width, height, kPilotPixels), width, height, settings.threads,
      [&](int x, int y) {
        const CameraSample a = renderCameraSample(scene, camera, filter, x, y, 0, integrator);
        const CameraSample b = renderCameraSample(scene, camera, filter, x, y, 1, integrator);
        // The pixel's value, from the estimates of both ends (a share of 0 and of 1).
        const Vec3f mean =
            (a.radiance + b.radiance) * 0.5f + (a.domeSamplingShift + b.domeSamplingShift) * 0.25f;
        const Vec3f &ua = a.radiance, &ub = b.radiance;
        const Vec3f &da = a.domeSamplingShift, &db = b.domeSamplingShift;
        DomePilotPixel pixel;
        pixel.varianceUnsampled = relativeCovariance(ua, ub, ua, ub, mean);
        pixel.varianceShift = relativeCovariance(da, db, da, db, mean);
        pixel.covariance = relativeCovariance(ua, ub, da, db, mean);
        pixel.rays = a.rays + b.rays;
        pixel.domeShadowRays = a.domeSamplingShadowRays + b.domeSamplingShadowRays;
        return pixel;
      });
  // Summed in the grid's order, so that the sums do not depend on the threads.
  for (const DomePilotPixel& pixel : grid) {
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
