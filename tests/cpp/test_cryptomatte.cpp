// Cryptomatte: MurmurHash3 and the float conversion against published values, the ranking of a
// pixel's ids, the per-pixel counts and their saved state, and Cryptomatte AOVs through a render
// pass (coverage that sums to one, names that merge, depth, any thread count).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <tuple>

#include "penumbra/cryptomatte.h"
#include "penumbra/film.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using namespace penumbra::plugin;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::facingDown;
using penumbra::test::translation;

namespace {

uint32_t bitsOf(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  return bits;
}

/// A floor filling the view under a smaller occluder, seen from above.
void floorAndOccluder(RenderDelegate& delegate) {
  for (const auto& [id, halfSize, y] :
       {std::tuple{"/floor", 4.0f, 0.0f}, std::tuple{"/occluder", 0.5f, 1.0f}})
    addFloor(delegate, id, halfSize, y);
  addCamera(delegate, facingDown(0, 5, 0), 1);  // sees x and z in [-2.5, 2.5]
}

/// `coverage` saved as a checkpoint (into `state`) and loaded into one of `pixels` pixels.
CryptomatteCoverage reloaded(const CryptomatteCoverage& coverage, size_t pixels,
                             std::vector<uint8_t>& state) {
  coverage.saveState(state);
  CryptomatteCoverage loaded;
  loaded.reset(pixels);
  const uint8_t* cursor = state.data();
  loaded.loadState(cursor, state.data() + state.size());
  EXPECT_EQ(cursor, state.data() + state.size());
  return loaded;
}

const std::map<PrimId, std::vector<std::string>> kObjectNames = {{"/floor", {"floor"}},
                                                                 {"/occluder", {"occluder"}}};

}  // namespace

TEST(Cryptomatte, HashesAsMurmurHash3AndTheSpecificationsManifest) {
  // MurmurHash3_x86_32's published test values (seed 0)...
  EXPECT_EQ(murmurHash3(""), 0u);
  EXPECT_EQ(murmurHash3("hello"), 0x248bfa47u);
  EXPECT_EQ(murmurHash3("The quick brown fox jumps over the lazy dog"), 0x2e4ff723u);
  EXPECT_EQ(murmurHash3("", 1), 0x514e28b7u);
  // ... and the manifest of the Cryptomatte specification's example.
  EXPECT_EQ(cryptomatteBits(murmurHash3("bunny")), 0x13851a76u);
  EXPECT_EQ(cryptomatteBits(murmurHash3("default")), 0x42c9679fu);
  EXPECT_EQ(cryptomatteBits(murmurHash3("bunny_porcelain_mat")), 0xb24b26d4u);
}

TEST(Cryptomatte, FloatIdsAreNeverDenormalInfiniteOrNan) {
  EXPECT_EQ(cryptomatteBits(0x00000001u), 0x00800001u);  // a denormal: exponent 0 -> 1
  EXPECT_EQ(cryptomatteBits(0x7f800000u), 0x7f000000u);  // infinity: exponent 255 -> 254
  EXPECT_EQ(cryptomatteBits(0xff812345u), 0xff012345u);  // a negative NaN
  EXPECT_EQ(cryptomatteBits(0x3f800000u), 0x3f800000u);  // others are kept bit for bit
  EXPECT_EQ(bitsOf(cryptomatteFloat(0x13851a76u)), 0x13851a76u);
  for (uint64_t hash = 0; hash <= 0xffffffffull; hash += 0x00012345ull) {
    const float id = cryptomatteFloat(uint32_t(hash));
    EXPECT_TRUE(std::isnormal(id)) << hash;
  }
}

TEST(Cryptomatte, RanksMergeEqualIdsAndSortByCoverageThenHash) {
  const std::vector<CryptomatteRank> ranks =
      rankCoverage({{30, 1}, {10, 2}, {20, 3}, {10, 1}, {5, 1}}, 8);
  ASSERT_EQ(ranks.size(), 4u);
  EXPECT_EQ(ranks[0].id, cryptomatteFloat(10));  // 2 + 1 samples, ahead of 20 by its hash
  EXPECT_EQ(ranks[0].coverage, 3.0f / 8);
  EXPECT_EQ(ranks[1].id, cryptomatteFloat(20));
  EXPECT_EQ(ranks[2].id, cryptomatteFloat(5));  // 1 sample each: smaller hash first
  EXPECT_EQ(ranks[3].id, cryptomatteFloat(30));
  EXPECT_EQ(ranks[3].coverage, 1.0f / 8);
}

