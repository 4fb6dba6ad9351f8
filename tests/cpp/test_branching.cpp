// Branching and light estimates at the first surface chosen per render (branching.h): what a
// sample records for the pilot, the pilot's choice where the noise lies beyond the first surface,
// where it is the choice of light and where it is the pixel's own, its branches per region of the
// image, the same for any crop and thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
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
using penumbra::test::meanRed;
using penumbra::test::redSquaredDifference;
using penumbra::test::syncedCamera;
using penumbra::test::translation;
using namespace penumbra::plugin;

namespace {

constexpr int kSize = 32;

/// The pilot's measurement of the delegate's scene, seen by "/cam", with its settings' depth.
BranchingPilot pilotOf(RenderDelegate& delegate, int threads = 0) {
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
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

/// A grey floor seen from above under 64 small sphere lights of powers spread over two orders
/// of magnitude, 1 to 2.5 units above it, direct light only: which light a shading point samples
/// is most of its noise.
void floorUnderManyBulbs(RenderDelegate& delegate) {
  penumbra::test::addFloor(delegate, "/floor", 20);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  for (int i = 0; i < 64; ++i) {
    const std::string id = "/bulb" + std::to_string(i);
    delegate.insertSprim("sphereLight", id);
    delegate.light(id).setParam("radius", 0.05f);
    delegate.light(id).setParam("cameraVisible", false);  // their light on the floor alone
    delegate.light(id).setParam("intensity", 20.0f * std::pow(10.0f, float(i * 37 % 64) / 32));
    delegate.light(id).setTransform(
        translation(-3.5 + (i % 8), 1 + 1.5 * double(i * 13 % 64) / 64, -3.5 + (i / 8)));
  }
  addCamera(delegate, facingDown(0, 5, 0), 1.5f);
  delegate.settings().set("maxPathDepth", 1);
}

/// floorLitByCeiling with a glowing dark quad (a lamp's shade) at height 1 over the view's half
/// x > 0: there the pixels' own light is bright and what their paths find beyond the first
/// surface is dim, while the floor's light is all found beyond it.
void floorLitByCeilingBesideAGlow(RenderDelegate& delegate) {
  floorLitByCeiling(delegate);
  penumbra::test::addFloor(delegate, "/glow", 10, 1);
  delegate.mesh("/glow").setTransform(translation(10, 0, 0));
  delegate.insertSprim("material", "/glowing");
  delegate.material("/glowing").setParam("emissiveColor", Vec3f(4.0f));
  delegate.material("/glowing").setParam("diffuseColor", Vec3f(0.05f));
  delegate.mesh("/glow").setMaterialId("/glowing");
}

/// Two seeds' images of 32 samples with the settings `set` (key, value) on the delegate's, and
/// the rays the two traced.
struct TwoSeeds {
  std::vector<float> images[2];
  uint64_t rays = 0;
};
TwoSeeds renderTwoSeeds(RenderDelegate& delegate,
                        const std::vector<std::pair<std::string, double>>& set) {
  for (const auto& [key, value] : set) delegate.settings().set(key, value);
  TwoSeeds rendered;
  for (int seed = 0; seed < 2; ++seed) {
    delegate.settings().set("seed", seed);
    RenderPass pass(delegate, "/cam", kSize, kSize);
    pass.execute(32);
    rendered.images[seed] = pass.aov("color");
    rendered.rays += pass.raysTraced();
  }
  return rendered;
}

/// Noise (the red channel's squared difference between two seeds' images) times the rays the
/// two traced, with the settings `set`.
double noiseTimesRays(RenderDelegate& delegate,
                      const std::vector<std::pair<std::string, double>>& set) {
  const TwoSeeds rendered = renderTwoSeeds(delegate, set);
  return redSquaredDifference(rendered.images[0], rendered.images[1]) * double(rendered.rays);
}

/// The same noise relative to the pixels' value (over their mean's square + 0.01, as the pilot
/// weighs it), times the rays.
double relativeNoiseTimesRays(RenderDelegate& delegate,
                              const std::vector<std::pair<std::string, double>>& set) {
  const TwoSeeds rendered = renderTwoSeeds(delegate, set);
  const std::vector<float>&a = rendered.images[0], &b = rendered.images[1];
  double noise = 0;
  for (size_t i = 0; i < a.size(); i += 4) {
    const double mean = 0.5 * (double(a[i]) + double(b[i]));
    const double difference = double(a[i]) - double(b[i]);
    noise += difference * difference / (mean * mean + 0.01);
  }
  return noise / double(a.size() / 4) * double(rendered.rays);
}

}  // namespace

TEST(Branching, ASampleKeepsItsBranchesDifferenceAndTheWorkBeforeTheSplit) {
  RenderDelegate delegate;
  ballsUnderSky(delegate, true);
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
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
        ASSERT_EQ(one.verticesBeforeBranching, one.vertices);
        ASSERT_GE(one.vertices, 1u);
        ASSERT_TRUE(isBlack(one.branchDifference));
        const CameraSample two =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, twoBranches);
        // Every pixel sees the floor or a ball: the camera ray and a shadow ray or two are
        // traced before the split, and each branch traces at least its bounce.
        ASSERT_GE(two.raysBeforeBranching, 1u);
        ASSERT_GE(two.rays, two.raysBeforeBranching + 2);
        // The first surface is the one vertex shaded before the split.
        ASSERT_EQ(two.verticesBeforeBranching, 1u);
        ASSERT_GE(two.vertices, two.verticesBeforeBranching);
        // The branches' estimates, the mean plus and minus half the difference, are light.
        for (int k = 0; k < 3; ++k) {
          ASSERT_GE(two.radiance[k] + 0.5f * two.branchDifference[k], -1e-5f);
          ASSERT_GE(two.radiance[k] - 0.5f * two.branchDifference[k], -1e-5f);
        }
        differing += !isBlack(two.branchDifference);
      }
  EXPECT_GT(differing, 300);  // of 484: the branches' bounces find other light
}

