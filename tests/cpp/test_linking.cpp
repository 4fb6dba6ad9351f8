// Light and shadow linking at the renderer's level: the linking table's bit sets, and what
// linking classes of placements and link slots of lights do to pixels.
#include <gtest/gtest.h>

#include "image_stats.h"
#include "penumbra/linking.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::facingDown;
using penumbra::test::meanRed;
using penumbra::test::translation;
using namespace penumbra::plugin;

namespace {

std::vector<float> render(RenderDelegate& delegate, int samples = 16) {
  RenderPass pass(delegate, "/cam", 8, 8);
  pass.execute(samples);
  return pass.aov("color");
}

/// A grey floor seen from straight above (direct light only; `focalLength` 5 sees x and z in
/// [-0.5, 0.5]), under a sphere light "/bulb" (link slot `bulbSlot`) 3 above it and out of view.
void floorUnderBulb(RenderDelegate& delegate, int bulbSlot, float focalLength = 50) {
  addFloor(delegate, "/floor", 50);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  addCamera(delegate, facingDown(0, 5, 0), focalLength);
  delegate.insertSprim("sphereLight", "/bulb");
  delegate.light("/bulb").setTransform(translation(1, 3, 0));
  delegate.light("/bulb").setLinkSlot(bulbSlot);
  delegate.settings().set("maxPathDepth", 1);
}

}  // namespace

TEST(LinkingTable, ClassesAreBitSetsOverSlots) {
  LinkingTable table;
  EXPECT_FALSE(table.lightExcluded(0, 0));
  EXPECT_FALSE(table.lightExcluded(1, 0));  // no such class yet: linked to all
  table.setClasses({{{0, 70}, {}}, {{}, {3}}});
  EXPECT_EQ(table.classCount(), 3u);
  EXPECT_TRUE(table.lightExcluded(1, 0));
  EXPECT_TRUE(table.lightExcluded(1, 70));  // past the first 64 slots
  EXPECT_FALSE(table.lightExcluded(1, 3));
  EXPECT_FALSE(table.shadowExcluded(1, 0));
  EXPECT_TRUE(table.shadowExcluded(2, 3));
  EXPECT_FALSE(table.lightExcluded(2, 3));
  // Class 0 and lights without a slot are linked to everything; unknown classes and slots too.
  EXPECT_FALSE(table.lightExcluded(LinkingTable::kLinkedToAll, 0));
  EXPECT_FALSE(table.lightExcluded(1, -1));
  EXPECT_FALSE(table.lightExcluded(7, 0));
  EXPECT_FALSE(table.lightExcluded(1, 200));
  EXPECT_TRUE(table.shadowLinked(3));
  EXPECT_FALSE(table.shadowLinked(0));
  EXPECT_FALSE(table.shadowLinked(-1));
}

TEST(Linking, AnExcludedSurfaceReceivesNothingFromTheLightByEitherStrategy) {
  // The bulb is an area light: BSDF-sampled rays meet it as well as light samples, and both
  // must add nothing. A dome light (met by escaping rays) likewise.
  for (const bool dome : {false, true}) {
    SCOPED_TRACE(dome ? "dome" : "sphere light");
    const auto renderFloor = [&](bool excluded) {
      RenderDelegate delegate;
      floorUnderBulb(delegate, dome ? -1 : 0);
      if (dome) {
        delegate.removePrim("/bulb");
        delegate.insertSprim("domeLight", "/sky");
        delegate.light("/sky").setLinkSlot(0);
      }
      delegate.setLinkingClasses({{{0}, {}}});
      if (excluded) delegate.mesh("/floor").setLinkingClass(1);
      return meanRed(render(delegate));
    };
    EXPECT_GT(renderFloor(false), 0.01);
    EXPECT_EQ(renderFloor(true), 0.0);
  }
}

TEST(Linking, OnlyTheExcludingLightIsCutOff) {
  // Two bulbs; the floor is excluded from the first only: it receives exactly what the second
  // gives on its own, in expectation.
  const auto renderFloor = [](bool first, bool second, bool excluded) {
    RenderDelegate delegate;
    floorUnderBulb(delegate, 0);
    delegate.light("/bulb").setVisible(first);
    delegate.insertSprim("sphereLight", "/other");
    delegate.light("/other").setTransform(translation(-1, 3, 0));
    delegate.light("/other").setVisible(second);
    delegate.setLinkingClasses({{{0}, {}}});
    if (excluded) delegate.mesh("/floor").setLinkingClass(1);
    return meanRed(render(delegate, 256));
  };
  const double secondAlone = renderFloor(false, true, false);
  EXPECT_NEAR(renderFloor(true, true, true), secondAlone, secondAlone * 0.02);
  EXPECT_GT(renderFloor(true, true, false), secondAlone * 1.5);
}

TEST(Linking, InstancerCopiesAreLinkedOneByOne) {
  // Two copies of a square under the bulb; the second copy is excluded from its light.
  RenderDelegate delegate;
  floorUnderBulb(delegate, 0, 5);
  delegate.mesh("/floor").setVisible(false);
  addFloor(delegate, "/square", 0.2f);
  delegate.mesh("/square").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  delegate.mesh("/square").setVisible(false);
  delegate.insertRprim("instancer", "/copies");
  delegate.instancer("/copies").setInstances("/square",
                                             {translation(-0.25f, 0, 0), translation(0.25f, 0, 0)});
  delegate.instancer("/copies").setLinkingClasses({0, 1});
  delegate.setLinkingClasses({{{0}, {}}});
  const std::vector<float> image = render(delegate);
  const auto red = [&](int x, int y) { return image[size_t(4 * (y * 8 + x))]; };
  for (int y = 2; y <= 5; ++y) {
    EXPECT_GT(red(2, y), 0.001f);
    EXPECT_EQ(red(5, y), 0.0f);
  }
  // A class count that does not match the copies is refused with a warning, and ignored.
  delegate.instancer("/copies").setLinkingClasses({1});
  const std::vector<float> unlinked = render(delegate);
  EXPECT_GT(unlinked[size_t(4 * (3 * 8 + 5))], 0.001f);
}

TEST(Linking, AShadowLinkLetsOnlyItsLightThroughTheExcludedOccluder) {
  // The floor seen from between it and an occluder 1 above it, under a bulb 3 above: the
  // occluder excluded from the bulb's shadow link (slot 0) lets its light through exactly as a
  // light without shadows would; another light's shadow rays (slot 1) are still blocked.
  const auto renderFloor = [](int bulbSlot, bool shadows, bool excluded) {
    RenderDelegate delegate;
    floorUnderBulb(delegate, bulbSlot);
    addFloor(delegate, "/occluder", 5, 1);
    delegate.light("/bulb").setParam("shadow:enable", shadows);
    delegate.camera("/cam").setTransform(facingDown(0, 0.5, 0));
    delegate.setLinkingClasses({{{}, {0}}});
    if (excluded) delegate.mesh("/occluder").setLinkingClass(1);
    // Compared bit for bit with the pilot's choices: a light without shadows costs it the same
    // light samples as one whose shadow rays pass.
    return render(delegate);
  };
  EXPECT_EQ(meanRed(renderFloor(0, true, false)), 0.0);
  EXPECT_EQ(renderFloor(0, true, true), renderFloor(0, false, false));
  EXPECT_GT(meanRed(renderFloor(0, true, true)), 0.001);
  EXPECT_EQ(meanRed(renderFloor(1, true, true)), 0.0);
}
