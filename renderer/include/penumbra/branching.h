// How many paths go on from each camera ray's first surface (IntegratorSettings::indirectSamples)
// and how many light estimates are made there (IntegratorSettings::lightSamples), where the
// render leaves the counts to Penumbra: chosen once per render, from a pilot, the branches per
// region of the image (docs/branching.md).
//
// A camera sample's variance is that of what it finds up to and at its first surface but its
// direct light there (where in the pixel, on the lens and in the shutter it looks, the surface's
// emission), V_first, plus that of one estimate of the first surface's direct light (which
// light, where on it, whether it is hidden), V_light, plus that of what lies beyond the surface,
// V_beyond; its cost is that of the camera ray and its hit, C_first, plus that of a light
// estimate, C_light, plus that of the path beyond, C_beyond. M light estimates and N branches
// give the variance V_first + V_light / M + V_beyond / N for the cost C_first + M C_light +
// N C_beyond. Branches pay where most of the noise lies beyond the first surface and much of
// the cost before it (open scenes under a sky, a room lit by a lamp); light estimates where the
// choice of light is the noise (many lights, large soft ones); neither where the noise is the
// pixel's own (motion blur, texture finer than a pixel).
//
// The pilot traces, at each pixel of a sparse grid over the whole image (a crop or a farm's band
// runs the same pilot, so every band makes the same choice), two independent replicas of four
// samples, each sample estimating its first surface's light twice and branching in two: the
// difference of a sample's two branches estimates V_beyond, that of its two light estimates
// V_light; the covariance of a replica's mean of branches 0 and its mean of branches 1, which
// share what lies up to the first surfaces and nothing beyond, V_first / 4 + V_light / 8; the
// work done before the split, by the light estimates and after the split, the costs. Work counts
// rays traced and scattering vertices shaded (kVertexCost): more of a sample's time goes into
// setting up BSDFs, estimating light and drawing directions than into Embree's traversal, and
// rays alone made the camera ray and its shaded hit look as cheap as a branch's one ray into the
// sky, which gave too few branches and estimates among many lights (docs/branching.md). V_first
// so measured is that of samples stratified as a render's are (over the pixel's area, the lens,
// the shutter), which is far less than a lone sample's where the pixel's own noise is smooth
// (edges, defocus). Its numbers are its own (seeds derived from the render's), so the choice does
// not depend on the samples it is used for.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/render.h"
#include "penumbra/scene.h"

namespace penumbra {

/// What the branching pilot measured, relative to the image (each pixel's and channel's variance
/// over its squared value + 0.01, as bench/quality.py weighs error) and summed over the grid.
struct BranchingPilot {
  /// The most branches the pilot chooses: from 3 to 4 the variance times cost of the benchmark
  /// scenes fell by 5 % at most (docs/branching.md), while a sample's cost, and so the time to a
  /// first image, keeps growing.
  static constexpr int kMaxBranches = 4;
  /// The most light estimates it chooses: among 1,000 lights, 8 gave 3 % less variance times
  /// cost than 4 (docs/branching.md).
  static constexpr int kMaxLightEstimates = 8;

  double varianceFirst = 0;   // V_first: of what a sample finds up to its first surface (≥ 0)
  double varianceLight = 0;   // V_light: of one estimate of the first surface's direct light
  double varianceBeyond = 0;  // V_beyond: of what one branch finds beyond it
  // Work (rays traced, plus kVertexCost per scattering vertex shaded):
  double costFirst = 0;   // up to the split, but the light estimates' (no split: all)
  double costLight = 0;   // of one light estimate at the first surface
  double costBeyond = 0;  // beyond the first surface, per branch
  uint32_t pixels = 0;    // 0: no pilot was needed (camera rays only see)

  /// The same terms per cell of the pilot's grid, each of one grid pixel's samples (row by row;
  /// `gridColumns` x `gridRows` cells, `gridStride` image pixels across): for branch counts
  /// that differ across the image (chooseRegions). V_first of a cell may be below 0.
  struct Cell {
    double varianceFirst = 0, varianceLight = 0, varianceBeyond = 0;
    double costFirst = 0, costLight = 0, costBeyond = 0;
  };
  std::vector<Cell> cells;
  int gridStride = 0, gridColumns = 0, gridRows = 0;

  /// What shading a scattering vertex costs, in rays: about one on the benchmark scenes, where
  /// a sample's time per part follows rays + vertices (docs/branching.md).
  static constexpr double kVertexCost = 1;

  /// The counts at the first surface: IntegratorSettings::indirectSamples and lightSamples.
  struct Choice {
    int indirectSamples = 1;
    int lightSamples = 1;
  };

  /// A camera sample's variance and cost (work) with `branches` branches and `lightEstimates`
  /// light estimates.
  double variance(int branches, int lightEstimates) const {
    return varianceFirst + varianceLight / lightEstimates + varianceBeyond / branches;
  }
  double cost(int branches, int lightEstimates) const {
    return costFirst + lightEstimates * costLight + branches * costBeyond;
  }
  /// Of the counts left free (`choice`'s counts that are 0; a count set is kept), from 1 to
  /// kMaxBranches and kMaxLightEstimates, the cheapest whose variance times cost is within
  /// kTolerance of the least; 1 for both where there was no pilot.
  Choice choose(Choice choice) const;
  /// How much more variance times cost than the least the choice may have, for a cheaper
  /// sample: the product is flat near its least, and a cheaper sample makes a first image sooner.
  static constexpr double kTolerance = 0.05;
  /// A sample's relative variance per pixel that is no noise worth paying for: (1 %)², a sample
  /// so noisy being below the benchmark's target error (5 %) by itself. The choice weighs the
  /// variance from it up: where every term is below it (a lone quad under a sun), the relative
  /// decrease of a negligible V_light would otherwise buy the most estimates.
  static constexpr double kNoiseFloor = 1e-4;

  /// Branches per region of the image, each region kRegionCells x kRegionCells cells of the
  /// grid, for `choice`'s light estimates: the counts of 1 to kMaxBranches per region whose
  /// image-wide variance times cost is least, where that is less than `choice`'s one count
  /// everywhere gives by more than kRegionMargin (else that count everywhere). Where the noise
  /// beyond the first surface differs across the image (a glass object, a lamp's shade, the
  /// sky), a count per region gives less variance for the work (docs/branching.md).
  FirstSurfaceBranches chooseRegions(Choice choice) const;
  /// Cells of the grid across a region: 2, a region holding 4 of the pilot's pixels (32 samples).
  /// With 4, the benchmark scenes measured about the same variance times time, and glass less
  /// of a gain (docs/performance-log.md).
  static constexpr int kRegionCells = 2;
  /// The least share of variance times cost that counts per region must save, by the pilot's
  /// measure, to be used: choosing the least of many noisy estimates flatters it, and on dof,
  /// predicted at 0.96 of the one count's, they measured 1.02 (docs/branching.md).
  static constexpr double kRegionMargin = 0.05;
};

/// Runs the pilot for a `width` x `height` image of `camera` rendered with `settings` (its
/// integrator's seed, depths, clamp, filter and constant dome share; guiding is left out).
/// Returns no measurement (pixels 0) where paths end before their first surface's light
/// (maxPathDepth < 1).
/// The scene must be committed. Deterministic for any thread count.
BranchingPilot runBranchingPilot(const Scene& scene, const Camera& camera, int width, int height,
                                 const RenderSettings& settings);

}  // namespace penumbra
