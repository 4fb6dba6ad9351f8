#include "penumbra/render.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include "on_threads.h"
#include "penumbra/light_images.h"

namespace penumbra {
namespace {
constexpr int kTileSize = 16;

/// Whether the caller's cancel flag (if it gave one) is set.
bool cancelled(const std::atomic<bool>* cancel) {
  return cancel && cancel->load(std::memory_order_relaxed);
}

/// Calls `renderPixel(x, y)` for every pixel of a `width` x `height` grid, in parallel over
/// tiles on `threads` threads (0: all cores), until `cancel` is set; returns false if it was.
template <class RenderPixel>
bool forEachPixel(int width, int height, int threads, const std::atomic<bool>* cancel,
                  const RenderPixel& renderPixel) {
  const auto renderTiles = [&] {
    tbb::parallel_for(tbb::blocked_range2d<int>(0, height, kTileSize, 0, width, kTileSize),
                      [&](const tbb::blocked_range2d<int>& tile) {
                        for (int y = tile.rows().begin(); y < tile.rows().end(); ++y)
                          for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
                            if (cancelled(cancel)) return;
                            renderPixel(x, y);
                          }
                      });
  };
  onThreads(threads, renderTiles);
  return !cancelled(cancel);
}

}  // namespace

bool renderSamples(const Scene& scene, const Camera& camera, Film& film, uint32_t firstSample,
                   uint32_t sampleCount, const RenderSettings& settings,
                   const std::atomic<bool>* cancel) {
  const PixelFilter filter;
  const LightImages lightImages(scene.lights().all(), camera, filter.radius());
  IntegratorSettings integrator = settings.integrator;
  if (!lightImages.empty()) integrator.lightImages = &lightImages;
  return forEachPixel(film.width(), film.height(), settings.threads, cancel, [&](int x, int y) {
    if (!film.isActive(x, y)) return;
    // Samples are seeded by the pixel's position in the image, not on the film.
    const int imageX = film.region().x + x, imageY = film.region().y + y;
    for (uint32_t s = firstSample; s < firstSample + sampleCount; ++s) {
      if (cancelled(cancel)) return;
      if (film.wantsFirstHit()) {
        FirstHitSample firstHit;
        const CameraSample sample =
            renderCameraSample(scene, camera, filter, imageX, imageY, s, integrator, &firstHit);
        film.addSample(x, y, s, sample, &firstHit);
      } else {
        film.addSample(x, y, s,
                       renderCameraSample(scene, camera, filter, imageX, imageY, s, integrator));
      }
    }
  });
}

bool traceSamples(const Scene& scene, const Camera& camera, int width, int height,
                  uint32_t firstSample, uint32_t sampleCount, const RenderSettings& settings,
                  const std::atomic<bool>* cancel) {
  // No image is kept: the light images, which only add to it, are left out.
  const PixelFilter filter;
  return forEachPixel(width, height, settings.threads, cancel, [&](int x, int y) {
    for (uint32_t s = firstSample; s < firstSample + sampleCount; ++s) {
      if (cancelled(cancel)) return;
      renderCameraSample(scene, camera, filter, x, y, s, settings.integrator);
    }
  });
}

}  // namespace penumbra
