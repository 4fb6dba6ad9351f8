#include "penumbra/branching.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
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
/// Samples per pixel of each of the pilot's two replicas, each estimating its first surface's
/// light twice and branching in two.
constexpr uint32_t kPilotSamples = 4;

/// One grid pixel's samples: BranchingPilot's terms.
struct BranchingPilotPixel {
  double varianceFirstAndHalfLight = 0, varianceLight = 0, varianceBeyond = 0;
  double workFirst = 0, workBothLightEstimates = 0, workBeyondBothBranches = 0;
};

/// What the pilot counts a part of a sample's cost in (BranchingPilot).
double work(uint32_t rays, uint32_t vertices) {
  return double(rays) + BranchingPilot::kVertexCost * double(vertices);
}

}  // namespace

BranchingPilot::Choice BranchingPilot::choose(Choice choice) const {
  if (pixels == 0) return {std::max(choice.indirectSamples, 1), std::max(choice.lightSamples, 1)};
  const int fewestBranches = choice.indirectSamples > 0 ? choice.indirectSamples : 1;
  const int mostBranches = choice.indirectSamples > 0 ? choice.indirectSamples : kMaxBranches;
  const int fewestEstimates = choice.lightSamples > 0 ? choice.lightSamples : 1;
  const int mostEstimates = choice.lightSamples > 0 ? choice.lightSamples : kMaxLightEstimates;
  // A sample's variance counts from the noise floor up: below it, more branches or estimates
  // would only cost.
  const double floor = kNoiseFloor * double(pixels);
  const auto product = [&](int branches, int estimates) {
    return (variance(branches, estimates) + floor) * cost(branches, estimates);
  };
  const auto forEachCount = [&](auto&& visit) {
    for (int branches = fewestBranches; branches <= mostBranches; ++branches)
      for (int estimates = fewestEstimates; estimates <= mostEstimates; ++estimates)
        visit(branches, estimates);
  };
  double least = product(fewestBranches, fewestEstimates);
  forEachCount(
      [&](int branches, int estimates) { least = std::min(least, product(branches, estimates)); });
  // The cheapest within the tolerance; of equally cheap ones, the fewest counts.
  std::optional<Choice> chosen;
  forEachCount([&](int branches, int estimates) {
    if (product(branches, estimates) > least * (1 + kTolerance)) return;
    const double price = cost(branches, estimates);
    const double chosenPrice = chosen ? cost(chosen->indirectSamples, chosen->lightSamples) : 0;
    if (!chosen || price < chosenPrice ||
        (price == chosenPrice &&
         branches + estimates < chosen->indirectSamples + chosen->lightSamples))
      chosen = Choice{branches, estimates};
  });
  return *chosen;
}