TEST(Branching, TheDifferenceOfBranchesOfWavelengthCopiesIsThatOfTheirMeans) {
  // A smooth glass ball over a grey floor under a white dome, seen from above: each of a
  // sample's two branches goes on from the ball, where the glass is dispersive as three
  // wavelength copies, and the difference the pilot reads is that of the two branches' means.
  // It averages 0, and it is about as large as without dispersion (one path per branch);
  // counted per copy instead of per branch it would be three times as large.
  struct Differences {
    double radiance = 0, difference = 0, absoluteDifference = 0;
  };
  const auto differencesWith = [](float abbeNumber) {
    RenderDelegate delegate;
    penumbra::test::addFloor(delegate, "/floor", 20, -1);
    delegate.mesh("/floor").setDisplayColor({Vec3f(0.3f)}, Interpolation::Constant);
    penumbra::test::addSphere(delegate, "/ball", 1);
    delegate.insertSprim("material", "/glass");
    delegate.material("/glass").setParam("opacity", 0.0f);
    delegate.material("/glass").setParam("roughness", 0.0f);
    delegate.material("/glass").setParam("penumbra:abbeNumber", abbeNumber);
    delegate.mesh("/ball").setMaterialId("/glass");
    delegate.insertSprim("domeLight", "/sky");
    addCamera(delegate, facingDown(0, 5, 0), 2.5f);
    const penumbra::Camera camera = syncedCamera(delegate, kSize);
    const PixelFilter filter;
    IntegratorSettings twoBranches;
    twoBranches.indirectSamples = 2;
    Differences sums;
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x)
        for (uint32_t s = 0; s < 8; ++s) {
          const CameraSample sample =
              renderCameraSample(delegate.scene(), camera, filter, x, y, s, twoBranches);
          sums.radiance += luminance(sample.radiance);
          sums.difference += luminance(sample.branchDifference);
          sums.absoluteDifference += std::abs(luminance(sample.branchDifference));
        }
    return sums;
  };
  const Differences dispersive = differencesWith(20), plain = differencesWith(0);
  ASSERT_GT(plain.absoluteDifference, 0.05 * plain.radiance);
  EXPECT_LT(std::abs(dispersive.difference), 0.05 * dispersive.radiance);
  const double ratio = dispersive.absoluteDifference / plain.absoluteDifference;
  RecordProperty("absoluteDifferenceDispersiveOverPlain", std::to_string(ratio));
  EXPECT_GT(ratio, 0.7);
  EXPECT_LT(ratio, 1.4);
}

