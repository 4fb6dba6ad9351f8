// Unidirectional path tracing with next-event estimation. Each camera sample distributes its rays
// over the pixel area (filter), the lens, the shutter and, at every vertex, the light's surface
// and the BSDF lobes; light and BSDF samples are combined by multiple importance sampling (power
// heuristic).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "penumbra/aov.h"
#include "penumbra/camera.h"
#include "penumbra/filter.h"
#include "penumbra/scene.h"

namespace penumbra {

/// How direct lighting is estimated. Only multiple importance sampling is meant for images; the
/// single strategies exist to check it (all three converge to the same result).
enum class DirectLighting { MultipleImportance, LightSamplingOnly, BsdfSamplingOnly };

class CausticPhotons;
class CausticTakeover;
class GuidingField;
class GuidingRecorder;
class LightImages;
class RayLog;

/// Most branches a path may split into at its first surface (IntegratorSettings::indirectSamples,
/// the render option's bound): more only multiply a sample's cost, and each branch's random
/// streams stay apart from every other's below 256 (PathState::branchOff).
constexpr int kMaxIndirectSamples = 16;
/// The most next-event estimates at a camera ray's first surface (IntegratorSettings).
constexpr int kMaxLightSamples = 16;

/// How many paths go on from the first surface of each pixel's camera samples: one count per
/// square region of the image, `regionSize` pixels across (the last row and column may be
/// narrower), chosen by the branching pilot (branching.h).
struct FirstSurfaceBranches {
  int regionSize = 1;
  int columns = 0, rows = 0;
  std::vector<uint8_t> counts;  // row by row

