// Subsurface scattering by random walk (standard_surface's and OpenPBR's subsurface): light that
// the BSDF's Subsurface lobe sends into a solid scatters through a homogeneous medium inside it
// until it crosses the surface again, elsewhere.
//
// The medium (subsurfaceMedium) is set from what artists author, not from physical
// coefficients: the colour the surface should show (the walk's multiple-scattering albedo) and a
// mean free path per channel. The single-scattering albedo α that gives a multiple-scattering
// albedo A is the inversion of van de Hulst's albedo of a semi-infinite medium that Chiang,
// Kutz and Burley fitted ("Practical and Controllable Subsurface Scattering for Production Path
// Tracing", SIGGRAPH 2016 talk):
//   α = 1 − (4.09712 + 4.20863 A − √(9.59217 + 41.6808 A + 17.7126 A²))²,
// for isotropic scattering with light entering and leaving through Lambertian (cosine) lobes.
// Anisotropic media (g ≠ 0) take that α and 1/radius as their similarity-reduced albedo and
// extinction (σs' = σs (1 − g)), so that colour and spread stay those authored whatever g.
//
// The walk (subsurfaceRandomWalk) samples free flights through a chromatic medium with one
// channel chosen in proportion to the walk's throughput and weighs them by the one-sample
// (balance heuristic) mixture over the three channels ("spectral MIS", as Wilkie et al. 2014
// and Cycles do): the weights stay bounded by the sum of the throughput's channels.
#pragma once

#include <optional>

#include "penumbra/material.h"
#include "penumbra/math.h"
#include "penumbra/random_stream.h"
#include "penumbra/scene.h"
#include "penumbra/surface_hit.h"

namespace penumbra {

/// The homogeneous medium inside a solid with subsurface scattering.
struct SubsurfaceMedium {
  Vec3f extinction{1.0f};  // σt per channel, per scene unit
  Vec3f albedo{0.0f};      // single-scattering albedo σs / σt per channel
  float anisotropy = 0;    // Henyey–Greenstein g
};

/// Largest |g| the medium takes: the similarity relation divides by 1 − α g.
constexpr float kMaxSubsurfaceAnisotropy = 0.9f;
/// Shortest mean free path, in scene units (a radius of 0 would make σt infinite).
constexpr float kMinSubsurfaceRadius = 1e-6f;
/// Longest mean free path: an infinite radius is a clear medium, as far as floats go.
constexpr float kMaxSubsurfaceRadius = 1e6f;
/// Scattering events after which a walk gives up (counted as absorbed): four times Cycles'
/// 256. With 256, a thick solid of multiple-scattering albedo 0.9 lost 2 % (g = 0) to 4 %
/// (g = 0.5, whose forward scattering needs more events for the same spread) of its light
/// (tests/cpp/test_subsurface.cpp); with 1024 the loss is below that test's noise (< 1 %).
/// Walks that long are rare: the cost is small.
constexpr int kMaxSubsurfaceSteps = 1024;

/// The single-scattering albedo whose walk in a semi-infinite medium, entered and left through
/// Lambertian lobes, has multiple-scattering albedo `multipleScatteringAlbedo` (clamped to
/// [0, 1]); see above.
float subsurfaceSingleScatteringAlbedo(float multipleScatteringAlbedo);

/// The medium of `material` (subsurfaceColor, subsurfaceRadius, subsurfaceAnisotropy): the
/// colour clamped to [0, 1], the radius to [kMinSubsurfaceRadius, kMaxSubsurfaceRadius], g to
/// ±kMaxSubsurfaceAnisotropy.
SubsurfaceMedium subsurfaceMedium(const MaterialParams& material);

/// Where a random walk left the solid.
struct SubsurfaceExit {
  /// The surface crossed, as intersectSurface gives it: the solid's own boundary, or another
  /// object met inside it first (which the walk also treats as its exit; `sameObject` false).
  SurfaceHit hit;
  /// The walk's last direction, towards and through `hit` (leaving the solid when sameObject).
  Vec3f direction;
  /// The walk's throughput: the radiance leaving at the exit is multiplied by it.
  Vec3f weight;
  bool sameObject = true;
};

/// A random walk from `entry` (a hit on a solid) into it along `inwardDirection` (a direction
/// on the side of the surface away from the incident ray, e.g. a Subsurface lobe's sample):
/// free flights and Henyey–Greenstein scattering until the walk crosses a surface. Empty when
/// the walk is absorbed (Russian roulette after 8 events, in proportion to the throughput's
/// largest channel), escapes (no surface ahead: the mesh is not closed), meets its own surface
/// from outside (an event rounded onto the far side of the surface: leaked) or takes more than
/// kMaxSubsurfaceSteps events. `time`: the ray's shutter time.
std::optional<SubsurfaceExit> subsurfaceRandomWalk(const Scene& scene, const SurfaceHit& entry,
                                                   const Vec3f& inwardDirection,
                                                   const SubsurfaceMedium& medium,
                                                   RandomStream& random, float time);

/// σa per scene unit of the interior of absorbing glass: −ln(transmissionColor) /
/// transmissionDepth per channel (colour clamped to [1e-6, 1]); zero when transmissionDepth is
/// not positive.
Vec3f transmissionAbsorption(const MaterialParams& material);

}  // namespace penumbra