TEST(Branching, PilotBranchesWhereTheNoiseLiesBeyondTheFirstSurface) {
  RenderDelegate delegate;
  floorLitByCeiling(delegate);
  const BranchingPilot pilot = pilotOf(delegate);
  EXPECT_GT(pilot.pixels, 0u);
  EXPECT_GT(pilot.varianceBeyond, 4 * pilot.varianceFirst);
  RenderPass chosen(delegate, "/cam", kSize, kSize);
  chosen.execute(1);
  const int branches = pilot.choose({0, 0}).indirectSamples;
  EXPECT_GE(branches, 2);
  // On a floor alike everywhere, the counts per region stay near the image's.
  EXPECT_NEAR(chosen.indirectSamplesUsed(), branches, 0.5);
  // It pays: less noise for the rays traced than without branching (one light estimate each).
  EXPECT_LT(noiseTimesRays(delegate, {{"indirectSamples", branches}, {"lightSamples", 1}}),
            0.85 * noiseTimesRays(delegate, {{"indirectSamples", 1}, {"lightSamples", 1}}));
}

TEST(Branching, ASampleKeepsItsLightEstimatesDifferenceAndTheirRays) {
  RenderDelegate delegate;
  floorUnderManyBulbs(delegate);
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
  const PixelFilter filter;
  IntegratorSettings one, two;
  one.maxPathDepth = two.maxPathDepth = 1;
  two.lightSamples = 2;
  int differing = 0;
  for (int y = 0; y < kSize; y += 3)
    for (int x = 0; x < kSize; x += 3)
      for (uint32_t s = 0; s < 4; ++s) {
        const CameraSample single =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, one);
        // The camera ray, the light estimate's shadow rays (up to four local lights) and the
        // BSDF-sampled ray that finds the lights' emission (MIS).
        ASSERT_GE(single.firstSurfaceLightRays, 1u);
        // Nothing occludes the floor: every light sample evaluated traces its shadow ray.
        ASSERT_EQ(single.firstSurfaceLightSamples, single.firstSurfaceLightRays);
        ASSERT_LE(single.rays, single.firstSurfaceLightRays + 2);
        ASSERT_TRUE(isBlack(single.lightEstimateDifference));
        const CameraSample pair =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, two);
        ASSERT_LE(pair.rays, pair.firstSurfaceLightRays + 2);
        ASSERT_GT(pair.firstSurfaceLightRays, single.firstSurfaceLightRays / 2);
        // The two estimates, the mean plus and minus half the difference, are light.
        for (int k = 0; k < 3; ++k) {
          ASSERT_GE(pair.radiance[k] + 0.5f * pair.lightEstimateDifference[k], -1e-5f);
          ASSERT_GE(pair.radiance[k] - 0.5f * pair.lightEstimateDifference[k], -1e-5f);
        }
        differing += !isBlack(pair.lightEstimateDifference);
      }
  EXPECT_GT(differing, 400);  // of 484: the estimates choose other lights and points on them
}

TEST(Branching, PilotEstimatesLightSeveralTimesWhereTheChoiceOfLightIsTheNoise) {
  RenderDelegate delegate;
  floorUnderManyBulbs(delegate);
  const BranchingPilot pilot = pilotOf(delegate);
  // Direct light only: beyond the first surface, the BSDF-sampled rays that find the lights'
  // emission, which MIS gives little weight.
  EXPECT_GT(pilot.varianceLight, 4 * (pilot.varianceFirst + pilot.varianceBeyond));
  RenderPass chosen(delegate, "/cam", kSize, kSize);
  chosen.execute(1);
  const int estimates = chosen.lightSamplesUsed();
  EXPECT_GE(estimates, 2);
  EXPECT_EQ(chosen.indirectSamplesUsed(), 1);
  EXPECT_EQ(estimates, pilot.choose({0, 0}).lightSamples);
  // A count set is kept, and the other chosen for it.
  EXPECT_EQ(pilot.choose({0, 3}).lightSamples, 3);
  EXPECT_EQ(pilot.choose({2, 0}).indirectSamples, 2);
  // It pays: less noise for the rays traced than with one estimate.
  EXPECT_LT(noiseTimesRays(delegate, {{"lightSamples", estimates}}),
            0.8 * noiseTimesRays(delegate, {{"lightSamples", 1}}));
  // And the mean is the same (to 2 %: 32 samples of each of two seeds).
  delegate.settings().set("samples", 32);
  const auto meanWith = [&](int lightSamples) {
    delegate.settings().set("lightSamples", lightSamples);
    RenderPass pass(delegate, "/cam", kSize, kSize);
    pass.execute(64);
    return meanRed(pass.aov("color"));
  };
  EXPECT_NEAR(meanWith(estimates), meanWith(1), 0.02 * meanWith(1));
}