FirstSurfaceBranches BranchingPilot::chooseRegions(Choice choice) const {
  FirstSurfaceBranches regions;
  regions.regionSize = std::max(1, gridStride * kRegionCells);
  regions.columns = std::max(1, (gridColumns + kRegionCells - 1) / kRegionCells);
  regions.rows = std::max(1, (gridRows + kRegionCells - 1) / kRegionCells);
  const size_t count = size_t(regions.columns) * size_t(regions.rows);
  regions.counts.assign(count, uint8_t(std::clamp(choice.indirectSamples, 1, kMaxIndirectSamples)));
  if (pixels == 0 || cells.size() != size_t(gridColumns) * size_t(gridRows)) return regions;
  // Calls visit(cell, region) for each cell of the grid, in the grid's order.
  const auto forEachCell = [&](auto&& visit) {
    for (int row = 0; row < gridRows; ++row)
      for (int column = 0; column < gridColumns; ++column)
        visit(cells[size_t(row) * size_t(gridColumns) + size_t(column)],
              size_t(row / kRegionCells) * size_t(regions.columns) + size_t(column / kRegionCells));
  };
  // Each region's terms: the sums over its cells.
  std::vector<Cell> sums(count);
  forEachCell([&](const Cell& cell, size_t region) {
    Cell& sum = sums[region];
    sum.varianceFirst += cell.varianceFirst;
    sum.varianceLight += cell.varianceLight;
    sum.varianceBeyond += cell.varianceBeyond;
    sum.costFirst += cell.costFirst;
    sum.costLight += cell.costLight;
    sum.costBeyond += cell.costBeyond;
  });
  // A region's V_beyond comes from a few pixels' samples, where rare bright paths beyond the
  // split (caustics) make it noisy. Its V_beyond per work beyond is taken as the image's plus
  // the share of its own's difference from it that the regions' spread leaves to the noise of
  // its own (empirical Bayes: the noise from the spread of its cells' values, the regions'
  // spread from that of their values less their mean noise). Where nothing lies beyond (the
  // sky), V_beyond stays 0: one branch, which costs nothing there.
  const auto perWork = [](const Cell& cell) { return cell.varianceBeyond / cell.costBeyond; };
  const double imagePerWork = costBeyond > 0 ? varianceBeyond / costBeyond : 0.0;
  // Of each region, the cells with work beyond and their squared deviations from its value.
  std::vector<double> measured(count, 0.0), squares(count, 0.0);
  forEachCell([&](const Cell& cell, size_t region) {
    if (cell.costBeyond <= 0) return;
    const double deviation = perWork(cell) - perWork(sums[region]);
    squares[region] += deviation * deviation;
    measured[region] += 1;
  });
  // One cell's variance about its region's value, pooled over the regions of several cells:
  // for a region with one (at a horizon, or in the odd last row or column of the grid).
  double pooledSquares = 0, degrees = 0;
  for (size_t r = 0; r < count; ++r)
    if (measured[r] > 1) {
      pooledSquares += squares[r];
      degrees += measured[r] - 1;
    }
  const double cellVariance = degrees > 0 ? pooledSquares / degrees : 0.0;
  std::vector<double> noise(count, 0.0);  // the variance of a region's value
  double spread = 0, meanNoise = 0, regionsBeyond = 0;
  for (size_t r = 0; r < count; ++r) {
    if (measured[r] == 0) continue;
    noise[r] = (measured[r] > 1 ? squares[r] / (measured[r] - 1) : cellVariance) / measured[r];
    const double deviation = perWork(sums[r]) - imagePerWork;
    spread += deviation * deviation;
    meanNoise += noise[r];
    regionsBeyond += 1;
  }
  // The regions' spread beyond their noise: 0 where they differ no more than it.
  const double regionSpread =
      regionsBeyond > 0 ? std::max((spread - meanNoise) / regionsBeyond, 0.0) : 0.0;
  for (size_t r = 0; r < count; ++r) {
    Cell& sum = sums[r];
    if (measured[r] == 0) continue;
    const double trust = regionSpread > 0 ? regionSpread / (regionSpread + noise[r]) : 0.0;
    sum.varianceBeyond = (imagePerWork + trust * (perWork(sum) - imagePerWork)) * sum.costBeyond;
  }
  const int estimates = std::max(choice.lightSamples, 1);
  // The image's variance times cost with `counts`. V_first, summed over regions whose own may
  // come out below 0, is kept at 0 or more as a whole, as the image's is.
  const auto product = [&](const std::vector<uint8_t>& counts) {
    double first = 0, rest = 0, work = 0;
    for (size_t r = 0; r < count; ++r) {
      const Cell& sum = sums[r];
      first += sum.varianceFirst;
      rest += sum.varianceLight / estimates + sum.varianceBeyond / counts[r];
      work += sum.costFirst + estimates * sum.costLight + counts[r] * sum.costBeyond;
    }
    return (std::max(first, 0.0) + rest + kNoiseFloor * double(pixels)) * work;
  };
  // The counts of least product: there each region's count minimises its own
  // V_beyond / N + μ · N · C_beyond for one μ (the image's variance over its cost), tried in
  // steps of 2^(1/6) over 20 octaves around the one-branch image's.
  const double typicalMu = (variance(1, estimates) + kNoiseFloor * double(pixels)) /
                           std::max(cost(1, estimates), std::numeric_limits<double>::min());
  std::vector<uint8_t> trial(count), best;
  double least = std::numeric_limits<double>::infinity();
  for (int step = -60; step <= 60; ++step) {
    const double mu = typicalMu * std::exp2(double(step) / 6);
    for (size_t r = 0; r < count; ++r) {
      const Cell& sum = sums[r];
      int branches = 1;
      for (int more = 2; more <= kMaxBranches; ++more)
        if (sum.varianceBeyond / more + mu * more * sum.costBeyond <
            sum.varianceBeyond / branches + mu * branches * sum.costBeyond)
          branches = more;
      trial[r] = uint8_t(branches);
    }
    const double value = product(trial);
    if (value < least) {
      least = value;
      best = trial;
    }
  }
  if (least < (1 - kRegionMargin) * product(regions.counts)) regions.counts = best;
  return regions;
}

