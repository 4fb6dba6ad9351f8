// AOVs through the render pass: deterministic, free when not asked for, ids never averaged,
// primvars as wide as authored, variance that falls with the sample count.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <tuple>

#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using namespace penumbra::plugin;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::facingDown;

namespace {

const std::vector<std::string> kEveryAov = {
    "alpha",  "depth",      "Z",         "normal",        "Neye",        "position", "albedo",
    "primId", "instanceId", "elementId", "primvars:heat", "sampleCount", "variance"};

/// A lit floor under a smaller occluder, seen from above: the floor fills the view, the occluder
/// its middle, and casts a soft shadow (noise).
void floorAndOccluder(RenderDelegate& delegate) {
  for (const auto& [id, halfSize, y] :
       {std::tuple{"/floor", 4.0f, 0.0f}, std::tuple{"/occluder", 0.5f, 1.0f}}) {
    addFloor(delegate, id, halfSize, y);
    delegate.mesh(id).setDisplayColor({Vec3f(0.6f)}, Interpolation::Constant);
  }
  delegate.mesh("/occluder").setPrimvars({{"heat", {0.25f, 0.75f}, 2, Interpolation::Constant}});
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setTransform(facingDown(0.3, 2, 0));
  addCamera(delegate, facingDown(0, 5, 0), 1);  // sees x and z in [-2.5, 2.5]
}

}  // namespace

TEST(Aovs, AreBitIdenticalForAnyThreadCountAndSplitAndLeaveColourAlone) {
  const auto renderWith = [](int threads, std::vector<int> passes, bool aovs) {
    RenderDelegate delegate;
    floorAndOccluder(delegate);
    delegate.settings().set("threads", threads);
    RenderPass pass(delegate, "/cam", 24, 20);
    if (aovs) pass.setAovs(kEveryAov);
    for (int samples : passes) pass.execute(samples);
    std::vector<std::vector<float>> images = {pass.aov("color")};
    if (aovs)
      for (const std::string& name : kEveryAov) images.push_back(pass.aov(name));
    return images;
  };
  const auto one = renderWith(1, {8}, true);
  EXPECT_EQ(one, renderWith(2, {8}, true));
  EXPECT_EQ(one, renderWith(2, {2, 6}, true));
  EXPECT_EQ(one.front(), renderWith(2, {8}, false).front());
}

TEST(Aovs, IdsNameOneMeshEvenWhereFilteredAovsBlendTwo) {
  RenderDelegate delegate;
  floorAndOccluder(delegate);
  RenderPass pass(delegate, "/cam", 24, 20);
  pass.setAovs({"primId", "elementId", "instanceId", "primvars:heat"});
  pass.execute(16);
  const std::map<uint32_t, PrimId> manifest = delegate.primIdManifest();
  std::set<float> ids;
  for (const float id : pass.aov("primId")) ids.insert(id);
  std::set<float> expected;
  for (const auto& [id, path] : manifest) expected.insert(float(id));
  EXPECT_EQ(ids, expected);  // both meshes seen, nothing in between
  for (const float face : pass.aov("elementId")) EXPECT_EQ(face, 0.0f);
  for (const float copy : pass.aov("instanceId")) EXPECT_EQ(copy, -1.0f);
  // The primvar is averaged: 2 channels, the authored value over the occluder, 0 on the floor
  // (which lacks it), in between at its edges.
  ASSERT_EQ(pass.aovChannels("primvars:heat"), 2);
  const std::vector<float> heat = pass.aov("primvars:heat");
  const std::vector<float> primId = pass.aov("primId");
  const float occluder =
      float(std::find_if(manifest.begin(), manifest.end(), [](const auto& entry) {
              return entry.second == "/occluder";
            })->first);
  bool blended = false;
  for (size_t i = 0; i < primId.size(); ++i) {
    const float first = heat[2 * i], second = heat[2 * i + 1];
    EXPECT_FLOAT_EQ(second, 3 * first);
    blended = blended || (first > 0 && first < 0.25f);
    if (first == 0.25f) {
      EXPECT_EQ(primId[i], occluder);
    }
    if (first == 0.0f) {
      EXPECT_NE(primId[i], occluder);
    }
  }
  EXPECT_TRUE(blended);
}

TEST(Aovs, VarianceOfTheMeanFallsWithTheSampleCount) {
  RenderDelegate delegate;
  floorAndOccluder(delegate);
  RenderPass pass(delegate, "/cam", 24, 20);
  pass.setAovs({"variance"});
  const auto meanVariance = [&] {
    const std::vector<float> variance = pass.aov("variance");
    double sum = 0;
    for (const float v : variance) sum += v;
    return sum / double(variance.size());
  };
  pass.execute(16);
  const double at16 = meanVariance();
  pass.execute(48);
  EXPECT_EQ(pass.aov("sampleCount").front(), 64.0f);
  EXPECT_GT(at16, 0);
  EXPECT_NEAR(meanVariance() / at16, 0.25, 0.05);
}

TEST(Aovs, OnlyThoseAccumulatedCanBeRead) {
  RenderDelegate delegate;
  floorAndOccluder(delegate);
  RenderPass pass(delegate, "/cam", 4, 4);
  pass.execute(1);
  EXPECT_NO_THROW(pass.aov("alpha"));
  EXPECT_NO_THROW(pass.aov("sampleCount"));
  EXPECT_THROW(pass.aov("normal"), std::invalid_argument);
  EXPECT_THROW(pass.aov("bogus"), std::invalid_argument);
  EXPECT_THROW(pass.setAovs({"primvars:"}), std::invalid_argument);
  pass.setAovs({"normal"});
  EXPECT_EQ(pass.samplesDone(), 0);  // a new AOV restarts accumulation
  pass.execute(1);
  const std::vector<float> alpha = pass.aov("alpha"), normal = pass.aov("normal");
  for (size_t i = 0; i < 16; ++i)  // one sample: the floor's or occluder's normal, or none
    EXPECT_NEAR(normal[3 * i + 1], alpha[i], 1e-6f);
  EXPECT_EQ(pass.aovChannels("primvars:missing"), 1);
  pass.setAovs({});  // AOVs no longer asked for are no longer accumulated (they cost time)
  EXPECT_THROW(pass.aov("normal"), std::invalid_argument);
}
