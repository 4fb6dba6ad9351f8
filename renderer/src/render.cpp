#include "penumbra/render.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace penumbra {
namespace {
constexpr int kTileSize = 16;
}

bool renderSamples(const Scene& scene, const Camera& camera, Film& film, uint32_t firstSample,
                   uint32_t sampleCount, const RenderSettings& settings,
                   const std::atomic<bool>* cancel) {
  const PixelFilter filter;
  const auto cancelled = [cancel] { return cancel && cancel->load(std::memory_order_relaxed); };
  const auto renderTiles = [&] {
    tbb::parallel_for(
        tbb::blocked_range2d<int>(0, film.height(), kTileSize, 0, film.width(), kTileSize),
        [&](const tbb::blocked_range2d<int>& tile) {
          for (int y = tile.rows().begin(); y < tile.rows().end(); ++y)
            for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
              if (!film.isActive(x, y)) continue;
              for (uint32_t s = firstSample; s < firstSample + sampleCount; ++s) {
                if (cancelled()) return;
                if (film.wantsFirstHit()) {
                  FirstHitSample firstHit;
                  const CameraSample sample = renderCameraSample(scene, camera, filter, x, y, s,
                                                                 settings.integrator, &firstHit);
                  film.addSample(x, y, s, sample, &firstHit);
                } else {
                  film.addSample(
                      x, y, s,
                      renderCameraSample(scene, camera, filter, x, y, s, settings.integrator));
                }
              }
            }
        });
  };
  if (settings.threads > 0) {
    tbb::task_arena arena(settings.threads);
    arena.execute(renderTiles);
  } else {
    renderTiles();
  }
  return !cancelled();
}

}  // namespace penumbra