TEST(Cryptomatte, FacesASubsetBindsTakeItsNameInAMaterialLayer) {
  CryptomatteCoverage coverage;
  coverage.reset(1);
  const PlacementKey mesh = placementKey(4, -1);
  coverage.add(0, mesh);     // a face with the mesh's own material
  coverage.add(0, mesh, 2);  // two on faces of the mesh's second subset
  coverage.add(0, mesh, 2);
  coverage.add(0, mesh, 3);  // one on faces of its third
  const PlacementHashes hashes = {{mesh, 70}};
  float layer[6];
  // An object layer: one placement, whatever the faces' materials.
  coverage.resolve(0, 4, hashes, 3, layer);
  EXPECT_EQ(layer[0], cryptomatteFloat(70));
  EXPECT_EQ(layer[1], 1.0f);
  EXPECT_EQ(layer[3], 0.0f);
  // A material layer: each subset's faces apart; one missing from the map is a miss.
  const SlotHashes materials = {{4, {50, 20, 10}}};
  coverage.resolve(0, 4, hashes, 3, layer, &materials);
  EXPECT_EQ(layer[0], cryptomatteFloat(20));
  EXPECT_EQ(layer[1], 0.5f);
  EXPECT_EQ(layer[2], cryptomatteFloat(10));  // 1 sample each: smaller hash first
  EXPECT_EQ(layer[3], 0.25f);
  EXPECT_EQ(layer[4], cryptomatteFloat(70));
  EXPECT_EQ(layer[5], 0.25f);
  const SlotHashes without = {{4, {50, 20}}};
  coverage.resolve(0, 4, hashes, 3, layer, &without);
  EXPECT_EQ(layer[1] + layer[3] + layer[5], 0.75f);
  // The checkpoint keeps the faces' slots.
  std::vector<uint8_t> state;
  float again[6];
  reloaded(coverage, 1, state).resolve(0, 4, hashes, 3, again, &materials);
  coverage.resolve(0, 4, hashes, 3, layer, &materials);
  EXPECT_EQ(0, std::memcmp(again, layer, sizeof layer));
}

TEST(Cryptomatte, CoverageCountsSamplesPerPlacementAndKeepsTheDeepestRanks) {
  CryptomatteCoverage coverage;
  coverage.reset(2);
  const PlacementKey a = placementKey(0, -1), b = placementKey(0, 0), c = placementKey(1, 3);
  for (const PlacementKey key : {a, b, b, c, b, a}) coverage.add(0, key);
  // b and c share a name (a material, say): their samples add up.
  const PlacementHashes hashes = {{a, 7}, {b, 9}, {c, 9}};
  float two[4], one[2];
  coverage.resolve(0, 8, hashes, 2, two);  // 8 samples: 2 missed everything
  EXPECT_EQ(two[0], cryptomatteFloat(9));
  EXPECT_EQ(two[1], 4.0f / 8);
  EXPECT_EQ(two[2], cryptomatteFloat(7));
  EXPECT_EQ(two[3], 2.0f / 8);
  coverage.resolve(0, 8, hashes, 1, one);
  EXPECT_EQ(one[1], 0.5f);
  coverage.resolve(1, 4, hashes, 2, two);  // nothing hit: zeros
  for (const float value : two) EXPECT_EQ(value, 0.0f);

  std::vector<uint8_t> state;
  CryptomatteCoverage loaded = reloaded(coverage, 2, state);
  float again[4];
  loaded.resolve(0, 8, hashes, 2, again);
  coverage.resolve(0, 8, hashes, 2, two);
  EXPECT_EQ(0, std::memcmp(again, two, sizeof two));
  const uint8_t* cursor = state.data();
  for (const size_t cut : {size_t(0), size_t(9), state.size() - 1}) {
    cursor = state.data();
    EXPECT_THROW(loaded.loadState(cursor, state.data() + cut), std::invalid_argument) << cut;
  }
  CryptomatteCoverage other;
  other.reset(3);
  cursor = state.data();
  EXPECT_THROW(other.loadState(cursor, state.data() + state.size()), std::invalid_argument);
}

