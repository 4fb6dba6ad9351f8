// How many paths go on from each camera ray's first surface (IntegratorSettings::indirectSamples)
// where the render leaves the count to Penumbra: chosen once per render, from a pilot
// (docs/branching.md).
//
// A camera sample's variance is that of what it finds up to and at its first surface (where in
// the pixel, on the lens and in the shutter it looks, the surface's emission and direct light),
// V_first, plus that of what lies beyond it, V_beyond; its cost is that of the camera ray, its
// hit and its light samples, C_first, plus that of the path beyond, C_beyond. N branches give
// the variance V_first + V_beyond / N for the cost C_first + N C_beyond, least in product at
// N = sqrt((V_beyond / V_first) (C_first / C_beyond)): many where most of the noise lies beyond
// the first surface and much of the cost before it (open scenes under a sky, a room lit by a
// lamp), one where the noise is the pixel's own (motion blur, texture finer than a pixel, direct
// light alone).
//
// The pilot traces, at each pixel of a sparse grid over the whole image (a crop or a farm's band
// runs the same pilot, so every band makes the same choice), two independent replicas of four
// samples, each sample branching in two: the difference of a sample's two branches estimates
// V_beyond; the covariance of a replica's mean of branches 0 and its mean of branches 1, which
// share what lies up to the first surfaces and nothing beyond, V_first / 4; the rays traced before
// and after the split, the costs. V_first so measured is that of samples stratified as a render's
// are (over the pixel's area, the lens, the shutter), which is far less than a lone sample's
// where the pixel's own noise is smooth (edges, defocus). Its numbers are its own (seeds derived
// from the render's), so the choice does not depend on the samples it is used for.
#pragma once

#include <cstdint>

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

  double varianceFirst = 0;   // V_first: of what a sample finds up to its first surface (≥ 0)
  double varianceBeyond = 0;  // V_beyond: of what one branch finds beyond it
  uint64_t raysFirst = 0;     // traced up to the split (by samples that did not split: all)
  uint64_t raysBeyond = 0;    // traced beyond it, per branch
  uint32_t pixels = 0;        // 0: no pilot was needed (no path goes beyond its first surface)

  /// A camera sample's variance and cost (rays) with `branches` branches.
  double variance(int branches) const { return varianceFirst + varianceBeyond / branches; }
  double cost(int branches) const { return double(raysFirst) + branches * double(raysBeyond); }
  /// IntegratorSettings::indirectSamples: the fewest branches (1 to kMaxBranches) whose
  /// variance times cost is within kTolerance of the least; 1 where there was no pilot.
  int indirectSamples() const;
  /// How much more variance times cost than the least the choice may have, for fewer branches:
  /// the product is flat near its least, and fewer branches cost less per sample.
  static constexpr double kTolerance = 0.05;
};

/// Runs the pilot for a `width` x `height` image of `camera` rendered with `settings` (its
/// integrator's seed, depths, clamp, filter and constant dome share; guiding is left out).
/// Returns no measurement (pixels 0) where paths end at their first surface (maxPathDepth < 2).
/// The scene must be committed. Deterministic for any thread count.
BranchingPilot runBranchingPilot(const Scene& scene, const Camera& camera, int width, int height,
                                 const RenderSettings& settings);

}  // namespace penumbra
