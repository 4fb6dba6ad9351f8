// Saved accumulation state (checkpoints): a film or render pass loaded from a state goes on
// exactly as the one that saved it, and states of another film or render are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "penumbra/film.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using namespace penumbra::plugin;

namespace {

const std::vector<AovRequest> kAovs = {parseAov("normal"), parseAov("depth"), parseAov("primId"),
                                       parseAov("variance"), parseAov("CryptoObject")};
/// Names of the placements addSampleOf hits (primIds 0-6, no instancer copy).
PlacementHashes placementHashes() {
  PlacementHashes hashes;
  for (uint32_t primId = 0; primId < 7; ++primId) hashes[placementKey(primId, -1)] = 1000 + primId;
  return hashes;
}

/// Sample `index` of pixel (x, y): values that differ per pixel and sample, in no pattern,
/// but a constant colour in the two leftmost columns (which adaptive sampling stops).
void addSampleOf(Film& film, int x, int y, uint32_t index) {
  const float noise = std::fmod(std::sin(float(x * 131 + y * 71 + int(index) * 17)) * 43758.5f, 1);
  CameraSample sample;
  sample.radiance =
      x < 2 ? Vec3f(1, 1, 1) : Vec3f(std::abs(noise), 0.5f * noise * noise, float(index % 3));
  sample.alpha = index % 2 ? 1.0f : 0.0f;
  sample.depth = 10 + noise;
  sample.rays = 3 + index % 5;
  FirstHitSample hit;
  hit.hit = index % 4 != 0;
  hit.filterOffset = Vec2f{noise * 0.5f, 0.25f};
  hit.distance = 9 + noise;
  hit.normal = Vec3f(noise, 1, 0);
  hit.primId = int(index % 7);
  film.addSample(x, y, index, sample, &hit);
}

void addSamples(Film& film, uint32_t first, uint32_t count) {
  for (int y = 0; y < film.height(); ++y)
    for (int x = 0; x < film.width(); ++x)
      if (film.isActive(x, y))
        for (uint32_t index = first; index < first + count; ++index) addSampleOf(film, x, y, index);
}

/// Light-traced splats of light paths [first, first + count) (caustics.h), each path of a
/// sample index of its own, some of them on image pixels outside the film's region.
void addSplats(Film& film, uint32_t first, uint32_t count) {
  for (uint32_t path = first; path < first + count; ++path) {
    const PixelRect& region = film.region();
    film.addSplat(region.x - 1 + int(path * 7 % uint32_t(region.width + 2)),
                  region.y - 1 + int(path * 3 % uint32_t(region.height + 2)), path,
                  Vec3f(0.1f * float(path % 5), 0.3f, 0.01f * float(path)));
    film.addLightPaths(1, path);
  }
}

std::vector<std::vector<float>> resolveAll(const Film& film) {
  std::vector<std::vector<float>> images = {film.resolveColor(), film.resolveDepth()};
  for (const AovRequest& aov : kAovs)
    if (aov.kind != AovKind::CryptoObject) images.push_back(film.resolve(aov));
  images.push_back(film.resolve(parseAov("sampleCount")));
  images.push_back(film.resolveCryptomatte(placementHashes(), 6));
  return images;
}

}  // namespace

TEST(Checkpoints, AFilmLoadedFromAStateGoesOnBitIdentically) {
  const PixelRect region{3, 2, 7, 5};
  Film original(region, kAovs);
  addSamples(original, 0, 8);
  addSplats(original, 0, 40);
  original.updateConvergence(0.05f);  // some pixels stop: the active set is state too
  ASSERT_GT(original.activePixels(), 0u);
  ASSERT_LT(original.activePixels(), size_t(7 * 5));
  std::vector<uint8_t> state;
  original.saveState(state);

  Film loaded(region, kAovs);
  const uint8_t* cursor = state.data();
  loaded.loadState(cursor, state.data() + state.size());
  EXPECT_EQ(cursor, state.data() + state.size());
  EXPECT_EQ(resolveAll(loaded), resolveAll(original));
  for (Film* film : {&original, &loaded}) {
    addSamples(*film, 8, 8);
    addSplats(*film, 40, 40);
    film->updateConvergence(0.2f);
  }
  EXPECT_EQ(resolveAll(loaded), resolveAll(original));
  EXPECT_EQ(loaded.lightPaths(), 80u);
  EXPECT_EQ(loaded.activePixels(), original.activePixels());
  EXPECT_EQ(loaded.raysTraced(), original.raysTraced());
}

