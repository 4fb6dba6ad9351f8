// Renders a range of samples for every pixel, in parallel over image tiles (TBB).
#pragma once

#include <atomic>

#include "penumbra/film.h"

namespace penumbra {

struct RenderSettings {
  IntegratorSettings integrator;
  int threads = 0;  // 0: all cores
};

/// Adds samples [firstSample, firstSample + sampleCount) of every active pixel to `film`, whose
/// region places it in the camera's image (a film of part of the image renders exactly those
/// pixels of the whole image).
/// The scene must be committed. Deterministic for any thread count. Once `cancel` (when given)
/// is set, every thread stops at its next sample and false is returned: the film then holds
/// an unknown subset of the samples and must be cleared.
bool renderSamples(const Scene& scene, const Camera& camera, Film& film, uint32_t firstSample,
                   uint32_t sampleCount, const RenderSettings& settings,
                   const std::atomic<bool>* cancel = nullptr);

/// Traces samples [firstSample, firstSample + sampleCount) of every pixel of a `width` x
/// `height` image for what they record (IntegratorSettings::guidingRecorder), keeping no image.
/// Returns false once `cancel` is set.
bool traceSamples(const Scene& scene, const Camera& camera, int width, int height,
                  uint32_t firstSample, uint32_t sampleCount, const RenderSettings& settings,
                  const std::atomic<bool>* cancel = nullptr);

}  // namespace penumbra
