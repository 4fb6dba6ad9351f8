// Caustics by light tracing. Light that leaves a lamp, passes one or more smooth glass or metal
// surfaces (the casters) and lands on the first surface a camera ray sees is found by a path
// tracer only where a path from that surface happens to pass through the casters to the lamp: a
// small bright target (fireflies). Traced from the lamp, through the casters to that surface and
// joined to the camera, the same light is a smooth estimate (Veach 1997, §10.2; pbrt-v4's
// LightPathIntegrator).
//
// The two share the work exactly: the path tracer leaves out the light of the lamps this tracer
// takes (CausticTakeover::takesLight) on paths whose first surface receives (receivesCaustics)
// and whose later vertices, one to maxCasters() of them, are all casters; the light tracer adds
// exactly those paths. Where the last of them (the lamp's side) is a caster above a diffuse
// layer (CasterKind::AboveDiffuse: smooth plastic), the path tracer keeps that layer's part and
// the light tracer adds the rest. Together they are unbiased.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/caustic_photons.h"
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

/// How a material takes part in the light tracer's paths.
enum class CasterKind : uint8_t {
  None,
  /// castsCaustics: every lobe is narrow, and light passes one to maxCasters() such surfaces.
  Whole,
  /// Opaque and no caster, but its layers above the diffuse one (specular, clearcoat) are
  /// smooth, as on plastic or lacquer: the light tracer takes their light where they are the
  /// first surface its path meets; the diffuse layer's light stays with the path tracer.
  AboveDiffuse,
};
CasterKind casterKind(const MaterialParams& material);

/// Whether the BSDF at a hit splits at its diffuse layer as the two tracers share an
/// AboveDiffuse caster's light: opaque there, without sheen, subsurface scattering or hair.
/// Textures may give a hit what its material's constants, which casterKind reads, lack.
bool splitsAboveDiffuse(const MaterialParams& atHit);

/// The most casters between a surface and a lamp that no depth limit of `settings` cuts, the
/// path having made the given bounces of each kind (and `bounce` in all) before that surface: a
/// path with k casters scatters k times before its last caster (at the surface once, at the
/// casters but the last one each once), and once more there towards the lamp.
int castersWithinDepthLimits(const IntegratorSettings& settings, int diffuseBounces,
                             int glossyBounces, int transmissionBounces, int bounce);

/// Whether a surface can receive caustics from the light tracer: it is no caster, no hair fibre
/// and has no subsurface scattering (its BSDF is evaluated between any two directions).
bool receivesCaustics(const MaterialParams& material);

/// What the path tracer leaves to the light tracer (IntegratorSettings::caustics).
class CausticTakeover {
 public:
  CausticTakeover() = default;
  /// How each light `index` (LightSet::all()) is taken.
  enum class LightTaken : uint8_t {
    No,
    /// Through Whole casters alone.
    PastWholeCasters,
    /// Through AboveDiffuse casters too: its diffuse and specular multipliers are equal (the
    /// path tracer weighs light it samples by the lobe it sampled, which the two tracers'
    /// shares of an AboveDiffuse surface do not follow).
    PastEveryCaster,
  };
  CausticTakeover(std::vector<CasterKind> casterMaterials, std::vector<LightTaken> lights,
                  int maxCasters)
      : casterMaterials_(std::move(casterMaterials)),
        lights_(std::move(lights)),
        maxCasters_(maxCasters) {}

  /// How material `index` (MaterialTable's; kNoMaterial for none) casts.
  CasterKind casterKind(int index) const {
    return index >= 0 && size_t(index) < casterMaterials_.size() ? casterMaterials_[size_t(index)]
                                                                 : CasterKind::None;
  }
  /// How a hit of material `index` whose (textured) parameters are `atHit` casts: as its
  /// material, but no AboveDiffuse caster where its BSDF there does not split
  /// (splitsAboveDiffuse). Both tracers classify their hits by it.
  CasterKind casterKindAt(int index, const MaterialParams& atHit) const {
    const CasterKind kind = casterKind(index);
    return kind == CasterKind::AboveDiffuse && !splitsAboveDiffuse(atHit) ? CasterKind::None : kind;
  }
  /// Whether material `index` is a Whole caster.
  bool isCaster(int index) const { return casterKind(index) == CasterKind::Whole; }
  /// Whether the light tracer starts paths on light `index` (LightSet::all()).
  bool takesLight(size_t index) const {
    return index < lights_.size() && lights_[index] != LightTaken::No;
  }
  /// Whether it takes that light's part above the diffuse layer of AboveDiffuse casters too.
  bool takesLightAboveDiffuse(size_t index) const {
    return index < lights_.size() && lights_[index] == LightTaken::PastEveryCaster;
  }
  /// Whether it takes light `index` on a path it takes whose last caster is AboveDiffuse or not:
  /// all of it past a Whole caster, the part above the diffuse layer past an AboveDiffuse one.
  bool takesLightPast(size_t index, bool pastAboveDiffuse) const {
    return pastAboveDiffuse ? takesLightAboveDiffuse(index) : takesLight(index);
  }
  /// The most casters between a light and the receiving surface on the paths taken: paths with
  /// more stay with the path tracer. Small enough that no depth limit cuts a path taken.
  int maxCasters() const { return maxCasters_; }