BranchingPilot runBranchingPilot(const Scene& scene, const Camera& camera, int width, int height,
                                 const RenderSettings& settings) {
  BranchingPilot pilot;
  if (width <= 0 || height <= 0 || settings.integrator.maxPathDepth < 1) return pilot;
  // Two replicas of the pixel, each from a seed of its own: independent, each stratified as
  // a render's samples are.
  IntegratorSettings replicas[2];
  for (uint32_t replica = 0; replica < 2; ++replica) {
    IntegratorSettings& integrator = replicas[replica];
    integrator = pilotIntegrator(settings.integrator,
                                 pilotSeed(settings.integrator.seed, Pilot::Branching) + replica);
    integrator.indirectSamples = 2;
    integrator.lightSamples = 2;
    integrator.measureConstantDomeSampling = false;
  }
  const PixelFilter filter;
  const uint32_t maxPixels = uint32_t(
      std::clamp(double(width) * double(height) / kPilotPixelShare, 1.0, double(kPilotPixels)));
  const PilotGridShape shape = pilotGridShape(width, height, maxPixels);
  const std::vector<BranchingPilotPixel> grid = tracePilotGrid<BranchingPilotPixel>(
      shape, width, height, settings.threads, [&](int x, int y) {
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
        // Var(Y0 - Y1) = 2 V_beyond for a sample's two branches Y0, Y1; so for its two light
        // estimates and V_light.
        for (const CameraSample& sample : samples) {
          const Vec3f& difference = sample.branchDifference;
          const Vec3f& lightDifference = sample.lightEstimateDifference;
          pixel.varianceBeyond +=
              relativeCovariance(difference, zero, difference, zero, mean) / double(samples.size());
          pixel.varianceLight +=
              relativeCovariance(lightDifference, zero, lightDifference, zero, mean) /
              double(samples.size());
          // The light estimates shade no vertex of their own; a light sample costs a ray, its
          // shadow ray or, for a light without shadows, its evaluation.
          pixel.workFirst += work(sample.raysBeforeBranching - sample.firstSurfaceLightRays,
                                  sample.verticesBeforeBranching);
          pixel.workBothLightEstimates += work(sample.firstSurfaceLightSamples, 0);
          pixel.workBeyondBothBranches += work(sample.rays - sample.raysBeforeBranching,
                                               sample.vertices - sample.verticesBeforeBranching);
        }
        // A replica's branch-0 and branch-1 means share what lies up to the first surfaces and
        // nothing beyond: their covariance is (V_first + V_light / 2) / n for its n samples,
        // V_first being the variance per sample of what lies up to the first surface as
        // stratified over n samples (less than a single sample's: the pixel's area, the lens and
        // the shutter are sampled evenly). Measured so, rather than as what the replicas'
        // variance leaves of V_beyond's share, it is not swamped by rare bright paths beyond the
        // split (caustics).
        pixel.varianceFirstAndHalfLight =
            double(kPilotSamples) * relativeCovariance(branchMeans[0][0], branchMeans[1][0],
                                                       branchMeans[0][1], branchMeans[1][1], mean);
        return pixel;
      });
  // Summed in the grid's order, so that the sums do not depend on the threads.
  double varianceFirstAndHalfLight = 0;
  for (const BranchingPilotPixel& pixel : grid) {
    varianceFirstAndHalfLight += pixel.varianceFirstAndHalfLight;
    pilot.varianceLight += pixel.varianceLight;
    pilot.varianceBeyond += pixel.varianceBeyond;
    pilot.costFirst += pixel.workFirst;
    pilot.costLight += pixel.workBothLightEstimates;
    pilot.costBeyond += pixel.workBeyondBothBranches;
    BranchingPilot::Cell& cell = pilot.cells.emplace_back();
    cell.varianceFirst = pixel.varianceFirstAndHalfLight - pixel.varianceLight / 2;
    cell.varianceLight = pixel.varianceLight;
    cell.varianceBeyond = pixel.varianceBeyond;
    cell.costFirst = pixel.workFirst;
    cell.costLight = pixel.workBothLightEstimates / 2;
    cell.costBeyond = pixel.workBeyondBothBranches / 2;
  }
  pilot.costLight /= 2;
  pilot.costBeyond /= 2;
  // Estimated from products of differences, V_first may come out below 0 where it is small.
  pilot.varianceFirst = std::max(varianceFirstAndHalfLight - pilot.varianceLight / 2, 0.0);
  pilot.pixels = uint32_t(grid.size());
  pilot.gridStride = shape.stride;
  pilot.gridColumns = shape.columns;
  pilot.gridRows = shape.rows;
  return pilot;
}

}  // namespace penumbra
