// Light transport through the scene's volumes (volume_set.h) along one ray: free-flight sampling
// by spectral tracking (Kutz et al. 2017: delta tracking with history-aware event probabilities,
// so that chromatic media stay unbiased and grey ones are tracked analogously) for paths, and
// ratio tracking (Novák et al. 2014) for the transmittance of shadow rays. Both sample tentative
// collisions against the sum of the overlapping volumes' majorants, cell by cell of their
// majorant grids, so empty space costs one step per cell.
#pragma once

#include "penumbra/camera.h"
#include "penumbra/linking.h"
#include "penumbra/random_stream.h"
#include "penumbra/spectrum.h"
#include "penumbra/volume_set.h"

namespace penumbra {

/// How the path's channels read the volumes' RGB coefficients: as RGB, or (`wavelengths` set)
/// upsampled to spectra at the path's wavelengths.
struct MediumSpectrum {
  const SampledWavelengths* wavelengths = nullptr;
};

enum class FlightOutcome {
  Passed,     // no collision before tMax: the ray goes on to whatever it met there
  Scattered,  // a real scattering collision: `scattering` says where
  Absorbed,   // the path ended in the medium (its emission up to there was collected)
};

/// Which of the volumes at a point scatters there: its phase function's anisotropy and its
/// placement's linking class (linking.h).
struct ScatteringMedium {
  float anisotropy = 0;
  uint32_t linkingClass = 0;
};

/// Where a flight collided in the medium (scattered or absorbed there).
struct MediumScattering {
  Vec3f position;
  float distance = 0;         // along the ray, in its own parameter
  float anisotropy = 0;       // of the medium that scattered it
  uint32_t linkingClass = 0;  // of the medium that scattered it (light linking)
};

/// Samples where the ray first collides with the medium within [ray.tNear, tMax) (`scattering`
/// says where, unless it passed). `throughput` is the path's weight on entry and is reweighted
/// by the tracking's event probabilities; the volumes' emission met on the way is added to
/// `emitted`, already multiplied by throughput.
FlightOutcome sampleFreeFlight(const VolumeSet& volumes, const Ray& ray, float tMax,
                               const MediumSpectrum& spectrum, RandomStream& random,
                               Vec3f* throughput, Vec3f* emitted, MediumScattering* scattering);

/// An unbiased estimate of the transmittance of the volumes over [ray.tNear, tMax) for a shadow
/// ray of the light with link slot `linkSlot` (-1: linked to everything): volumes whose class
/// `linking` says its shadow link excludes are passed through.
Vec3f estimateTransmittance(const VolumeSet& volumes, const Ray& ray, float tMax,
                            const MediumSpectrum& spectrum, RandomStream& random,
                            const LinkingTable& linking, int linkSlot);

}  // namespace penumbra
