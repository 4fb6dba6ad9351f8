// Path guiding (guiding.h): the field's distributions, their determinism, and guided renders
// against unguided ones and analytic values.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "image_stats.h"
#include "penumbra/guiding.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "penumbra/warp.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::facingDown;
using penumbra::test::meanRed;
using penumbra::test::redSquaredDifference;
using penumbra::test::translation;
using namespace penumbra::plugin;

namespace {

const Vec3f kUp{0, 1, 0};
const Vec3f kBright = normalize(Vec3f(0.3f, 1, 0.2f));  // where the training light comes from

/// Records of a surface facing up near the origin: most flux from a 10° cone about kBright, a
/// little from everywhere above; `count` of them, in a random order. Their estimates are
/// taken as a uniform hemisphere sampler's (the density the guide competes with), which the
/// cone's flux beats.
std::vector<GuidingRecord> coneRecords(size_t count, uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> uniform(0, 1);
  const Frame frame(kBright);
  std::vector<GuidingRecord> records(count);
  for (size_t i = 0; i < count; ++i) {
    GuidingRecord& r = records[i];
    r.position = {uniform(random) * 0.1f, 0, uniform(random) * 0.1f};
    r.orientation = orientationOf(kUp);
    const bool inCone = i % 2 == 0;
    const Vec3f local =
        inCone ? sampleUniformCone({uniform(random), uniform(random)}, 1 - std::cos(10 * kPi / 180))
               : sampleUniformHemisphere({uniform(random), uniform(random)});
    const Vec3f direction = inCone ? frame.toWorld(local) : Vec3f(local.x, local.z, local.y);
    r.direction = directionToSquare(direction);
    r.flux = inCone ? 1.0f : 0.01f;
    r.sampledPdf = 1 / (2 * kPi);
    r.estimate = r.flux;
    r.key = GuidingRecord::makeKey(uint32_t(i % 1000), uint32_t(i / 1000), 0, 0);
  }
  return records;
}

Vec3f uniformSphere(std::mt19937& random) {
  std::uniform_real_distribution<float> uniform(0, 1);
  return sampleUniformSphere({uniform(random), uniform(random)});
}

}  // namespace

TEST(Guiding, CylindricalMapRoundTrips) {
  std::mt19937 random(1);
  for (int i = 0; i < 1000; ++i) {
    const Vec3f direction = uniformSphere(random);
    const Vec3f back = squareToDirection(directionToSquare(direction));
    EXPECT_NEAR(length(back - direction), 0, 1e-5f);
  }
}

TEST(Guiding, DistributionSamplesItsOwnDensityWhichIntegratesToOne) {
  const GuidingField field = GuidingField::build(coneRecords(4000, 1));
  const DirectionalDistribution* guide = field.at({0.05f, 0, 0.05f}, kUp);
  ASSERT_NE(guide, nullptr);
  EXPECT_EQ(field.at({0.05f, 0, 0.05f}, -kUp), nullptr);  // nothing learnt facing down
  std::mt19937 random(2);
  std::uniform_real_distribution<float> uniform(0, 1);
  // ∫ pdf dω = 1, by uniform sampling of the sphere; the solid angle where pdf > 0 (no
  // record came from below the surface).
  double integral = 0, support = 0;
  const int n = 400000;
  for (int i = 0; i < n; ++i) {
    const float pdf = guide->pdf(uniformSphere(random));
    integral += pdf;
    support += pdf > 0;
  }
  EXPECT_NEAR(integral / n * 4 * M_PI, 1.0, 0.02);
  EXPECT_LT(support / n, 0.75);
  // E[1 / pdf(ω)] over its own samples is the solid angle where pdf > 0, and most samples
  // fall where most of the flux came from.
  double inverseDensity = 0;
  int inCone = 0, sameDensity = 0;
  for (int i = 0; i < n; ++i) {
    float pdf = 0;
    const Vec3f direction =
        guide->sample(uniform(random), {uniform(random), uniform(random)}, &pdf);
    EXPECT_NEAR(length(direction), 1, 1e-4f);
    ASSERT_GT(pdf, 0);
    // The leaf's density is the one pdf() finds for the direction (but where rounding moves a
    // direction on a leaf's edge across it).
    sameDensity += guide->pdf(direction) == pdf;
    inverseDensity += 1 / pdf;
    inCone += dot(direction, kBright) > std::cos(15 * kPi / 180);
  }
  EXPECT_NEAR(inverseDensity / n / (4 * M_PI * support / n), 1.0, 0.03);
  EXPECT_GT(double(inCone) / n, 0.8);
  EXPECT_GT(double(sameDensity) / n, 0.999);
}

