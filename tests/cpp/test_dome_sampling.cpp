// Untextured domes at the camera rays' first surfaces (dome_sampling.h): the share of its MIS
// weight next-event estimation keeps for them, from none (left to BSDF sampling) to all, every
// share unbiased, the pilot choosing the least noisy, the same for any crop and thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "image_stats.h"
#include "penumbra/dome_sampling.h"
#include "penumbra/filter.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::ballsUnderSky;
using penumbra::test::cropOf;
using penumbra::test::facingDown;
using penumbra::test::meanRed;
using penumbra::test::redSquaredDifference;
using penumbra::test::syncedCamera;
using namespace penumbra::plugin;

namespace {

constexpr int kSize = 32;

/// The colour (RGBA) of ballsUnderSky at `samples` per pixel, with the domeSampling setting
/// `domeSampling` (DomeSampling's levels), on `threads` threads, of the pixels of `crop`.
std::vector<float> renderBalls(bool sun, DomeSampling domeSampling, int samples, int seed,
                               int threads = 0, PixelRect crop = {0, 0, kSize, kSize}) {
  RenderDelegate delegate;
  ballsUnderSky(delegate, sun);
  delegate.settings().set("domeSampling", double(domeSampling));
  // Unbranched, so that the noise compared is the dome's sampling alone.
  delegate.settings().set("indirectSamples", 1);
  delegate.settings().set("seed", seed);
  delegate.settings().set("threads", threads);
  RenderPass pass(delegate, "/cam", kSize, kSize, crop);
  pass.execute(samples);
  return pass.aov("color");
}

/// The pilot's measurement of ballsUnderSky.
DomeSamplingPilot pilotOf(bool sun, int seed = 0, int threads = 0) {
  RenderDelegate delegate;
  ballsUnderSky(delegate, sun);
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
  RenderSettings settings;
  settings.integrator.seed = uint32_t(seed);
  settings.threads = threads;
  return runDomeSamplingPilot(delegate.scene(), camera, kSize, kSize, settings);
}

}  // namespace

TEST(DomeSampling, ASampleIsLinearInTheDomesShare) {
  // With the same random numbers, a sample with share k is the sample with share 0 plus k times
  // the shift the measurement finds (the MIS weights are linear in k).
  RenderDelegate delegate;
  ballsUnderSky(delegate, true);
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
  const PixelFilter filter;
  IntegratorSettings measured;
  measured.firstSurfaceConstantDomeShare = 0;
  measured.measureConstantDomeSampling = true;
  IntegratorSettings unsampled = measured;
  unsampled.measureConstantDomeSampling = false;
  int shifted = 0;
  for (int y = 0; y < kSize; y += 3)
    for (int x = 0; x < kSize; x += 3)
      for (uint32_t s = 0; s < 4; ++s) {
        const CameraSample b =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, measured);
        const CameraSample c =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, unsampled);
        // Measuring changes nothing of the sample itself.
        for (int k = 0; k < 3; ++k) ASSERT_EQ(b.radiance[k], c.radiance[k]);
        ASSERT_EQ(b.rays, c.rays);
        ASSERT_EQ(c.domeSamplingShadowRays, 0u);
        shifted += !isBlack(b.domeSamplingShift);
        for (const float share : {0.375f, 1.0f}) {
          IntegratorSettings shared;
          shared.firstSurfaceConstantDomeShare = share;
          const CameraSample a =
              renderCameraSample(delegate.scene(), camera, filter, x, y, s, shared);
          const Vec3f expected = b.radiance + b.domeSamplingShift * share;
          for (int k = 0; k < 3; ++k)
            ASSERT_NEAR(a.radiance[k], expected[k], 1e-4f * std::max(1.0f, expected[k]));
          ASSERT_EQ(a.rays, b.rays + b.domeSamplingShadowRays);
        }
      }
  EXPECT_GT(shifted, 100);  // most samples see the sky and shift
}