TEST(Checkpoints, AFilmRefusesAStateOfAnotherFilmAndStaysUnchanged) {
  Film saved(PixelRect{0, 0, 4, 4}, kAovs);
  addSamples(saved, 0, 2);
  std::vector<uint8_t> state;
  saved.saveState(state);
  const auto load = [&](Film& film, size_t bytes) {
    const uint8_t* cursor = state.data();
    film.loadState(cursor, state.data() + bytes);
  };
  Film otherRegion(PixelRect{1, 0, 4, 4}, kAovs);
  EXPECT_THROW(load(otherRegion, state.size()), std::invalid_argument);
  Film otherAovs(PixelRect{0, 0, 4, 4}, {parseAov("normal")});
  EXPECT_THROW(load(otherAovs, state.size()), std::invalid_argument);
  Film same(PixelRect{0, 0, 4, 4}, kAovs);
  addSamples(same, 0, 1);
  const auto before = resolveAll(same);
  for (size_t bytes : {size_t(0), size_t(10), state.size() / 2, state.size() - 1})
    EXPECT_THROW(load(same, bytes), std::invalid_argument) << bytes << " bytes";
  EXPECT_EQ(resolveAll(same), before);
}

namespace {

/// A lit floor seen from above, with adaptive sampling that stops part of it.
void litFloor(RenderDelegate& delegate) {
  test::addFloor(delegate, "/floor", 4, 0);
  test::addFloor(delegate, "/occluder", 0.5f, 1);
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setTransform(test::facingDown(0.3, 2, 0));
  test::addCamera(delegate, test::facingDown(0, 5, 0), 1);
  delegate.settings().set("adaptiveThreshold", 0.05);
  delegate.settings().set("adaptiveMinSamples", 4);
  delegate.settings().set("threads", 2);
}

}  // namespace

TEST(Checkpoints, ARenderPassResumedFromAStateEqualsAnUninterruptedOne) {
  RenderDelegate delegate;
  litFloor(delegate);
  const std::vector<std::string> aovs = {"normal", "variance"};
  RenderPass uninterrupted(delegate, "/cam", 24, 20);
  uninterrupted.setAovs(aovs);
  uninterrupted.execute(40);
  ASSERT_LT(uninterrupted.meanSamples(), 40);  // adaptive sampling stopped some pixels

  RenderPass interrupted(delegate, "/cam", 24, 20);
  interrupted.setAovs(aovs);
  interrupted.execute(10);  // between two convergence tests
  const std::vector<uint8_t> state = interrupted.saveState("frame 1");

  RenderPass resumed(delegate, "/cam", 24, 20);
  resumed.setAovs(aovs);
  EXPECT_THROW(resumed.loadState(state, "frame 1"), std::logic_error);  // not synced yet
  resumed.execute(0);
  EXPECT_THROW(resumed.loadState(state, "frame 2"), std::invalid_argument);
  resumed.loadState(state, "frame 1");
  EXPECT_EQ(resumed.samplesDone(), 10);
  resumed.execute(30);
  for (const char* name : {"color", "normal", "variance", "sampleCount"})
    EXPECT_EQ(resumed.aov(name), uninterrupted.aov(name)) << name;

  RenderPass cropped(delegate, "/cam", 24, 20, PixelRect{0, 0, 12, 20}, 4);
  cropped.setAovs(aovs);
  cropped.execute(0);
  EXPECT_THROW(cropped.loadState(state, "frame 1"), std::invalid_argument);
  delegate.settings().set("seed", 5);
  RenderPass otherSeed(delegate, "/cam", 24, 20);
  otherSeed.setAovs(aovs);
  otherSeed.execute(0);
  EXPECT_THROW(otherSeed.loadState(state, "frame 1"), std::invalid_argument);
}
