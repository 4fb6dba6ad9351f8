// How much of an untextured dome's light next-event estimation takes at the camera rays' first
// surfaces, the BSDF-sampled ray the rest: chosen once per render, from a pilot
// (docs/dome-sampling.md).
//
// Under a constant sky, a surface receives the sky's light wherever the sky is not occluded.
// Next-event estimation finds that with a shadow ray in a direction of its own; the BSDF-sampled
// ray that continues the path finds, in directions drawn alike, either the sky or an occluder
// and the light that occluder sends back. Where occluders are about as bright as the sky (sunlit
// geometry under a blue sky), that one ray estimates all the light arriving at the surface with
// little variance, and the shadow ray, independent of it, adds noise: leaving the sky to the
// BSDF-sampled ray is then less noisy, and cheaper by a shadow ray. Where occluders are black,
// the shadow ray's MIS share halves the sky's noise; where they are dark but not black (a sky
// alone over light objects), a smaller share is best. Deeper vertices, whose occluders are lit
// only by what paths bring back, are better off with MIS everywhere, and keep it.
//
// Which holds depends on the scene as the camera sees it, so a pilot measures it: two samples at
// each pixel of a sparse grid over the whole image (a crop or a farm's band runs the same pilot,
// so every band makes the same choice), each traced with the sky left to the BSDF-sampled ray
// and measured as it would have been with MIS, with the same random numbers
// (IntegratorSettings::measureConstantDomeSampling). A sample is linear in the share
// (IntegratorSettings::firstSurfaceConstantDomeShare), so its variance is quadratic in it, and
// each pixel's pair of samples estimates the quadratic's terms. The pilot keeps share 0 (no
// shadow ray) or the share of least variance (with a shadow ray), whichever has less variance
// times cost. Its numbers are its own (a seed derived from the render's), so the choice does not
// depend on the samples it is used for; it costs at most half a sample per pixel (about 0.03 of
// one at 640 x 360).
#pragma once

#include <cstdint>

#include "penumbra/camera.h"
#include "penumbra/render.h"
#include "penumbra/scene.h"

namespace penumbra {

/// How untextured domes are found at the camera rays' first surfaces (the domeSampling render
/// setting): with the share the pilot chooses, by next-event estimation and the BSDF-sampled ray
/// weighed by MIS (share 1), or by the BSDF-sampled ray alone (share 0).
enum class DomeSampling { Auto, Mis, Bsdf };

/// What the pilot measured, relative to the image (each pixel's and channel's variance over its
/// squared value + 0.01, as bench/quality.py weighs error) and summed over the grid: the
/// variance of samples that give the domes a share of 0 (U), that of the shift a share of 1
/// would add to them (D), and their covariance; and the rays each traces. A share k gives the
/// sample U + k·D (the weights are linear in k), of variance
/// varianceUnsampled + 2k·covariance + k²·varianceShift.
struct DomeSamplingPilot {
  /// What a shadow ray towards a constant dome costs, as a share of an average ray of the path
  /// (whose hits are shaded): the time that leaving those shadow rays out saved per ray left out,
  /// measured on the five benchmark scenes at 320 px, was 0.56-0.87 of it.
  static constexpr double kDomeShadowRayCost = 0.6;
  /// Shares are chosen among multiples of this: the variance is flat near its least, and a
  /// share that stays put while the scene changes a little keeps the images' noise put too.
  static constexpr double kShareStep = 0.125;

  double varianceUnsampled = 0, varianceShift = 0, covariance = 0;
  uint64_t rays = 0;            // traced with a share of 0
  uint64_t domeShadowRays = 0;  // traced besides with a share above 0
  uint32_t pixels = 0;          // 0: no pilot was needed (no constant dome, or not MIS)

  /// The variance of samples with share `share`.
  double variance(double share) const {
    return varianceUnsampled + 2 * share * covariance + share * share * varianceShift;
  }
  /// IntegratorSettings::firstSurfaceConstantDomeShare: 0, or the share of least variance
  /// (a multiple of kShareStep above 0), whichever has less variance times cost; 1 where there
  /// was no pilot.
  float firstSurfaceShare() const;
};

/// Runs the pilot for a `width` x `height` image of `camera` rendered with `settings` (its
/// integrator's seed, depths, clamp and filter; guiding and branching are left out). Returns no
/// measurement (pixels 0) where the scene has no untextured dome or direct lighting is not
/// estimated by multiple importance sampling. The scene must be committed. Deterministic for
/// any thread count.
DomeSamplingPilot runDomeSamplingPilot(const Scene& scene, const Camera& camera, int width,
                                       int height, const RenderSettings& settings);

}  // namespace penumbra
