// Branching at the first surface chosen per render (branching.h): what a sample records for the
// pilot, the pilot's choice where the noise lies beyond the first surface and where it does not,
// the same for any crop and thread count.
#include <gtest/gtest.h>

#include <vector>

#include "image_stats.h"
#include "penumbra/branching.h"
#include "penumbra/filter.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::addCamera;
using penumbra::test::ballsUnderSky;
using penumbra::test::cropOf;
using penumbra::test::facingDown;
using penumbra::test::floorLitByCeiling;
using penumbra::test::redSquaredDifference;
using namespace penumbra::plugin;

namespace {

constexpr int kSize = 32;

/// The pilot's measurement of the delegate's scene, seen by "/cam", with its settings' depth.
BranchingPilot pilotOf(RenderDelegate& delegate, int threads = 0) {
  RenderPass pass(delegate, "/cam", kSize, kSize);
  pass.execute(0);  // sync
  const penumbra::Camera camera(delegate.camera("/cam").params(), kSize, kSize);
  RenderSettings settings;
  settings.threads = threads;
  settings.integrator.maxPathDepth = delegate.settings().maxPathDepth;
  return runBranchingPilot(delegate.scene(), camera, kSize, kSize, settings);
}

/// A black and white checkerboard, its squares a fifth of a pixel across, under a sun straight
/// above and nothing else: where in the pixel a sample looks is all its noise (the squares are
/// finer than the samples' stratification), and the board's bounces escape to the empty sky.
void fineCheckerboardInTheSun(RenderDelegate& delegate) {
  constexpr int kSquares = 160;  // across the view's 3.3 units, seen over kSize pixels
  constexpr float kHalfSize = 1.7f, kStep = 2 * kHalfSize / kSquares;
  std::vector<Vec3f> points;
  for (int row = 0; row <= kSquares; ++row)
    for (int column = 0; column <= kSquares; ++column)
      points.push_back({-kHalfSize + kStep * float(column), 0, -kHalfSize + kStep * float(row)});
  std::vector<int> counts, indices;
  std::vector<Vec3f> colors;
  for (int row = 0; row < kSquares; ++row)
    for (int column = 0; column < kSquares; ++column) {
      const int corner = row * (kSquares + 1) + column;
      counts.push_back(4);
      indices.insert(indices.end(),
                     {corner, corner + kSquares + 1, corner + kSquares + 2, corner + 1});
      colors.push_back(Vec3f((row + column) % 2 ? 0.8f : 0.0f));
    }
  delegate.insertRprim("mesh", "/board");
  Mesh& board = delegate.mesh("/board");
  board.setPoints(points);
  board.setTopology(counts, indices, false, "none");
  board.setDisplayColor(colors, Interpolation::Uniform);
  delegate.insertSprim("distantLight", "/sun");
  delegate.light("/sun").setParam("angle", 0.0f);
  delegate.light("/sun").setTransform(facingDown(0, 10, 0));
  addCamera(delegate, facingDown(0, 5, 0), 1.5f);
}

}  // namespace

TEST(Branching, ASampleKeepsItsBranchesDifferenceAndTheRaysBeforeTheSplit) {
  RenderDelegate delegate;
  ballsUnderSky(delegate, true);
  RenderPass pass(delegate, "/cam", kSize, kSize);
  pass.execute(0);  // sync
  const penumbra::Camera camera(delegate.camera("/cam").params(), kSize, kSize);
  const PixelFilter filter;
  IntegratorSettings unbranched, twoBranches;
  twoBranches.indirectSamples = 2;
  int differing = 0;
  for (int y = 0; y < kSize; y += 3)
    for (int x = 0; x < kSize; x += 3)
      for (uint32_t s = 0; s < 4; ++s) {
        const CameraSample one =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, unbranched);
        ASSERT_EQ(one.raysBeforeBranching, one.rays);
        ASSERT_TRUE(isBlack(one.branchDifference));
        const CameraSample two =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, twoBranches);
        // Every pixel sees the floor or a ball: the camera ray and a shadow ray or two are
        // traced before the split, and each branch traces at least its bounce.
        ASSERT_GE(two.raysBeforeBranching, 1u);
        ASSERT_GE(two.rays, two.raysBeforeBranching + 2);
        // The branches' estimates, the mean plus and minus half the difference, are light.
        for (int k = 0; k < 3; ++k) {
          ASSERT_GE(two.radiance[k] + 0.5f * two.branchDifference[k], -1e-5f);
          ASSERT_GE(two.radiance[k] - 0.5f * two.branchDifference[k], -1e-5f);
        }
        differing += !isBlack(two.branchDifference);
      }
  EXPECT_GT(differing, 300);  // of 484: the branches' bounces find other light
}