TEST(Cryptomatte, PassCoverageSumsToOneWhereEverySampleHitsAndIsThreadIndependent) {
  const auto renderWith = [](int threads, int depth) {
    RenderDelegate delegate;
    floorAndOccluder(delegate);
    delegate.settings().set("threads", threads);
    delegate.settings().set("cryptomatteDepth", depth);
    RenderPass pass(delegate, "/cam", 24, 20);
    pass.setAovs({"CryptoObject", "CryptoMaterial"});
    pass.execute(16);
    EXPECT_EQ(pass.aovChannels("CryptoObject"), Film::cryptomatteChannels(depth));
    return std::pair{pass.cryptomatte(kObjectNames),
                     pass.cryptomatte({{"/floor", {"grey"}}, {"/occluder", {"grey"}}})};
  };
  const auto [objects, materials] = renderWith(1, 6);
  EXPECT_EQ(objects, renderWith(2, 6).first);
  ASSERT_EQ(objects.size(), 24u * 20u * 12u);
  const float floor = cryptomatteFloat(murmurHash3("floor"));
  const float occluder = cryptomatteFloat(murmurHash3("occluder"));
  int edges = 0;
  for (size_t pixel = 0; pixel < 24 * 20; ++pixel) {
    const float* ranks = objects.data() + pixel * 12;
    EXPECT_EQ(ranks[1] + ranks[3], 1.0f);  // the floor fills the view: no background
    EXPECT_TRUE(ranks[0] == floor || ranks[0] == occluder);
    EXPECT_GE(ranks[1], ranks[3]);
    for (size_t c = 4; c < 12; ++c) EXPECT_EQ(ranks[c], 0.0f);  // two objects at most
    if (ranks[3] > 0) {
      ++edges;
      EXPECT_EQ(ranks[2], ranks[0] == floor ? occluder : floor);
    }
    // One material for both: one id covering the whole pixel.
    EXPECT_EQ(materials[pixel * 12], cryptomatteFloat(murmurHash3("grey")));
    EXPECT_EQ(materials[pixel * 12 + 1], 1.0f);
  }
  EXPECT_GT(edges, 0);
  const std::vector<float> shallow = renderWith(1, 1).first;  // one rank: one RGBA layer
  ASSERT_EQ(shallow.size(), 24u * 20u * 4u);
  for (size_t pixel = 0; pixel < 24 * 20; ++pixel) {
    EXPECT_EQ(shallow[pixel * 4], objects[pixel * 12]);
    EXPECT_EQ(shallow[pixel * 4 + 1], objects[pixel * 12 + 1]);
    EXPECT_EQ(shallow[pixel * 4 + 2], 0.0f);
  }
}

TEST(Cryptomatte, PassNamesInstancerCopiesOneByOneAndRejectsWrongNames) {
  RenderDelegate delegate;
  addFloor(delegate, "/tile", 0.5f, 0.0f);
  delegate.mesh("/tile").setVisible(false);  // only its copies render
  delegate.insertRprim("instancer", "/copies");
  delegate.instancer("/copies").setInstances(
      "/tile", {MotionTransform(translation(-1, 0, 0)), MotionTransform(translation(1, 0, 0))});
  addCamera(delegate, facingDown(0, 5, 0), 1);
  RenderPass pass(delegate, "/cam", 20, 20);
  pass.setAovs({"CryptoObject"});
  EXPECT_THROW(pass.cryptomatte({{"/copies", {"left"}}}), std::invalid_argument);  // not run
  pass.execute(4);
  EXPECT_THROW(pass.cryptomatte({{"/copies", {"left"}}}), std::invalid_argument);
  EXPECT_THROW(pass.cryptomatte({{"/cam", {"camera"}}}), std::invalid_argument);
  EXPECT_THROW(pass.aov("CryptoObject"), std::invalid_argument);  // needs names
  const std::vector<float> ids = pass.cryptomatte({{"/copies", {"left", "right"}}});
  const float left = cryptomatteFloat(murmurHash3("left"));
  const float right = cryptomatteFloat(murmurHash3("right"));
  // Row 10, column 5 sees x = -1.19 (the left copy), column 14 x = +1.13 (the right one).
  EXPECT_EQ(ids[(10 * 20 + 5) * 12], left);
  EXPECT_EQ(ids[(10 * 20 + 5) * 12 + 1], 1.0f);
  EXPECT_EQ(ids[(10 * 20 + 14) * 12], right);
  EXPECT_EQ(ids[(10 * 20 + 0) * 12 + 1], 0.0f);  // x = -2.4: between nothing
}