TEST(Branching, PilotCountsTheShadingOfVerticesInASamplesCost) {
  RenderDelegate delegate;
  floorUnderManyBulbs(delegate);
  const BranchingPilot pilot = pilotOf(delegate);
  ASSERT_GT(pilot.pixels, 0u);
  // Each of a grid pixel's 8 samples: its camera ray and the floor's vertex; each branch, its
  // bounce ray, whose hit is not shaded (direct light only); each light estimate, its light
  // samples alone. Counted in rays only, the first part would cost as much as a branch.
  EXPECT_EQ(pilot.costBeyond, 8.0 * pilot.pixels);
  EXPECT_EQ(pilot.costFirst, (1 + BranchingPilot::kVertexCost) * pilot.costBeyond);
  EXPECT_GT(pilot.costFirst, pilot.costBeyond);
  EXPECT_GE(pilot.costLight, 8.0 * pilot.pixels);
}

TEST(Branching, PilotCountsTheEvaluationOfLightsWithoutShadows) {
  // Nothing stands between the floor and its bulbs: with or without shadows, the light
  // estimates evaluate the same light samples, whose work is the same. (Counted in shadow rays,
  // lights without shadows cost nothing, and the pilot took the most estimates of them.)
  RenderDelegate shadowed, unshadowed;
  floorUnderManyBulbs(shadowed);
  floorUnderManyBulbs(unshadowed);
  for (int i = 0; i < 64; ++i)
    unshadowed.light("/bulb" + std::to_string(i)).setParam("shadow:enable", false);
  const BranchingPilot withShadows = pilotOf(shadowed), withoutShadows = pilotOf(unshadowed);
  EXPECT_GT(withoutShadows.costLight, 0);
  EXPECT_EQ(withoutShadows.costLight, withShadows.costLight);
  EXPECT_EQ(withoutShadows.varianceLight, withShadows.varianceLight);
  EXPECT_EQ(withoutShadows.choose({0, 0}).lightSamples, withShadows.choose({0, 0}).lightSamples);
}

TEST(Branching, PilotDoesNotBranchWhereTheNoiseIsThePixelsOwn) {
  RenderDelegate delegate;
  fineCheckerboardInTheSun(delegate);
  const BranchingPilot pilot = pilotOf(delegate);
  EXPECT_GT(pilot.varianceFirst, 1);
  EXPECT_EQ(pilot.varianceBeyond, 0);
  EXPECT_EQ(pilot.varianceLight, 0);  // a sun (a delta light) over an unshadowed board
  EXPECT_EQ(pilot.choose({0, 0}).indirectSamples, 1);
  EXPECT_EQ(pilot.choose({0, 0}).lightSamples, 1);
  RenderPass pass(delegate, "/cam", kSize, kSize);
  pass.execute(1);
  EXPECT_EQ(pass.indirectSamplesUsed(), 1);
  EXPECT_EQ(pass.lightSamplesUsed(), 1);
  // Paths that end before their first surface's light have nothing to choose: no pilot.
  RenderDelegate direct;
  ballsUnderSky(direct, true);
  direct.settings().set("maxPathDepth", 0);
  EXPECT_EQ(pilotOf(direct).pixels, 0u);
  EXPECT_EQ(pilotOf(direct).choose({0, 0}).indirectSamples, 1);
  EXPECT_EQ(pilotOf(direct).choose({0, 0}).lightSamples, 1);
}