TEST(Branching, PilotBranchesWhereTheNoiseLiesBeyondTheFirstSurface) {
  RenderDelegate delegate;
  floorLitByCeiling(delegate);
  const BranchingPilot pilot = pilotOf(delegate);
  EXPECT_GT(pilot.pixels, 0u);
  EXPECT_GT(pilot.varianceBeyond, 4 * pilot.varianceFirst);
  RenderPass chosen(delegate, "/cam", kSize, kSize);
  chosen.execute(1);
  const int branches = chosen.indirectSamplesUsed();
  EXPECT_GE(branches, 2);
  EXPECT_EQ(branches, pilot.indirectSamples());
  // It pays: less noise for the rays traced than without branching.
  const auto noiseTimesRays = [&](int indirectSamples) {
    std::vector<float> images[2];
    uint64_t rays = 0;
    for (int seed = 0; seed < 2; ++seed) {
      delegate.settings().set("indirectSamples", indirectSamples);
      delegate.settings().set("seed", seed);
      RenderPass pass(delegate, "/cam", kSize, kSize);
      pass.execute(32);
      images[seed] = pass.aov("color");
      rays += pass.raysTraced();
    }
    return redSquaredDifference(images[0], images[1]) * double(rays);
  };
  EXPECT_LT(noiseTimesRays(branches), 0.85 * noiseTimesRays(1));
}

TEST(Branching, PilotDoesNotBranchWhereTheNoiseIsThePixelsOwn) {
  RenderDelegate delegate;
  fineCheckerboardInTheSun(delegate);
  const BranchingPilot pilot = pilotOf(delegate);
  EXPECT_GT(pilot.varianceFirst, 1);
  EXPECT_EQ(pilot.varianceBeyond, 0);
  EXPECT_EQ(pilot.indirectSamples(), 1);
  RenderPass pass(delegate, "/cam", kSize, kSize);
  pass.execute(1);
  EXPECT_EQ(pass.indirectSamplesUsed(), 1);
  // Paths that end at their first surface have nothing to branch: no pilot.
  RenderDelegate direct;
  ballsUnderSky(direct, true);
  direct.settings().set("maxPathDepth", 1);
  EXPECT_EQ(pilotOf(direct).pixels, 0u);
  EXPECT_EQ(pilotOf(direct).indirectSamples(), 1);
}

TEST(Branching, PilotChoosesTheSameForAnyThreadCountAndCrop) {
  const auto renderWith = [](int threads, PixelRect crop) {
    RenderDelegate delegate;
    floorLitByCeiling(delegate);
    delegate.settings().set("threads", threads);
    RenderPass pass(delegate, "/cam", kSize, kSize, crop);
    pass.execute(4);
    EXPECT_GT(pass.indirectSamplesUsed(), 1);
    return pass.aov("color");
  };
  const std::vector<float> whole = renderWith(1, {0, 0, kSize, kSize});
  EXPECT_EQ(renderWith(2, {0, 0, kSize, kSize}), whole);
  const PixelRect band{0, 11, kSize, 7};
  EXPECT_EQ(renderWith(2, band), cropOf(whole, kSize, 4, band));
  RenderDelegate delegate;
  floorLitByCeiling(delegate);
  EXPECT_EQ(pilotOf(delegate, 1).varianceFirst, pilotOf(delegate, 2).varianceFirst);
  EXPECT_EQ(pilotOf(delegate, 1).varianceBeyond, pilotOf(delegate, 2).varianceBeyond);
}

TEST(Branching, TheSettingChoosesOrLeavesTheChoiceToThePilot) {
  RenderDelegate delegate;
  floorLitByCeiling(delegate);
  EXPECT_EQ(delegate.settings().indirectSamples, 0);  // the pilot's choice by default
  RenderPass pass(delegate, "/cam", kSize, kSize);
  EXPECT_EQ(pass.indirectSamplesUsed(), 1);  // nothing rendered yet
  for (const int set : {1, 2, 7}) {
    delegate.settings().set("indirectSamples", set);
    pass.execute(1);
    EXPECT_EQ(pass.indirectSamplesUsed(), set);
  }
  EXPECT_THROW(delegate.settings().set("indirectSamples", -1), std::invalid_argument);
}
