// Renders a range of samples for every pixel, in parallel over image tiles (TBB).
#pragma once

#include "penumbra/film.h"

namespace penumbra {

struct RenderSettings {
  IntegratorSettings integrator;
  int threads = 0;  // 0: all cores
};

/// Adds samples [firstSample, firstSample + sampleCount) of every active pixel to `film`.
/// The scene must be committed. Deterministic for any thread count.
void renderSamples(const Scene& scene, const Camera& camera, Film& film, uint32_t firstSample,
                   uint32_t sampleCount, const RenderSettings& settings);

}  // namespace penumbra