TEST(Guiding, FieldDoesNotDependOnTheRecordsOrder) {
  std::vector<GuidingRecord> records = coneRecords(20000, 3);
  const GuidingField field = GuidingField::build(records);
  std::shuffle(records.begin(), records.end(), std::mt19937(4));
  const GuidingField shuffled = GuidingField::build(records);
  std::mt19937 random(5);
  for (int i = 0; i < 200; ++i) {
    const Vec3f position{0.1f * float(i % 10) / 10, 0, 0.1f * float(i / 10) / 20};
    const DirectionalDistribution* a = field.at(position, kUp);
    const DirectionalDistribution* b = shuffled.at(position, kUp);
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr);
    const Vec3f direction = uniformSphere(random);
    EXPECT_EQ(a->pdf(direction), b->pdf(direction));
    float pdfA = 0, pdfB = 0;
    EXPECT_EQ(length(a->sample(0.3f, {0.6f, 0.2f}, &pdfA) - b->sample(0.3f, {0.6f, 0.2f}, &pdfB)),
              0.0f);
    EXPECT_EQ(pdfA, pdfB);
    EXPECT_EQ(a->guideProbability(), b->guideProbability());
  }
}

namespace {

/// `count` training records of a white Lambertian floor facing up near the origin, sampled
/// as its BSDF samples (cosine-weighted): radiance 1 from everywhere, but `peak` from a 10°
/// cone about kBright, and `firefly` from the first record's direction.
std::vector<GuidingRecord> floorRecords(size_t count, float peak, float firefly = 1) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> uniform(0, 1);
  std::vector<GuidingRecord> records(count);
  for (size_t i = 0; i < count; ++i) {
    GuidingRecord& r = records[i];
    r.position = {uniform(random) * 0.1f, 0, uniform(random) * 0.1f};
    r.orientation = orientationOf(kUp);
    const Vec3f local = sampleCosineHemisphere({uniform(random), uniform(random)});
    const Vec3f direction{local.x, local.z, local.y};
    const float radiance = i == 0                                               ? firefly
                           : dot(direction, kBright) > std::cos(10 * kPi / 180) ? peak
                                                                                : 1.0f;
    r.direction = directionToSquare(direction);
    r.sampledPdf = cosineHemispherePdf(local.z);
    r.flux = radiance * local.z / r.sampledPdf;               // radiance·cos θ / pdf
    r.estimate = kInvPi * local.z * radiance / r.sampledPdf;  // f·cos θ·radiance / pdf
    r.key = GuidingRecord::makeKey(uint32_t(i % 1000), uint32_t(i / 1000), 0, 0);
  }
  return records;
}

}  // namespace

TEST(Guiding, CellsGuideOnlyWhereTheGuideWouldHaveCutTheirVariance) {
  const Vec3f here{0.05f, 0, 0.05f};
  // Light from everywhere: cosine sampling is already the best a Lambertian floor can do.
  const GuidingField uniform = GuidingField::build(floorRecords(4000, 1));
  EXPECT_EQ(uniform.at(here, kUp), nullptr);
  EXPECT_FALSE(uniform.guides());
  // Light from a small bright patch: the guide finds it far more often than the BSDF.
  const GuidingField concentrated = GuidingField::build(floorRecords(4000, 1000));
  const DirectionalDistribution* guide = concentrated.at(here, kUp);
  ASSERT_NE(guide, nullptr);
  EXPECT_TRUE(concentrated.guides());
  EXPECT_GE(guide->guideProbability(), 0.5f);
  EXPECT_LT(guide->guideProbability(), 1.0f);
  // One bright record alone shapes the distribution towards itself, but is not counted as
  // evidence for it: the cell does not guide.
  EXPECT_EQ(GuidingField::build(floorRecords(4000, 1, 1e6f)).at(here, kUp), nullptr);
}

namespace {

/// Local -Z onto world +Y, then a translation: a camera looking up.
Transform facingUp(double x, double y, double z) {
  const double m[16] = {1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, x, y, z, 1};
  return Transform::fromRowMajor(m);
}

/// A grey room lit only through what its floor reflects: a panel shining down on the floor
/// under a low ceiling that hides it from the camera, which looks up at the ceiling from
/// below. The ceiling's light is all indirect, from one bright patch of floor. `branches`: the
/// paths each camera sample branches into at its first surface (1: the guided and unguided
/// samples compared are one path each).
void indirectlyLitRoom(RenderDelegate& delegate, int trainingSamples, int branches = 1) {
  addFloor(delegate, "/floor", 4);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.8f)}, Interpolation::Constant);
  // The ceiling faces down (its square turned over) at y = 1.
  addFloor(delegate, "/ceiling", 4);
  delegate.mesh("/ceiling").setTopology({4}, {0, 3, 2, 1}, false, "none");
  delegate.mesh("/ceiling").setTransform(translation(0, 1, 0));
  delegate.mesh("/ceiling").setDisplayColor({Vec3f(0.8f)}, Interpolation::Constant);
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setParam("width", 0.4f);
  delegate.light("/panel").setParam("height", 0.4f);
  delegate.light("/panel").setParam("intensity", 40.0f);
  delegate.light("/panel").setTransform(facingDown(2.5, 0.9, 0));
  addCamera(delegate, facingUp(-1.5, 0.05, 0), 1);
  delegate.settings().set("guidingTrainingSamples", trainingSamples);
  delegate.settings().set("indirectSamples", branches);
}