  /// The count at image pixel (x, y); 1 where there are no regions.
  int at(int x, int y) const {
    if (counts.empty()) return 1;
    const int column = std::min(x / regionSize, columns - 1);
    const int row = std::min(y / regionSize, rows - 1);
    return counts[size_t(row) * size_t(columns) + size_t(column)];
  }
  /// The mean count over the pixels of a `width` x `height` image.
  double mean(int width, int height) const {
    // The pixels of column or row i of regions (the last one takes the rest, as at() does).
    const auto span = [&](int i, int last, int size) {
      return std::max(0,
                      (i == last ? size : std::min(size, (i + 1) * regionSize)) - i * regionSize);
    };
    double sum = 0;
    for (int row = 0; row < rows; ++row)
      for (int column = 0; column < columns; ++column)
        sum += double(counts[size_t(row) * size_t(columns) + size_t(column)]) *
               double(span(column, columns - 1, width)) * double(span(row, rows - 1, height));
    return width > 0 && height > 0 ? sum / (double(width) * double(height)) : 1.0;
  }
};

struct IntegratorSettings {
  uint32_t seed = 0;
  /// Surface interactions per path: 0 shows emitters only, 1 direct lighting, 2+ indirect.
  int maxPathDepth = 8;
  /// Scattering events per lobe type along a path (the light met by the last one still counts).
  int maxDiffuseDepth = 4;
  int maxGlossyDepth = 4;
  int maxTransmissionDepth = 8;
  /// Scattering events in volumes along a path (as the lobe caps; 0: volumes absorb and emit
  /// but do not scatter light on).
  int maxVolumeDepth = 4;
  DirectLighting directLighting = DirectLighting::MultipleImportance;
  /// Largest component a sample of indirect light (two or more surface interactions) may add;
  /// 0: no limit. Biased (darker), as Cycles' "clamp indirect"; off by default.
  float indirectClamp = 0;
  /// Cycles' "filter glossy": after a bounce whose direction had density p (solid angle), the
  /// GGX α of later lobes is at least sqrt(1 − glossyFilter · p) / 2 (the smallest p of the
  /// path so far), so that light reflected by a sharp lobe after a diffuse bounce (caustics) is
  /// blurred instead of noisy. 0: off. Biased, off by default.
  float glossyFilter = 0;
  /// Paths that go on from each camera ray's first surface (branched path tracing, as Cook et
  /// al. 1984 trace several rays from a hit): the light found beyond it is the mean of this many
  /// independent continuations, while the camera ray, the surface's shading and its direct light
  /// are paid for once. 1: no branching; clamped to [1, kMaxIndirectSamples]. Unbiased. Where
  /// the first surface is a smooth dispersive solid, each of them goes on as one copy per
  /// wavelength (each refracting with its own as the hero), with or without branching.
  int indirectSamples = 1;
  /// Where set, the paths that go on from the first surface per region of the image, instead
  /// of `indirectSamples` (not owned).
  const FirstSurfaceBranches* regionBranches = nullptr;
  /// Next-event estimates at each camera ray's first surface, averaged (as Cook et al. 1984
  /// send several shadow rays to an area light): where the choice of light and the point on it
  /// are most of the noise (many lights, soft shadows), more of them cost only their shadow rays.
  /// 1: one; clamped to [1, kMaxLightSamples]. Unbiased.
  int lightSamples = 1;
  /// Path guiding (guiding.h). Where `guidingField` is set, opaque rough surfaces draw the
  /// path's next direction from its distribution there (with the probability learnt for that
  /// cell) or from their BSDF; where `guidingRecorder` is set, each sample records what training
  /// needs of those vertices. Neither is owned.
  const GuidingField* guidingField = nullptr;
  GuidingRecorder* guidingRecorder = nullptr;
  /// The lights small in the image whose directly seen emission each camera sample integrates
  /// over their image (light_images.h) instead of its camera ray finding it; not owned. Null:
  /// camera rays find every light.
  const LightImages* lightImages = nullptr;
  /// The share of its MIS weight that next-event estimation keeps for untextured dome lights at
  /// the camera rays' first surfaces, in [0, 1]: the BSDF-sampled ray that leaves the surface
  /// and escapes takes the rest (weights `share · w` and `1 − share · w` where MIS gives `w` and
  /// `1 − w`: they still sum to one in every direction, so any share is unbiased). 1: MIS, as at
  /// every other vertex; 0: no shadow ray towards them there. Which share is least noisy depends
  /// on the scene (dome_sampling.h chooses).
  float firstSurfaceConstantDomeShare = 1;
  /// Where set, an unbranched sample whose first surface gives the constant domes a share of 0
  /// also finds what a share of 1 would have changed, with the same random numbers
  /// (CameraSample::domeSamplingShift).
  bool measureConstantDomeSampling = false;
  /// Where set, the light of the lights it takes on paths from the first surface through its
  /// casters is left out: a light tracer adds it (caustics.h); not owned.
  const CausticTakeover* caustics = nullptr;
  /// With `caustics`: where set, paths that reach a receiving surface through casters alone
  /// gather the light tracer's photons of their sample index there, and the path tracer leaves
  /// out what they stand for, as on the surfaces the camera sees (caustic_photons.h); not owned.
  const CausticPhotons* causticPhotons = nullptr;
  /// Where set, the rays a sample counts in CameraSample::rays for its path (the path's rays and
  /// their shadow rays; not those towards lights seen directly, `lightImages`) are logged there
  /// as they are traced; not owned. For timing Embree alone on them.
  RayLog* rayLog = nullptr;
};

struct CameraSample {
  Vec3f radiance;
  float alpha = 0;          // 1 when the camera ray hit a surface or saw a light (dome too)
  float depth = kInfinity;  // view-axis distance of the first hit
  uint32_t rays = 0;        // rays traced through the scene's BVH (intersection and shadow)
  /// With IntegratorSettings::measureConstantDomeSampling: what `radiance` would have been
  /// with the constant domes sampled at the first surface, less what it is (RGB), and the
  /// shadow rays that finding it traced (not in `rays`: the sample's strategy does not trace
  /// them).
  Vec3f domeSamplingShift{0.0f};
  uint32_t domeSamplingShadowRays = 0;
  /// The rays of `rays` traced before the path branched at its first surface (all of them
  /// where it did not), and where it branched in two, branch 0's estimate less branch 1's (RGB,
  /// each with the light found before the split; `radiance` is their mean): what the branching
  /// pilot measures (branching.h).
  uint32_t raysBeforeBranching = 0;
  Vec3f branchDifference{0.0f};
  /// The shadow rays of `rays` that the light estimates at the first surface traced, and where
  /// there were two (IntegratorSettings::lightSamples), the first estimate less the second
  /// (RGB; `radiance` holds their mean): what the branching pilot measures too.
  uint32_t firstSurfaceLightRays = 0;
  Vec3f lightEstimateDifference{0.0f};
  /// The light samples those estimates evaluated: one per shadow ray, and one per sample of a
  /// light that casts no shadows (which traces none), which costs its evaluation all the same.
  uint32_t firstSurfaceLightSamples = 0;
  /// Scattering vertices the sample shaded (a surface's BSDF or a medium's phase function set
  /// up, its light estimated, a direction drawn), and those of them before it branched (all
  /// where it did not): with the rays, what the branching pilot counts a sample's cost in.
  uint32_t vertices = 0;
  uint32_t verticesBeforeBranching = 0;
};

/// Renders sample `sampleIndex` of pixel (x, y); a pure function of its arguments. When
/// `firstHitRecord` is given, what the camera ray met first is recorded there (for AOVs).
CameraSample renderCameraSample(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                                int x, int y, uint32_t sampleIndex,
                                const IntegratorSettings& settings,
                                FirstHitSample* firstHitRecord = nullptr);

/// Power heuristic (β = 2) weight of a strategy with density `pdf` against `otherPdf`.
inline float powerHeuristic(float pdf, float otherPdf) {
  const float a = pdf * pdf, b = otherPdf * otherPdf, sum = a + b;
  if (sum > 0 && std::isfinite(sum)) return a / sum;
  // Neither density positive, or one not a number: no weight.
  if (!(pdf > 0 || otherPdf > 0) || std::isnan(sum)) return 0.0f;
  // The squares leave float's range: a light far smaller than its distance has a density
  // beyond 1.8e19 (whose square was infinite, and the weight NaN), a vast one below 1e-19.
  // The same weight from the ratio of the two densities, the larger one dividing.
  if (pdf >= otherPdf) {
    const float ratio = otherPdf / pdf;
    return 1 / (1 + ratio * ratio);
  }
  const float ratio = pdf / otherPdf;
  return ratio * ratio / (1 + ratio * ratio);
}

}  // namespace penumbra