TEST(Branching, PilotChoosesTheSameForAnyThreadCountAndCrop) {
  // Counts that differ across the image: the floor's and the shade's.
  std::vector<uint8_t> wholeCounts;
  const auto renderWith = [&](int threads, PixelRect crop) {
    RenderDelegate delegate;
    floorLitByCeilingBesideAGlow(delegate);
    delegate.settings().set("threads", threads);
    RenderPass pass(delegate, "/cam", kSize, kSize, crop);
    pass.execute(4);
    EXPECT_GT(pass.indirectSamplesUsed(), 1);
    if (!pass.regionBranches()) {
      ADD_FAILURE() << "one count for the whole image";
      return pass.aov("color");
    }
    if (wholeCounts.empty()) wholeCounts = pass.regionBranches()->counts;
    EXPECT_EQ(pass.regionBranches()->counts, wholeCounts);
    return pass.aov("color");
  };
  const std::vector<float> whole = renderWith(1, {0, 0, kSize, kSize});
  EXPECT_NE(*std::min_element(wholeCounts.begin(), wholeCounts.end()),
            *std::max_element(wholeCounts.begin(), wholeCounts.end()));
  EXPECT_EQ(renderWith(2, {0, 0, kSize, kSize}), whole);
  const PixelRect band{0, 11, kSize, 7};
  EXPECT_EQ(renderWith(2, band), cropOf(whole, kSize, 4, band));
  RenderDelegate delegate;
  floorLitByCeilingBesideAGlow(delegate);
  EXPECT_EQ(pilotOf(delegate, 1).varianceFirst, pilotOf(delegate, 2).varianceFirst);
  EXPECT_EQ(pilotOf(delegate, 1).varianceBeyond, pilotOf(delegate, 2).varianceBeyond);
  EXPECT_EQ(pilotOf(delegate, 1).varianceLight, pilotOf(delegate, 2).varianceLight);
}

TEST(Branching, TheSettingChoosesOrLeavesTheChoiceToThePilot) {
  RenderDelegate delegate;
  floorLitByCeiling(delegate);
  EXPECT_EQ(delegate.settings().indirectSamples, 0);  // the pilot's choice by default
  RenderPass pass(delegate, "/cam", kSize, kSize);
  EXPECT_EQ(pass.indirectSamplesUsed(), 1);  // nothing rendered yet
  EXPECT_EQ(pass.lightSamplesUsed(), 1);
  for (const int set : {1, 2, 7}) {
    delegate.settings().set("indirectSamples", set);
    pass.execute(1);
    EXPECT_EQ(pass.indirectSamplesUsed(), set);
  }
  EXPECT_THROW(delegate.settings().set("indirectSamples", -1), std::invalid_argument);
  EXPECT_EQ(delegate.settings().lightSamples, 0);  // the pilot's choice by default
  for (const int set : {1, 3}) {
    delegate.settings().set("lightSamples", set);
    pass.execute(1);
    EXPECT_EQ(pass.lightSamplesUsed(), set);
  }
  EXPECT_THROW(delegate.settings().set("lightSamples", -1), std::invalid_argument);
  EXPECT_THROW(delegate.settings().set("lightSamples", 17), std::invalid_argument);
}