constexpr int kRoomSize = 24;

/// The room's colour (RGBA) at `samples` per pixel with `seed`, in passes of `passes`
/// samples, on `threads` threads.
std::vector<float> renderRoom(int trainingSamples, int samples, int seed, int threads = 0,
                              int passes = 0, int branches = 1) {
  RenderDelegate delegate;
  indirectlyLitRoom(delegate, trainingSamples, branches);
  delegate.settings().set("seed", seed);
  delegate.settings().set("threads", threads);
  RenderPass pass(delegate, "/cam", kRoomSize, kRoomSize);
  for (int done = 0; done < samples; done += passes ? passes : samples)
    pass.execute(passes ? std::min(passes, samples - done) : samples);
  return pass.aov("color");
}

/// Mean squared difference of the red channel between two renders, relative to their mean.
double relativeSquaredDifference(const std::vector<float>& a, const std::vector<float>& b) {
  const double mean = (meanRed(a) + meanRed(b)) / 2;
  return redSquaredDifference(a, b) / (mean * mean);
}

}  // namespace

TEST(Guiding, GuidedRendersAreUnbiasedAndLessNoisyWhereLightIsIndirect) {
  // Enough samples that the unguided estimate's rare bright paths (the noise guiding cuts)
  // average out.
  const int spp = 256;
  const std::vector<float> plainA = renderRoom(0, spp, 1), plainB = renderRoom(0, spp, 2);
  const std::vector<float> guidedA = renderRoom(4, spp, 1), guidedB = renderRoom(4, spp, 2);
  const double plain = (meanRed(plainA) + meanRed(plainB)) / 2;
  ASSERT_GT(plain, 0.01);  // the ceiling is lit
  EXPECT_NEAR((meanRed(guidedA) + meanRed(guidedB)) / 2 / plain, 1.0, 0.03);
  // The difference of two seeds' images measures the noise.
  EXPECT_LT(relativeSquaredDifference(guidedA, guidedB),
            0.7 * relativeSquaredDifference(plainA, plainB));
}

TEST(Guiding, TrainingSamplesAreUnguidedAndGuidedImagesAreDeterministic) {
  // Up to the training budget a render is the unguided one, branching as it does; past it, it
  // differs.
  EXPECT_EQ(renderRoom(4, 4, 1), renderRoom(0, 4, 1));
  EXPECT_EQ(renderRoom(4, 4, 1, /*threads=*/0, /*passes=*/0, /*branches=*/3),
            renderRoom(0, 4, 1, /*threads=*/0, /*passes=*/0, /*branches=*/3));
  const std::vector<float> guided = renderRoom(4, 12, 1, 1);
  EXPECT_NE(guided, renderRoom(0, 12, 1, 1));
  // Any thread count, any split into passes: the same field, the same pixels.
  EXPECT_EQ(guided, renderRoom(4, 12, 1, 2));
  EXPECT_EQ(guided, renderRoom(4, 12, 1, 2, 3));
}

TEST(Guiding, CropsRenderTheWholeImagesPixels) {
  // A farm's band trains on the whole image (traced again for it, branching as the whole
  // image's training samples do), so its pixels are the whole image's.
  for (const int branches : {1, 3}) {
    SCOPED_TRACE(branches);
    const std::vector<float> whole = renderRoom(4, 12, 1, /*threads=*/0, /*passes=*/0, branches);
    RenderDelegate delegate;
    indirectlyLitRoom(delegate, 4, branches);
    delegate.settings().set("seed", 1);
    const PixelRect band{0, 8, kRoomSize, 6};
    RenderPass pass(delegate, "/cam", kRoomSize, kRoomSize, band);
    pass.execute(12);
    const std::vector<float> cropped = pass.aov("color");
    for (int y = 0; y < band.height; ++y)
      for (int x = 0; x < band.width; ++x)
        for (int c = 0; c < 4; ++c)
          ASSERT_EQ(cropped[size_t((y * band.width + x) * 4 + c)],
                    whole[size_t(((band.y + y) * kRoomSize + x) * 4 + c)]);
  }
}

TEST(Guiding, SavedStatesResumeToTheSamePixels) {
  const std::vector<float> straight = renderRoom(4, 12, 1);
  std::vector<uint8_t> state;
  {
    RenderDelegate delegate;
    indirectlyLitRoom(delegate, 4);
    delegate.settings().set("seed", 1);
    RenderPass pass(delegate, "/cam", kRoomSize, kRoomSize);
    pass.execute(6);  // past the training: the field is not saved, it is trained again
    state = pass.saveState("room");
  }
  RenderDelegate delegate;
  indirectlyLitRoom(delegate, 4);
  delegate.settings().set("seed", 1);
  RenderPass pass(delegate, "/cam", kRoomSize, kRoomSize);
  pass.execute(0);
  pass.loadState(state, "room");
  pass.execute(6);
  EXPECT_EQ(pass.aov("color"), straight);
}
