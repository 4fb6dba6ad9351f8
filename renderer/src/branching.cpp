#include "penumbra/branching.h"

#include <algorithm>
#include <array>
#include <vector>

#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "pilot_grid.h"

namespace penumbra {
namespace {

/// Grid pixels of the pilot at most; and at most one pixel in kPilotPixelShare of the image's,
/// so that it costs at most a sample per pixel on small images.
constexpr uint32_t kPilotPixels = 1024;
constexpr double kPilotPixelShare = 16;
/// Samples per pixel of each of the pilot's two replicas, each branching in two.
constexpr uint32_t kPilotSamples = 4;

/// One grid pixel's samples: BranchingPilot's terms.
struct BranchingPilotPixel {
  double varianceFirst = 0, varianceBeyond = 0;
  uint32_t raysFirst = 0, raysBeyondBothBranches = 0;
};

}  // namespace

int BranchingPilot::indirectSamples() const {
  if (pixels == 0) return 1;
  const auto product = [&](int branches) { return variance(branches) * cost(branches); };
  double least = product(1);
  for (int branches = 2; branches <= kMaxBranches; ++branches)
    least = std::min(least, product(branches));
  int branches = 1;
  while (product(branches) > least * (1 + kTolerance)) ++branches;
  return branches;
}

BranchingPilot runBranchingPilot(const Scene& scene, const Camera& camera, int width, int height,
                                 const RenderSettings& settings) {
  BranchingPilot pilot;
  if (width <= 0 || height <= 0 || settings.integrator.maxPathDepth < 2) return pilot;
  // Two replicas of the pixel, each from a seed of its own: independent, each stratified as
  // a render's samples are.
  IntegratorSettings replicas[2];
  for (uint32_t replica = 0; replica < 2; ++replica) {
    IntegratorSettings& integrator = replicas[replica];
    integrator = pilotIntegrator(settings.integrator,
                                 pilotSeed(settings.integrator.seed, Pilot::Branching) + replica);
    integrator.indirectSamples = 2;
    integrator.measureConstantDomeSampling = false;
  }
  const PixelFilter filter;
  const uint32_t maxPixels = uint32_t(
      std::clamp(double(width) * double(height) / kPilotPixelShare, 1.0, double(kPilotPixels)));
  const std::vector<BranchingPilotPixel> grid = tracePilotGrid<BranchingPilotPixel>(
      width, height, maxPixels, settings.threads, [&](int x, int y) {
        std::array<CameraSample, 2 * kPilotSamples> samples;
        // Per replica, the mean of its samples' branch 0 and of their branch 1.
        Vec3f branchMeans[2][2] = {{Vec3f(0.0f), Vec3f(0.0f)}, {Vec3f(0.0f), Vec3f(0.0f)}};
        for (uint32_t replica = 0; replica < 2; ++replica)
          for (uint32_t index = 0; index < kPilotSamples; ++index) {
            CameraSample& sample = samples[replica * kPilotSamples + index];
            sample = renderCameraSample(scene, camera, filter, x, y, index, replicas[replica]);
            const Vec3f half = sample.branchDifference * 0.5f;
            branchMeans[replica][0] += (sample.radiance + half) * (1.0f / float(kPilotSamples));
            branchMeans[replica][1] += (sample.radiance - half) * (1.0f / float(kPilotSamples));
          }
        const Vec3f mean =
            (branchMeans[0][0] + branchMeans[0][1] + branchMeans[1][0] + branchMeans[1][1]) * 0.25f;
        const Vec3f zero(0.0f);
        BranchingPilotPixel pixel;
        // Var(Y0 - Y1) = 2 V_beyond for a sample's two branches Y0, Y1.
        for (const CameraSample& sample : samples) {
          const Vec3f& difference = sample.branchDifference;
          pixel.varianceBeyond +=
              relativeCovariance(difference, zero, difference, zero, mean) / double(samples.size());
          pixel.raysFirst += sample.raysBeforeBranching;
          pixel.raysBeyondBothBranches += sample.rays - sample.raysBeforeBranching;
        }
        // A replica's branch-0 and branch-1 means share what lies up to the first surfaces and
        // nothing beyond: their covariance is V_first / n for its n samples, V_first being the
        // variance per sample of what lies up to the first surface as stratified over n samples
        // (less than a single sample's: the pixel's area, the lens and the shutter are sampled
        // evenly). Measured so, rather than as what the replicas' variance leaves of V_beyond's
        // share, it is not swamped by rare bright paths beyond the split (caustics).
        pixel.varianceFirst =
            double(kPilotSamples) * relativeCovariance(branchMeans[0][0], branchMeans[1][0],
                                                       branchMeans[0][1], branchMeans[1][1], mean);
        return pixel;
      });
  // Summed in the grid's order, so that the sums do not depend on the threads.
  for (const BranchingPilotPixel& pixel : grid) {
    pilot.varianceFirst += pixel.varianceFirst;
    pilot.varianceBeyond += pixel.varianceBeyond;
    pilot.raysFirst += pixel.raysFirst;
    pilot.raysBeyond += pixel.raysBeyondBothBranches;
  }
  pilot.raysBeyond /= 2;
  // Estimated from products of differences, V_first may come out below 0 where it is small.
  pilot.varianceFirst = std::max(pilot.varianceFirst, 0.0);
  pilot.pixels = uint32_t(grid.size());
  return pilot;
}

}  // namespace penumbra