TEST(DomeSampling, EveryShareConvergesToTheSameImage) {
  for (const bool sun : {false, true}) {
    const double mis = meanRed(renderBalls(sun, DomeSampling::Mis, 256, 1));
    ASSERT_GT(mis, 0.1);
    for (const DomeSampling other : {DomeSampling::Bsdf, DomeSampling::Auto})
      EXPECT_NEAR(meanRed(renderBalls(sun, other, 256, 1)) / mis, 1.0, 0.01)
          << "sun " << sun << ", strategy " << int(other);
  }
}

TEST(DomeSampling, PilotChoosesTheShareOfLeastNoise) {
  const int spp = 16;
  // The difference of two seeds' images measures the noise.
  const auto noise = [&](bool sun, DomeSampling strategy) {
    return redSquaredDifference(renderBalls(sun, strategy, spp, 1),
                                renderBalls(sun, strategy, spp, 2));
  };
  // Sunlit balls hide the sky from the floor: the BSDF-sampled ray that finds either is the
  // less noisy estimate, and saves a shadow ray.
  EXPECT_EQ(pilotOf(true).firstSurfaceShare(), 0.0f);
  EXPECT_LT(noise(true, DomeSampling::Bsdf), 0.9 * noise(true, DomeSampling::Mis));
  EXPECT_EQ(renderBalls(true, DomeSampling::Auto, 4, 1),
            renderBalls(true, DomeSampling::Bsdf, 4, 1));
  // Under the sky alone the balls are darker than the sky, but not black: the shadow ray pays,
  // with less of the sky's light than MIS gives it.
  const DomeSamplingPilot skyAlone = pilotOf(false);
  EXPECT_GT(skyAlone.firstSurfaceShare(), 0.0f);
  EXPECT_LT(skyAlone.firstSurfaceShare(), 1.0f);
  const double mis = noise(false, DomeSampling::Mis);
  EXPECT_LT(mis, 0.9 * noise(false, DomeSampling::Bsdf));
  EXPECT_LT(noise(false, DomeSampling::Auto), 0.95 * mis);
}

TEST(DomeSampling, PilotIsTheSameForAnyThreadsAndCrop) {
  const DomeSamplingPilot one = pilotOf(true, 3, 1), two = pilotOf(true, 3, 2);
  EXPECT_EQ(one.varianceUnsampled, two.varianceUnsampled);
  EXPECT_EQ(one.varianceShift, two.varianceShift);
  EXPECT_EQ(one.covariance, two.covariance);
  EXPECT_EQ(one.rays, two.rays);
  EXPECT_EQ(one.domeShadowRays, two.domeShadowRays);
  // A band runs the whole image's pilot, so its pixels are the whole image's.
  for (const bool sun : {false, true}) {
    const std::vector<float> whole = renderBalls(sun, DomeSampling::Auto, 4, 1, 1);
    const PixelRect band{0, 10, kSize, 7};
    EXPECT_EQ(renderBalls(sun, DomeSampling::Auto, 4, 1, 2, band), cropOf(whole, kSize, 4, band));
  }
}

TEST(DomeSampling, WithoutAConstantDomeThereIsNoPilotAndNothingChanges) {
  RenderDelegate delegate;
  addFloor(delegate, "/floor", 20);
  delegate.insertSprim("distantLight", "/sun");
  delegate.light("/sun").setTransform(facingDown(0, 10, 0));
  addCamera(delegate, facingDown(0, 5, 0), 1.5f);
  RenderPass pass(delegate, "/cam", kSize, kSize);
  pass.execute(0);
  const penumbra::Camera camera(delegate.camera("/cam").params(), kSize, kSize);
  const DomeSamplingPilot pilot =
      runDomeSamplingPilot(delegate.scene(), camera, kSize, kSize, RenderSettings());
  EXPECT_EQ(pilot.pixels, 0u);
  EXPECT_EQ(pilot.firstSurfaceShare(), 1.0f);
  pass.execute(4);
  const std::vector<float> mis = pass.aov("color");
  delegate.settings().set("domeSampling", double(DomeSampling::Bsdf));
  pass.execute(4);  // a changed setting starts the render again
  EXPECT_EQ(pass.aov("color"), mis);
}