 private:
  std::vector<CasterKind> casterMaterials_;  // by material index
  std::vector<LightTaken> lights_;           // by light index
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
  /// Light paths aim at a sphere around each caster up to this many casters; beyond, at one
  /// around each kind's.
  static constexpr size_t kMaxTargets = 16;
  /// What the power that reaches an AboveDiffuse caster counts for in choosing where light
  /// paths aim, against a Whole caster's: about the share of light its smooth layers reflect
  /// (docs/caustics.md).
  static constexpr float kAboveDiffuseShare = 0.1f;

  /// Prepares to trace `scene` (committed) as seen by `camera` with `filter`. It takes nothing
  /// (active() is false) unless there are casters and lights it can start from, and not for
  /// renders that it could not match: volumes, objects hidden from some rays (ray visibility), an
  /// orthographic camera, Cycles-like clamping or glossy filtering (which change the path tracer's
  /// caustics).
  CausticTracer(const Scene& scene, const Camera& camera, const PixelFilter& filter,
                const IntegratorSettings& settings);

  bool active() const { return !startCdf_.empty(); }
  /// For IntegratorSettings::caustics (valid while this tracer lives).
  const CausticTakeover& takeover() const { return takeover_; }

  /// Traces the light paths of sample indices [firstSample, firstSample + sampleCount) and adds
  /// them to `film` (its region of the image), on `threads` threads (0: all cores). The film
  /// receives the same sums in the same order whatever the thread count or how a render's sample
  /// indices are split into calls; each light path's rays count at a pixel of its own
  /// (Film::addRays), so that regions of the image share them out. Where `photons` is given (made
  /// by makePhotons), it then holds those sample indices' arrivals on receivers
  /// (caustic_photons.h), each index's in path order. Returns false (the film then holds part of
  /// them and must be cleared) once `cancel` is set.
  bool trace(uint32_t firstSample, uint32_t sampleCount, Film& film, int threads,
             const std::atomic<bool>* cancel = nullptr, CausticPhotons* photons = nullptr) const;
  /// An empty holder of photons for trace(), normalised by this tracer's paths per sample.
  CausticPhotons makePhotons() const { return CausticPhotons(pathsPerSample_); }

 private:
  struct Splat {
    int x, y;
    Vec3f light;
  };
  /// Where a light path leaves its light, and β there: the radiance (RGB, along the ray) times
  /// `weight`, the geometry over the densities (area measure), before the light's choice.
  struct LightPathStart {
    Ray ray;
    Vec3f radiance;
    float weight;
  };
  /// A sphere around casters that light paths aim at.
  struct Target {
    Vec3f centre;
    float radius;
    CasterKind kind;
  };
  /// A light and a target it aims at, chosen together by about the power that reaches the
  /// target (startCdf_). A light's are consecutive: [lightsFirst, lightsEnd).
  struct Start {
    uint32_t light, target;
    uint32_t lightsFirst, lightsEnd;
  };
  /// From a sphere, rect or disk light: a point on it, a direction towards start `startIndex`'s
  /// target.
  std::optional<LightPathStart> startOnSurface(const Light& light, size_t startIndex,
                                               RandomStream& random) const;
  /// From a distant light: a direction from it, a point of the target's cross-section.
  std::optional<LightPathStart> startFromAfar(const Light& light, size_t startIndex,
                                              RandomStream& random) const;
  /// 1 − cos of the half angle of the cone from `from` around `target`; empty within it.
  static std::optional<float> coneTowards(const Target& target, const Vec3f& from);
  float startProbability(size_t index) const;
  /// Traces light path `path` of sample index `sample`, appending its splats, and its arrival on
  /// a receiver to `photons` where given; returns the rays it traced.
  uint32_t tracePath(uint32_t sample, uint32_t path, std::vector<Splat>& splats,
                     std::vector<Photon>* photons) const;
  /// The footprint of a camera ray (RayCone radius) where `photons` lie, on average, for camera
  /// rays from `centre`.
  float meanFootprint(const std::vector<Photon>& photons, const Vec3f& centre) const;

  const Scene& scene_;
  const Camera& camera_;
  const PixelFilter& filter_;
  uint32_t seed_ = 0;
  CausticTakeover takeover_;
  uint32_t pathsPerSample_ = 0;
  std::vector<Target> targets_;
  /// The least share of the light paths a lamp may have (its starts' powers over `total`):
  /// the float choice of a start resolves it to within 0.1 %.
  static constexpr float kMinLampShare = 0x1p-14f;
  /// Drops the starts of lamps below kMinLampShare (not taken over), and `total` with them.
  void leaveDimLampsToThePathTracer(const std::vector<float>& powers, float& total,
                                    std::vector<CausticTakeover::LightTaken>& taken);

  std::vector<Start> starts_;
  std::vector<float> startCdf_;  // choosing among starts_, ascending to 1
};

}  // namespace penumbra
