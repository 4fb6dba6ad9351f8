// Caustics by light tracing. Light that leaves a lamp, passes one or more smooth glass or metal
// surfaces (the casters) and lands on the first surface a camera ray sees is found by a path
// tracer only where a path from that surface happens to pass through the casters to the lamp: a
// small bright target (fireflies). Traced from the lamp, through the casters to that surface and
// joined to the camera, the same light is a smooth estimate (Veach 1997, §10.2; pbrt-v4's
// LightPathIntegrator).
//
// The two share the work exactly: the path tracer leaves out the light of the lamps this tracer
// takes (CausticTakeover::takesLight) on paths whose first surface receives (receives()) and
// whose later vertices, one to maxCasters() of them, are all casters; the light tracer adds
// exactly those paths. Together they are unbiased.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "penumbra/material.h"
#include "penumbra/random_stream.h"
#include "penumbra/scene.h"

namespace penumbra {

class Film;

/// GGX roughness up to which a material casts caustics (castsCaustics). Measured on a metal box
/// in a Cornell box (docs/caustics.md): light tracing cut variance × time by 18 % at roughness
/// 0.3 and by 3 % at 0.5, where the path tracer's light samples at the metal already find most
/// of the lamp.
constexpr float kCausticMaxRoughness = 0.4f;

/// Whether a material is a caster: metal (metallic workflow, metallic 1) or clear glass (opacity
/// 0, no absorption), smooth (roughness, transmission and coat roughness up to
/// kCausticMaxRoughness), without hair, sheen or subsurface scattering: every lobe it has is
/// narrow.
bool castsCaustics(const MaterialParams& material);

/// Whether a surface can receive caustics from the light tracer: it is no caster, no hair fibre
/// and has no subsurface scattering (its BSDF is evaluated between any two directions).
bool receivesCaustics(const MaterialParams& material);

/// What the path tracer leaves to the light tracer (IntegratorSettings::caustics).
class CausticTakeover {
 public:
  CausticTakeover() = default;
  CausticTakeover(std::vector<uint8_t> casterMaterials, std::vector<uint8_t> lights, int maxCasters)
      : casterMaterials_(std::move(casterMaterials)),
        lights_(std::move(lights)),
        maxCasters_(maxCasters) {}

  /// Whether material `index` (MaterialTable's; kNoMaterial for none) is a caster.
  bool isCaster(int index) const {
    return index >= 0 && size_t(index) < casterMaterials_.size() && casterMaterials_[size_t(index)];
  }
  /// Whether the light tracer starts paths on light `index` (LightSet::all()).
  bool takesLight(size_t index) const { return index < lights_.size() && lights_[index]; }
  /// The most casters between a light and the receiving surface on the paths taken: paths with
  /// more stay with the path tracer. Small enough that no depth limit cuts a path taken.
  int maxCasters() const { return maxCasters_; }

 private:
  std::vector<uint8_t> casterMaterials_;  // by material index: 1 for a caster
  std::vector<uint8_t> lights_;           // by light index: 1 where taken
  int maxCasters_ = 0;
};

/// Traces paths from the lights through the casters and splats what reaches the camera onto a
/// film (Film::addSplat), so that the film holds what the path tracer leaves out.
class CausticTracer {
 public:
  /// Light paths per pixel of the image for each sample index: a render of N samples per pixel
  /// traces N · kPathsPerPixel · width · height of them. On the benchmark's glass ball their
  /// noise was already below the path tracer's at 0.05 (docs/caustics.md): more cost time.
  static constexpr float kPathsPerPixel = 0.1f;

  /// Prepares to trace `scene` (committed) as seen by `camera` with `filter`. It takes nothing
  /// (active() is false) unless there are casters and lights it can start from, and not for
  /// renders that it could not match: spectral scenes (dispersion), volumes, objects hidden
  /// from some rays (ray visibility), an orthographic camera, Cycles-like clamping or glossy
  /// filtering (which change the path tracer's caustics).
  CausticTracer(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                const IntegratorSettings& settings);

  bool active() const { return !lightCdf_.empty(); }
  /// For IntegratorSettings::caustics (valid while this tracer lives).
  const CausticTakeover& takeover() const { return takeover_; }

  /// Traces the light paths of sample indices [firstSample, firstSample + sampleCount) and adds
  /// them to `film` (its region of the image), on `threads` threads (0: all cores). The film
  /// receives the same sums in the same order whatever the thread count or how a render's sample
  /// indices are split into calls. Returns false (the film then holds part of them and must be
  /// cleared) once `cancel` is set.
  bool trace(uint32_t firstSample, uint32_t sampleCount, Film& film, int threads,
             const std::atomic<bool>* cancel = nullptr) const;

 private:
  struct Splat {
    int x, y;
    Vec3f light;
  };
  /// Where a light path leaves its light, and β there: the radiance times the geometry over
  /// the densities (area measure), before the light's choice.
  struct LightPathStart {
    Ray ray;
    Vec3f beta;
  };
  /// From a sphere, rect or disk light: a point on it, a direction towards the casters.
  std::optional<LightPathStart> startOnSurface(const Light& light, RandomStream& random) const;
  /// From a distant light: a direction from it, a point of the casters' cross-section.
  std::optional<LightPathStart> startFromAfar(const Light& light, RandomStream& random) const;
  /// Traces light path `path` of sample index `sample`, appending its splats.
  void tracePath(uint32_t sample, uint32_t path, std::vector<Splat>& splats) const;

  const Scene& scene_;
  const Camera& camera_;
  const PixelFilter& filter_;
  uint32_t seed_ = 0;
  CausticTakeover takeover_;
  uint32_t pathsPerSample_ = 0;
  Vec3f castersCentre_{0.0f};
  float castersRadius_ = 0;
  std::vector<uint32_t> lightIndices_;  // the lights taken
  std::vector<float> lightCdf_;         // choosing among them by power, ascending to 1
};

}  // namespace penumbra