TEST(Branching, PilotBranchesPerRegionWhereTheNoiseBeyondLies) {
  RenderDelegate delegate;
  floorLitByCeilingBesideAGlow(delegate);
  RenderPass pass(delegate, "/cam", kSize, kSize);
  pass.setAovs({"color", "depth"});
  EXPECT_EQ(pass.regionBranches(), nullptr);  // nothing rendered yet
  pass.execute(1);
  ASSERT_NE(pass.regionBranches(), nullptr);
  const FirstSurfaceBranches& regions = *pass.regionBranches();
  // Each region's count against what its pixels see, told by their depth: the glow's 1, the
  // floor's 2.
  const std::vector<float> depth = pass.aov("depth");
  int floorRegions = 0, glowRegions = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      if (x % regions.regionSize || y % regions.regionSize) continue;  // once per region
      const bool onFloor = depth[size_t(y * kSize + x)] > 1.5f;
      const int count = regions.at(x, y);
      // Regions wholly on one side: the glow's edge crosses none at this size.
      if (onFloor) {
        ++floorRegions;
        EXPECT_GE(count, 2) << "floor region at " << x << ", " << y;
      } else {
        ++glowRegions;
        EXPECT_EQ(count, 1) << "glow region at " << x << ", " << y;
      }
    }
  EXPECT_GT(floorRegions, 0);
  EXPECT_GT(glowRegions, 0);
  double sum = 0;  // the mean count over the pixels, as the pass reports it
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) sum += regions.at(x, y);
  EXPECT_DOUBLE_EQ(pass.indirectSamplesUsed(), sum / (kSize * kSize));
  EXPECT_GT(pass.indirectSamplesUsed(), 1);
  EXPECT_LT(pass.indirectSamplesUsed(), 4);
  // It pays: less relative noise for the rays traced than the pilot's one count for the image.
  const int imageCount = pilotOf(delegate).choose({0, 0}).indirectSamples;
  EXPECT_GE(imageCount, 2);
  const double perRegion = relativeNoiseTimesRays(delegate, {{"indirectSamples", 0}});
  const double perImage = relativeNoiseTimesRays(delegate, {{"indirectSamples", imageCount}});
  RecordProperty("perRegionOverPerImage", std::to_string(perRegion / perImage));
  EXPECT_LT(perRegion, 0.85 * perImage);
}

TEST(Branching, EachPixelBranchesAsItsRegionSays) {
  RenderDelegate delegate;
  floorLitByCeiling(delegate);
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
  // Two regions side by side: one path in the left one, three in the right one.
  FirstSurfaceBranches regions;
  regions.regionSize = kSize / 2;
  regions.columns = 2;
  regions.rows = 1;
  regions.counts = {1, 3};
  IntegratorSettings settings;
  settings.indirectSamples = 2;  // what the regions replace
  settings.regionBranches = &regions;
  const PixelFilter filter;
  uint32_t raysAfterSplit[2] = {0, 0}, raysBeforeSplit[2] = {0, 0};
  for (int side = 0; side < 2; ++side)
    for (uint32_t index = 0; index < 16; ++index) {
      const CameraSample sample = renderCameraSample(delegate.scene(), camera, filter,
                                                     side * kSize / 2 + 5, 7, index, settings);
      raysAfterSplit[side] += sample.rays - sample.raysBeforeBranching;
      raysBeforeSplit[side] += sample.raysBeforeBranching;
    }
  // Unbranched, every ray counts as before the split; three branches trace about three paths.
  EXPECT_EQ(raysAfterSplit[0], 0u);
  EXPECT_GT(raysAfterSplit[1], 2 * raysBeforeSplit[1]);
  EXPECT_EQ(regions.mean(kSize, kSize), 2.0);
}

TEST(Branching, RegionsCoverTheImageRowByRowTheLastTakingTheRest) {
  // Regions 12 pixels across over a 30 x 20 image: columns of 12, 12 and 6 pixels, rows of 12
  // and 8.
  FirstSurfaceBranches regions;
  regions.regionSize = 12;
  regions.columns = 3;
  regions.rows = 2;
  regions.counts = {1, 2, 3, 4, 5, 6};
  EXPECT_EQ(regions.at(0, 0), 1);
  EXPECT_EQ(regions.at(23, 11), 2);
  EXPECT_EQ(regions.at(29, 0), 3);
  EXPECT_EQ(regions.at(0, 12), 4);
  EXPECT_EQ(regions.at(29, 19), 6);
  // Pixels past the last region's size (a region map of a smaller grid) take the last's count.
  EXPECT_EQ(regions.at(40, 30), 6);
  const double areas = 1 * 144 + 2 * 144 + 3 * 72 + 4 * 96 + 5 * 96 + 6 * 48;
  EXPECT_DOUBLE_EQ(regions.mean(30, 20), areas / 600);
  EXPECT_EQ(FirstSurfaceBranches().at(3, 4), 1);  // no regions: one path
}
