// End-to-end tests of the render delegate: prims in, pixels out.
#include <gtest/gtest.h>

#include <functional>
#include <numeric>
#include <random>
#include <set>

#include "image_stats.h"
#include "penumbra/dome_sampling.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::addSphere;
using penumbra::test::cropOf;
using penumbra::test::facingDown;
using penumbra::test::floorLitByCeiling;
using penumbra::test::floorUnderCeiling;
using penumbra::test::translation;
using namespace penumbra::plugin;

namespace {

/// A grey floor (displayColor without a material: Lambertian) seen from straight above through
/// a narrow lens.
void lambertianFloorScene(RenderDelegate& delegate, float albedo) {
  addFloor(delegate, "/floor", 50);
  delegate.mesh("/floor").setDisplayColor({Vec3f(albedo)}, Interpolation::Constant);
  addCamera(delegate, facingDown(0, 5, 0));
}

double meanChannel(const std::vector<float>& rgba, int channel) {
  double sum = 0;
  for (size_t i = size_t(channel); i < rgba.size(); i += 4) sum += rgba[i];
  return sum / double(rgba.size() / 4);
}

std::vector<float> render(RenderDelegate& delegate, int width, int height, int samples) {
  RenderPass pass(delegate, "/cam", width, height);
  pass.execute(samples);
  return pass.aov("color");
}

double cornerFormFactor(double a, double b, double h) {
  const double x = a / h, y = b / h;
  const double sx = std::sqrt(1 + x * x), sy = std::sqrt(1 + y * y);
  return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2 * M_PI);
}

}  // namespace

TEST(Render, LambertianPlaneUnderSphereLightMatchesAnalyticRadiance) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  delegate.insertSprim("sphereLight", "/bulb");
  delegate.light("/bulb").setParam("radius", 0.25f);
  delegate.light("/bulb").setParam("intensity", 3.0f);
  delegate.light("/bulb").setTransform(translation(1, 2, 0));
  const double d2 = 5;
  const double irradiance = M_PI * 3 * (0.0625 / d2) * (2 / std::sqrt(d2));
  const std::vector<float> image = render(delegate, 8, 8, 256);
  EXPECT_NEAR(meanChannel(image, 0) / (0.5 / M_PI * irradiance), 1.0, 0.02);
  EXPECT_EQ(meanChannel(image, 3), 1.0);
}

TEST(Render, LambertianPlaneUnderRectLightMatchesAnalyticRadiance) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  delegate.insertSprim("rectLight", "/panel");
  plugin::Light& panel = delegate.light("/panel");
  panel.setParam("width", 1.2f);
  panel.setParam("height", 0.8f);
  panel.setParam("intensity", 5.0f);
  panel.setTransform(facingDown(0, 2, 0));
  const double irradiance = 5 * M_PI * 4 * cornerFormFactor(0.6, 0.4, 2);
  const std::vector<float> image = render(delegate, 8, 8, 256);
  EXPECT_NEAR(meanChannel(image, 1) / (0.5 / M_PI * irradiance), 1.0, 0.02);
}

namespace {

/// A grey floor under a small square occluder lit by a rect panel (soft shadows and indirect
/// light), seen from above through a wide lens.
void occludedPanelScene(RenderDelegate& delegate, float intensity = 1) {
  lambertianFloorScene(delegate, 0.7f);
  addFloor(delegate, "/occluder", 0.3f, 1);
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setParam("intensity", intensity);
  delegate.light("/panel").setTransform(facingDown(0.2, 2, 0));
  delegate.camera("/cam").setParams([] {
    CameraParams params;
    params.focalLength = 10;
    params.horizontalAperture = params.verticalAperture = 10;
    return params;
  }());
}

}  // namespace

TEST(Render, ImagesAreBitIdenticalForAnyThreadCountAndSplit) {
  const auto renderWith = [](int threads, std::vector<int> passes) {
    RenderDelegate delegate;
    occludedPanelScene(delegate);
    delegate.settings().set("threads", threads);
    RenderPass pass(delegate, "/cam", 48, 40);
    for (int samples : passes) pass.execute(samples);
    return pass.aov("color");
  };
  const std::vector<float> one = renderWith(1, {16});
  EXPECT_EQ(one, renderWith(2, {16}));
  EXPECT_EQ(one, renderWith(2, {4, 8, 4}));
  EXPECT_NE(one, renderWith(1, {17}));
}

TEST(Render, AreaLightsCastSoftShadows) {
  RenderDelegate delegate;
  addFloor(delegate, "/floor", 50);
  // The occluder covers x < 0 at height 1 and is single-sided, facing away from the light: it
  // still blocks light (only camera rays ignore back faces).
  addFloor(delegate, "/occluder", 5, 1);
  delegate.mesh("/occluder").setTransform(translation(-5, 0, 0));
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setParam("width", 1.0f);
  delegate.light("/panel").setParam("height", 1.0f);
  delegate.light("/panel").setTransform(facingDown(0, 2, 0));
  addCamera(delegate, facingDown(0, 0.9, 0), 5);
  const int width = 64;
  RenderPass pass(delegate, "/cam", width, 8);
  pass.execute(64);
  const std::vector<float> image = pass.aov("color");
  // The occluder edge at x = 0 is halfway between floor and light: the penumbra on the floor spans
  // x in [-0.5, 0.5] (similar triangles), i.e. the middle half of this 0.9-unit-high view of
  // width 1.8.
  std::vector<double> row(width);
  for (int x = 0; x < width; ++x) row[x] = image[size_t(4 * (4 * width + x))];
  const double lit = row[width - 1], dark = row[0];
  ASSERT_GT(lit, 10 * std::max(dark, 1e-3));
  int intermediate = 0;
  for (int x = 0; x < width; ++x)
    if (row[x] > dark + 0.1 * (lit - dark) && row[x] < lit - 0.1 * (lit - dark)) ++intermediate;
  EXPECT_GE(intermediate, width / 4);  // a gradient, not a hard step
  for (int x = 8; x + 1 < width - 8; ++x) EXPECT_LE(row[x], row[x + 1] * 1.1 + 1e-3);
}

TEST(Render, SingleSidedMeshesAreInvisibleFromBehindUnlessLeftHanded) {
  const auto alphaOfFloorSeenFromBelow = [](bool leftHanded, bool doubleSided) {
    RenderDelegate delegate;
    addFloor(delegate, "/floor", 1);
    delegate.mesh("/floor").setTopology({4}, {0, 1, 2, 3}, leftHanded, "none");
    delegate.mesh("/floor").setDoubleSided(doubleSided);
    const double lookUp[16] = {1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, -2, 0, 1};
    addCamera(delegate, Transform::fromRowMajor(lookUp));
    return meanChannel(render(delegate, 4, 4, 1), 3);
  };
  EXPECT_EQ(alphaOfFloorSeenFromBelow(false, false), 0.0);
  EXPECT_EQ(alphaOfFloorSeenFromBelow(true, false), 1.0);
  EXPECT_EQ(alphaOfFloorSeenFromBelow(false, true), 1.0);
}

TEST(Render, ZIsTheViewAxisDistanceOfTheFirstHit) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  RenderPass pass(delegate, "/cam", 4, 4);
  pass.execute(4);
  for (float depth : pass.aov("Z")) EXPECT_NEAR(depth, 5.0f, 1e-4f);
}

TEST(Render, DisplayColorIsTheFallbackAlbedo) {
  RenderDelegate delegate;
  addFloor(delegate, "/floor", 50);
  delegate.mesh("/floor").setDisplayColor({{0.2f, 0.4f, 0.8f}}, Interpolation::Constant);
  addCamera(delegate, facingDown(0, 5, 0));
  delegate.insertSprim("domeLight", "/sky");
  delegate.settings().set("maxPathDepth", 1);
  const std::vector<float> image = render(delegate, 4, 4, 64);
  // Under a unit dome a Lambertian plane reflects its albedo (E = π).
  EXPECT_NEAR(meanChannel(image, 0), 0.2, 0.004);
  EXPECT_NEAR(meanChannel(image, 2), 0.8, 0.016);
  delegate.insertSprim("material", "/red");
  delegate.material("/red").setParam("diffuseColor", Vec3f(0.9f, 0.1f, 0.1f));
  delegate.mesh("/floor").setMaterialId("/red");
  EXPECT_NEAR(meanChannel(render(delegate, 4, 4, 64), 0), 0.9, 0.018);
}

TEST(Render, EmissiveSurfacesAreSeenByTheCamera) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  delegate.insertSprim("material", "/glow");
  delegate.material("/glow").setParam("emissiveColor", Vec3f(2, 3, 4));
  delegate.mesh("/floor").setMaterialId("/glow");
  const std::vector<float> image = render(delegate, 4, 4, 4);
  EXPECT_FLOAT_EQ(float(meanChannel(image, 2)), 4.0f);
}

TEST(Render, LightsHiddenFromTheCameraStillLightTheScene) {
  // A floor filling the left half of the view under a unit dome: camera rays that miss the
  // floor see the dome (alpha 1) unless it is hidden from them (alpha 0, black); the floor is
  // lit the same either way.
  const auto renderWith = [](bool cameraVisible) {
    RenderDelegate delegate;
    addFloor(delegate, "/floor", 50);
    delegate.mesh("/floor").setTransform(translation(-50, 0, 0));
    delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
    addCamera(delegate, facingDown(0, 5, 0));
    delegate.insertSprim("domeLight", "/sky");
    delegate.light("/sky").setParam("cameraVisible", cameraVisible);
    delegate.settings().set("maxPathDepth", 1);
    return render(delegate, 4, 4, 64);
  };
  const std::vector<float> seen = renderWith(true), hidden = renderWith(false);
  double floorMean = 0;
  for (int row = 0; row < 4; ++row) {
    const size_t floor = size_t(row * 4) * 4, sky = size_t(row * 4 + 3) * 4;
    EXPECT_EQ(seen[sky + 3], 1.0f);
    EXPECT_FLOAT_EQ(seen[sky], 1.0f);
    for (size_t c = 0; c < 4; ++c) EXPECT_EQ(hidden[sky + c], 0.0f);
    EXPECT_EQ(hidden[floor + 3], 1.0f);
    EXPECT_EQ(hidden[floor], seen[floor]);
    floorMean += hidden[floor] / 4.0;
  }
  EXPECT_NEAR(floorMean, 0.5, 0.02);
}

TEST(Render, RenderPassesHideMeshesFromTheCameraOrMakeThemHoldouts) {
  // A bright square 1 above a grey floor under a unit dome, filling the middle of the view:
  // hidden from the camera it still shades the floor below it; as a matte its pixels are
  // empty (colour and alpha 0). Pixels away from it are the same either way. The square is
  // either a mesh or an instancer's copy of a hidden prototype.
  const auto renderWith = [](PassVisibility pass, bool instanced) {
    RenderDelegate delegate;
    addFloor(delegate, "/floor", 50);
    delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
    addFloor(delegate, "/square", 1, 1);
    delegate.mesh("/square").setDisplayColor({Vec3f(0.9f)}, Interpolation::Constant);
    if (instanced) {
      delegate.mesh("/square").setVisible(false);
      delegate.insertRprim("instancer", "/copies");
      delegate.instancer("/copies").setInstances("/square", {translation(0, 0, 0)});
      delegate.instancer("/copies").setPassVisibility(pass);
    } else {
      delegate.mesh("/square").setPassVisibility(pass);
    }
    addCamera(delegate, facingDown(0, 5, 0), 1);  // sees x in [-2, 2] at the square's height
    delegate.insertSprim("domeLight", "/sky");
    delegate.settings().set("maxPathDepth", 1);
    // One strategy for the sky in all three: left to choose, the pilot may choose differently
    // for each (docs/dome-sampling.md), and the pixels away from the square would differ in
    // noise alone.
    delegate.settings().set("domeSampling", double(DomeSampling::Mis));
    delegate.settings().set("lightSamples", 1);  // so for the light estimates (docs/branching.md)
    return render(delegate, 8, 8, 256);
  };
  const auto pixel = [](const std::vector<float>& rgba, int x, int y, int channel) {
    return rgba[size_t(4 * (y * 8 + x) + channel)];
  };
  for (const bool instanced : {false, true}) {
    SCOPED_TRACE(instanced ? "instancer" : "mesh");
    const std::vector<float> seen = renderWith({}, instanced);
    const std::vector<float> hidden = renderWith({false, false}, instanced);
    const std::vector<float> matte = renderWith({true, true}, instanced);
    for (int y = 3; y <= 4; ++y)
      for (int x = 3; x <= 4; ++x) {
        EXPECT_NEAR(pixel(seen, x, y, 0), 0.9f, 0.05f);
        // The floor below the square, which hides about half of the sky from it.
        EXPECT_EQ(pixel(hidden, x, y, 3), 1.0f);
        EXPECT_LT(pixel(hidden, x, y, 0), 0.35f);
        EXPECT_GT(pixel(hidden, x, y, 0), 0.1f);
        for (int c = 0; c < 4; ++c) EXPECT_EQ(pixel(matte, x, y, c), 0.0f);
      }
    for (const int corner : {0, 7})
      for (int c = 0; c < 4; ++c) {
        EXPECT_EQ(pixel(hidden, corner, corner, c), pixel(seen, corner, corner, c));
        EXPECT_EQ(pixel(matte, corner, corner, c), pixel(seen, corner, corner, c));
      }
  }
}

TEST(RenderDelegate, InvalidMeshesAreSkippedWithAWarningNamingThem) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  delegate.insertRprim("mesh", "/bad");
  delegate.mesh("/bad").setPoints({{0, 0, 0}});
  delegate.mesh("/bad").setTopology({3}, {0, 1, 2}, false, "none");
  delegate.insertSprim("domeLight", "/sky");
  const std::vector<float> image = render(delegate, 4, 4, 4);
  const std::vector<std::string> warnings = delegate.takeWarnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "/bad: faceVertexIndices[1] = 1 is out of range for 1 points; the mesh is skipped");
  EXPECT_GT(meanChannel(image, 0), 0.4);
  EXPECT_TRUE(delegate.takeWarnings().empty());
}

TEST(RenderDelegate, OnlyDirtyPrimsAreSynced) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  addFloor(delegate, "/other", 1, 1);
  RenderPass pass(delegate, "/cam", 4, 4);
  pass.execute(2);
  EXPECT_EQ(delegate.prim("/floor").syncCount(), 1);
  EXPECT_EQ(delegate.prim("/other").syncCount(), 1);
  delegate.mesh("/other").setTransform(translation(0, 0.5, 0));
  EXPECT_NE(delegate.prim("/other").dirtyBits(), 0u);
  pass.execute(2);
  EXPECT_EQ(delegate.prim("/floor").syncCount(), 1);
  EXPECT_EQ(delegate.prim("/other").syncCount(), 2);
  EXPECT_EQ(pass.samplesDone(), 2);  // the edit restarted accumulation
  pass.execute(2);
  EXPECT_EQ(pass.samplesDone(), 4);
  EXPECT_EQ(delegate.prim("/other").syncCount(), 2);
}

TEST(RenderDelegate, RejectsUnknownTypesIdsAndSettings) {
  RenderDelegate delegate;
  EXPECT_THROW(delegate.insertRprim("tetMesh", "/c"),
               std::invalid_argument);  // a USD type read as a mesh
  EXPECT_THROW(delegate.insertSprim("cylinderLightX", "/l"), std::invalid_argument);
  delegate.insertSprim("camera", "/cam");
  EXPECT_THROW(delegate.insertSprim("camera", "/cam"), std::invalid_argument);
  EXPECT_THROW(delegate.mesh("/cam"), std::out_of_range);
  EXPECT_THROW(delegate.removePrim("/nothing"), std::out_of_range);
  EXPECT_THROW(delegate.settings().set("spp", 4), std::invalid_argument);
  EXPECT_THROW(delegate.settings().set("samples", 0), std::invalid_argument);
  EXPECT_THROW(delegate.settings().set("samples", 2.5), std::invalid_argument);
  EXPECT_THROW(delegate.settings().set("adaptiveThreshold", -0.1), std::invalid_argument);
  delegate.settings().set("adaptiveThreshold", 0.02);
  EXPECT_FLOAT_EQ(float(delegate.settings().asMap().at("adaptiveThreshold")), 0.02f);
  delegate.insertSprim("rectLight", "/l");
  EXPECT_THROW(delegate.light("/l").setParam("radius", Vec3f(1, 1, 1)), std::invalid_argument);
  EXPECT_THROW(delegate.light("/l").setParam("shadow:color", Vec3f(1, 0, 0)),
               std::invalid_argument);  // UsdLux's, not rendered: unknown to the delegate
  EXPECT_THROW(delegate.light("/l").setParam("shaping:ies:file", 1.0f), std::invalid_argument);
  EXPECT_THROW(delegate.light("/l").setParam("texture:file", 1.0f), std::invalid_argument);
  RenderPass pass(delegate, "/missing", 4, 4);
  EXPECT_THROW(pass.execute(1), std::out_of_range);
}

TEST(Render, LightsWithShadowsDisabledShineThroughOccluders) {
  const auto floorUnderOccluder = [](bool shadows) {
    RenderDelegate delegate;
    lambertianFloorScene(delegate, 0.5f);
    addFloor(delegate, "/occluder", 5, 1);
    delegate.insertSprim("sphereLight", "/bulb");
    delegate.light("/bulb").setParam("shadow:enable", shadows);
    delegate.light("/bulb").setTransform(translation(0, 3, 0));
    delegate.settings().set("maxPathDepth", 1);
    delegate.camera("/cam").setTransform(facingDown(0, 0.5, 0));  // between floor and occluder
    return meanChannel(render(delegate, 4, 4, 16), 0);
  };
  EXPECT_EQ(floorUnderOccluder(true), 0.0);
  // E = π L (r/d)² with r = 0.5, d = 3: radiance 0.5/π · E.
  EXPECT_NEAR(floorUnderOccluder(false), 0.5 * 0.25 / 9, 0.5 * 0.25 / 9 * 0.02);
}

TEST(Render, SubdivisionMeshesRenderTheirLimitSurface) {
  RenderDelegate delegate;
  delegate.insertRprim("mesh", "/cube");
  Mesh& cube = delegate.mesh("/cube");
  cube.setPoints({{-1, -1, 1},
                  {1, -1, 1},
                  {-1, 1, 1},
                  {1, 1, 1},
                  {-1, 1, -1},
                  {1, 1, -1},
                  {-1, -1, -1},
                  {1, -1, -1}});
  cube.setTopology({4, 4, 4, 4, 4, 4},
                   {0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4}, false,
                   "catmullClark");
  addCamera(delegate, translation(0, 0, 5), 50);
  RenderPass pass(delegate, "/cam", 9, 9);
  pass.execute(1);
  // The limit surface of a 2-unit Catmull-Clark cube passes 0.8396 from its centre at the middle
  // of each face (the cage is at 1).
  const std::vector<float> depth = pass.aov("Z");
  EXPECT_NEAR(depth[4 * 9 + 4], 5 - 0.8396, 2e-3);
  EXPECT_TRUE(delegate.takeWarnings().empty());
  // A hole removes its face: the camera then looks into the cube, at the far side's inside.
  cube.setSubdivisionTags([] {
    SubdivisionTags tags;
    tags.holeIndices = {0};
    return tags;
  }());
  pass.execute(1);
  EXPECT_GT(pass.aov("Z")[4 * 9 + 4], 5.5f);
}

TEST(RenderDelegate, InstancersPlaceCopiesOfAPrototype) {
  RenderDelegate delegate;
  addFloor(delegate, "/proto", 0.25f);
  delegate.mesh("/proto").setVisible(false);  // only its copies render
  delegate.insertRprim("instancer", "/copies");
  delegate.instancer("/copies").setInstances("/proto",
                                             {translation(-1, 0, 0), translation(1, 0, 0)});
  addCamera(delegate, facingDown(0, 5, 0), 1);  // sees x in [-2.5, 2.5]
  const auto alphaAt = [&](RenderPass& pass, float x) {
    const std::vector<float> rgba = pass.aov("color");
    const int column = int((x + 2.5f) / 5 * 40);
    return rgba[size_t(4 * (20 * 40 + column) + 3)];
  };
  RenderPass pass(delegate, "/cam", 40, 40);
  pass.execute(1);
  EXPECT_EQ(alphaAt(pass, -1), 1.0f);
  EXPECT_EQ(alphaAt(pass, 1), 1.0f);
  EXPECT_EQ(alphaAt(pass, 0), 0.0f);  // the hidden prototype
  // Editing the prototype's geometry moves every copy with it.
  delegate.mesh("/proto").setTransform(translation(0, 0, 0));
  delegate.mesh("/proto").setPoints(
      {{1.5f, 0, -0.25f}, {1.5f, 0, 0.25f}, {2, 0, 0.25f}, {2, 0, -0.25f}});
  pass.execute(1);
  EXPECT_EQ(alphaAt(pass, -1), 0.0f);
  EXPECT_EQ(alphaAt(pass, 0.75f), 1.0f);  // -1 + 1.75
  // Removing the prototype drops the copies, with a warning at the next sync.
  delegate.removePrim("/proto");
  pass.execute(1);
  EXPECT_EQ(alphaAt(pass, 0.75f), 0.0f);
  const std::vector<std::string> warnings = delegate.takeWarnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "/copies: prototype /proto is not a mesh, points or curves in the render index; the "
            "instances are skipped");
}

TEST(RenderDelegate, PrototypesKnowTheirInstancers) {
  RenderDelegate delegate;
  addFloor(delegate, "/a", 0.25f);
  addFloor(delegate, "/b", 0.25f);
  delegate.insertRprim("instancer", "/copies");
  delegate.instancer("/copies").setInstances("/a", {translation(-1, 0, 0)});
  addCamera(delegate, facingDown(0, 5, 0), 1);
  RenderPass pass(delegate, "/cam", 8, 8);
  pass.execute(1);
  EXPECT_EQ(delegate.mesh("/a").instancers(), std::set<PrimId>{"/copies"});
  // Copying another mesh leaves a stale entry on the first: removing it must not touch the
  // copies, nor fail once the instancer itself is gone.
  delegate.instancer("/copies").setInstances("/b", {translation(1, 0, 0)});
  pass.execute(1);
  EXPECT_EQ(delegate.mesh("/b").instancers(), std::set<PrimId>{"/copies"});
  delegate.removePrim("/copies");
  EXPECT_TRUE(delegate.mesh("/b").instancers().empty());
  delegate.removePrim("/a");
  pass.execute(1);
  EXPECT_TRUE(delegate.takeWarnings().empty());
}

namespace {

/// A 1.2 x 0.8 quad 2 above the floor, facing down: a mesh light with `params`.
void addGlowingPanel(RenderDelegate& delegate,
                     const std::vector<std::pair<std::string, ParamValue>>& params) {
  delegate.insertRprim("mesh", "/panel");
  Mesh& panel = delegate.mesh("/panel");
  panel.setPoints({{-0.6f, 2, -0.4f}, {0.6f, 2, -0.4f}, {0.6f, 2, 0.4f}, {-0.6f, 2, 0.4f}});
  panel.setTopology({4}, {0, 1, 2, 3}, false, "none");  // counter-clockwise from below
  panel.setLight(true, params);
  panel.setVisible(true);
}

}  // namespace

TEST(Render, MeshLightsMatchTheEquivalentRectLight) {
  // A 1.2 x 0.8 quad 2 above the floor, facing down, emitting radiance 5: the rect-light case.
  const auto floorRadiance = [](int directLighting) {
    RenderDelegate delegate;
    lambertianFloorScene(delegate, 0.5f);
    addGlowingPanel(delegate, {{"intensity", 5.0f}});
    delegate.settings().set("maxPathDepth", 1);
    delegate.settings().set("directLighting", directLighting);
    return meanChannel(render(delegate, 8, 8, 256), 1);
  };
  const double expected = 0.5 / M_PI * 5 * M_PI * 4 * cornerFormFactor(0.6, 0.4, 2);
  EXPECT_NEAR(floorRadiance(0) / expected, 1.0, 0.02);  // MIS
  EXPECT_NEAR(floorRadiance(1) / expected, 1.0, 0.02);  // light sampling only
  EXPECT_NEAR(floorRadiance(2) / expected, 1.0, 0.05);  // BSDF sampling only (noisier)
}

TEST(Render, ShapedMeshLightsLookTheSameToEveryStrategy) {
  // The panel shaped into an 80-degree cone about the world's -Z axis (a mesh light's light has
  // no transform of its own): the floor sees the cone's edge. Rays that met the panel took its
  // unshaped radiance, next-event estimation the shaped one: BSDF sampling alone gave 0.176
  // where light sampling gave 0.00899 (at 16,384 samples now 0.00894).
  const auto floorRadiance = [](int directLighting) {
    RenderDelegate delegate;
    lambertianFloorScene(delegate, 0.5f);
    addGlowingPanel(delegate, {{"intensity", 5.0f}, {"shaping:cone:angle", 80.0f}});
    delegate.settings().set("maxPathDepth", 1);
    delegate.settings().set("directLighting", directLighting);
    return meanChannel(render(delegate, 8, 8, directLighting == 2 ? 4096 : 1024), 1);
  };
  const double lightSampled = floorRadiance(1);
  ASSERT_GT(lightSampled, 0.005);                           // the floor sees the cone's edge
  EXPECT_NEAR(floorRadiance(0) / lightSampled, 1.0, 0.02);  // MIS
  EXPECT_NEAR(floorRadiance(2) / lightSampled, 1.0, 0.05);  // BSDF sampling only (noisier)
}

TEST(Render, AuthoredNormalsShadeTheSurface) {
  const auto floorUnderSun = [](std::vector<Vec3f> normals, Interpolation interpolation) {
    RenderDelegate delegate;
    lambertianFloorScene(delegate, 0.5f);
    delegate.mesh("/floor").setNormals(std::move(normals), interpolation);
    delegate.insertSprim("distantLight", "/sun");
    delegate.light("/sun").setParam("angle", 0.0f);
    delegate.light("/sun").setParam("intensity", 2.0f);
    delegate.light("/sun").setTransform(facingDown(0, 0, 0));
    delegate.settings().set("maxPathDepth", 1);
    return meanChannel(render(delegate, 4, 4, 4), 0);
  };
  const float c = std::cos(float(M_PI) / 3), s = std::sin(float(M_PI) / 3);
  // The fallback surface (no material) is diffuse within 1 % of Lambertian.
  const double flat = floorUnderSun({}, Interpolation::Vertex);
  EXPECT_NEAR(flat, 0.5 / M_PI * 2, 0.01 * flat);
  // Normals tilted 60° from the sun: E·cos 60°, whatever their interpolation.
  const std::vector<std::pair<std::vector<Vec3f>, Interpolation>> tilted = {
      {{{s, c, 0}}, Interpolation::Constant},
      {std::vector<Vec3f>(4, {0, c, s}), Interpolation::Vertex},
      {std::vector<Vec3f>(4, {-s, c, 0}), Interpolation::FaceVarying},
      {{{0, c, -s}}, Interpolation::Uniform}};
  for (const auto& [normals, interpolation] : tilted)
    EXPECT_NEAR(floorUnderSun(normals, interpolation) / flat, 0.5, 0.01);
}

TEST(RenderDelegate, RenderPassesResolveBoundAovsIntoRenderBuffers) {
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  delegate.insertSprim("domeLight", "/sky");
  delegate.insertBprim("renderBuffer", "/buffers/color");
  delegate.renderBuffer("/buffers/color").allocate(4, 4);
  RenderPass pass(delegate, "/cam", 4, 4);
  pass.setAovBindings({{"color", "/buffers/color"}});
  delegate.settings().set("samples", 4);
  pass.execute(2);
  const RenderBuffer& buffer = delegate.renderBuffer("/buffers/color");
  EXPECT_EQ(buffer.channels(), 4);
  EXPECT_EQ(buffer.data(), pass.aov("color"));
  EXPECT_FALSE(buffer.converged());
  pass.execute(2);
  EXPECT_TRUE(buffer.converged());
  EXPECT_THROW(pass.setAovBindings({{"normal", "/buffers/color"}}), std::invalid_argument);
  EXPECT_THROW(pass.setAovBindings({{"Z", "/missing"}}), std::out_of_range);
  delegate.renderBuffer("/buffers/color").allocate(8, 8);
  EXPECT_THROW(pass.execute(1), std::invalid_argument);
}

TEST(Render, ManyLightsSumToTheirAnalyticIrradiance) {
  // 200 sphere lights of varied size, power and colour over a Lambertian floor: the light tree
  // chooses among them, and the estimate must still be their sum.
  RenderDelegate delegate;
  lambertianFloorScene(delegate, 0.5f);
  double irradiance = 0;
  for (int i = 0; i < 200; ++i) {
    const double x = std::fmod(i * 0.618034, 1.0) * 8 - 4, z = std::fmod(i * 0.414214, 1.0) * 8 - 4;
    const double y = 1 + std::fmod(i * 0.732051, 1.0) * 2;
    const float radius = 0.02f + 0.08f * float(std::fmod(i * 0.236068, 1.0));
    const float intensity = 1 + float(i % 7) * 3;
    const std::string id = "/bulb" + std::to_string(i);
    delegate.insertSprim("sphereLight", id);
    delegate.light(id).setParam("radius", radius);
    delegate.light(id).setParam("intensity", intensity);
    delegate.light(id).setTransform(translation(x, y, z));
    // π L (r/d)² cos θ for a sphere wholly above the plane.
    const double d2 = x * x + y * y + z * z;
    irradiance += M_PI * intensity * (radius * radius / d2) * (y / std::sqrt(d2));
  }
  delegate.settings().set("maxPathDepth", 1);
  const std::vector<float> image = render(delegate, 8, 8, 1024);
  EXPECT_NEAR(meanChannel(image, 0) / (0.5 / M_PI * irradiance), 1.0, 0.02);
}

TEST(Render, AHiddenDomeDoesNotStarveTheLightInAClosedRoom) {
  // A closed room lit by a 1 m² ceiling panel; a bright dome outside cannot reach the floor.
  // Infinite and local lights are sampled apart, so the dome changes nothing: the image is the
  // same bit for bit (choosing one light per point, even with the panel kept at a quarter of
  // the samples, multiplied the noise by 9; choosing by power, by 1,000).
  const auto renderRoom = [](bool withDome) {
    RenderDelegate delegate;
    const float s = 2, h = 3;
    delegate.insertRprim("mesh", "/room");
    delegate.mesh("/room").setPoints({{-s, 0, -s},
                                      {s, 0, -s},
                                      {s, 0, s},
                                      {-s, 0, s},
                                      {-s, h, -s},
                                      {s, h, -s},
                                      {s, h, s},
                                      {-s, h, s}});
    delegate.mesh("/room").setTopology(
        {4, 4, 4, 4, 4, 4},
        {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7}, false, "none");
    delegate.mesh("/room").setDoubleSided(true);
    delegate.mesh("/room").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
    delegate.insertSprim("rectLight", "/panel");
    delegate.light("/panel").setParam("intensity", 10.0f);
    delegate.light("/panel").setTransform(facingDown(0, h - 0.01, 0));
    if (withDome) {
      delegate.insertSprim("domeLight", "/sky");
      delegate.light("/sky").setParam("intensity", 1000.0f);
    }
    addCamera(delegate, facingDown(0.5, 2, 0.5), 20);
    delegate.settings().set("maxPathDepth", 1);
    return render(delegate, 16, 16, 16);
  };
  const std::vector<float> room = renderRoom(false), domed = renderRoom(true);
  EXPECT_GT(meanChannel(room, 0), 0.01);
  EXPECT_EQ(domed, room);
}

namespace {

/// rRMSE of a render's red channel against a reference (both RGBA).
double relativeRmse(const std::vector<float>& image, const std::vector<float>& reference) {
  double sum = 0;
  for (size_t i = 0; i < image.size(); i += 4)
    sum += std::pow(image[i] - reference[i], 2) / (std::pow(reference[i], 2) + 0.01);
  return std::sqrt(sum / double(image.size() / 4));
}

/// The occluded panel's floor (noisy soft shadows and indirect light) beside a uniformly
/// emissive wall that any single sample gets right.
void adaptiveScene(RenderDelegate& delegate) {
  occludedPanelScene(delegate, 20);
  addFloor(delegate, "/glow", 10, 0.01f);
  delegate.mesh("/glow").setTransform(translation(-10.5, 0, 0));  // covers x < -0.5
  delegate.insertSprim("material", "/emitter");
  delegate.material("/emitter").setParam("emissiveColor", Vec3f(0.5f));
  delegate.material("/emitter").setParam("diffuseColor", Vec3f(0.0f));
  delegate.material("/emitter").setParam("specularColor", Vec3f(0.0f));
  delegate.material("/emitter").setParam("useSpecularWorkflow", 1);
  delegate.mesh("/glow").setMaterialId("/emitter");
  delegate.settings().set("adaptiveThreshold", 0.05);
  delegate.settings().set("adaptiveMinSamples", 8);
  // One light estimate: with more (the pilot's choice), the lit floor is too smooth to show
  // pixels that go on sampling after the first test.
  delegate.settings().set("lightSamples", 1);
}

}  // namespace

TEST(Render, AdaptiveSamplingIsBitIdenticalForAnyThreadCountAndSplit) {
  const auto renderWith = [](int threads, std::vector<int> passes) {
    RenderDelegate delegate;
    adaptiveScene(delegate);
    delegate.settings().set("threads", threads);
    RenderPass pass(delegate, "/cam", 48, 40);
    for (int samples : passes) pass.execute(samples);
    return std::pair{pass.aov("color"), pass.meanSamples()};
  };
  const auto one = renderWith(1, {64});
  EXPECT_LT(one.second, 64);  // some pixels stopped early
  EXPECT_EQ(one, renderWith(2, {64}));
  EXPECT_EQ(one, renderWith(2, {5, 30, 1, 28}));
  EXPECT_EQ(one, renderWith(1, std::vector<int>(64, 1)));
}

TEST(Render, AdaptiveSamplingStopsConvergedPixelsAndKeepsTheMean) {
  RenderDelegate delegate;
  adaptiveScene(delegate);
  RenderPass adaptive(delegate, "/cam", 48, 40);
  adaptive.execute(256);
  // The emissive half stops at the first test (8 samples); the lit floor goes on.
  EXPECT_LT(adaptive.meanSamples(), 0.5 * 256);
  EXPECT_GT(adaptive.meanSamples(), 0.5 * 8 + 8);
  const std::vector<float> image = adaptive.aov("color");
  delegate.settings().set("adaptiveThreshold", 0.0);
  RenderPass full(delegate, "/cam", 48, 40);
  full.execute(256);
  EXPECT_EQ(full.meanSamples(), 256);
  const std::vector<float> reference = full.aov("color");
  double emissive = 0;
  for (size_t i = 0; i < image.size(); i += 4)
    if (i / 4 % 48 < 12) emissive += image[i];  // the left quarter is the emissive wall
  EXPECT_LT(relativeRmse(image, reference), 0.05);
  EXPECT_NEAR(meanChannel(image, 0) / meanChannel(reference, 0), 1.0, 0.01);
  EXPECT_NEAR(emissive / (12 * 40), 0.5, 1e-3);  // its grazing Fresnel reflection aside
}

TEST(Render, AdaptiveSamplingGivesPixelsSamplesInProportionToTheirNoise) {
  // A film fed samples of mean 1 whose spread is σ = 0.8 in its left half and 0.2 in its right
  // half, tested at powers of two as a render pass tests it: n ≥ 4σ/T asks for 178 and 44
  // samples, taken as 256 and 64 (the rule it replaced, e < T, asked for σ²/T² = 1975 and 123:
  // 16 times as many, not 4).
  constexpr int kWidth = 16, kHeight = 8;
  constexpr float kThreshold = 0.018f;
  Film film(kWidth, kHeight);
  std::mt19937 random(5);
  for (uint32_t sample = 0; sample < 2048; ++sample) {
    if (sample >= 8 && (sample & (sample - 1)) == 0) film.updateConvergence(kThreshold);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        if (!film.isActive(x, y)) continue;
        const float spread = x < kWidth / 2 ? 0.8f : 0.2f;
        const float uniform = float(random() >> 8) * 0x1p-24f;  // [0, 1)
        CameraSample cameraSample;
        cameraSample.radiance = Vec3f(1 + spread * std::sqrt(3.0f) * (2 * uniform - 1));
        film.addSample(x, y, sample, cameraSample);
      }
  }
  const std::vector<float> counts = film.resolve(AovRequest{AovKind::SampleCount, {}});
  // 6 columns each, away from the middle where neighbourhoods mix. One forward pass: GCC 12.2 at
  // -O3 summed the right columns wrongly when a loop read them in reverse beside the left ones.
  double noisy = 0, quiet = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      if (x < 6) noisy += counts[size_t(y * kWidth + x)];
      if (x >= kWidth - 6) quiet += counts[size_t(y * kWidth + x)];
    }
  EXPECT_GT(quiet / (6 * kHeight), 40);
  EXPECT_LT(quiet / (6 * kHeight), 80);
  EXPECT_NEAR(noisy / quiet, 4, 1);
}

TEST(Render, AdaptiveSamplingBeatsUniformSamplingAtTheSameMeanSampleCount) {
  // The occluded panel's floor alone: noise that varies smoothly over the image (a soft
  // shadow, indirect light), no region that any one sample gets right. Spending samples in
  // proportion to each pixel's noise (σ) makes the image's error the least for the samples
  // spent; stopping each pixel once its own error is below the threshold (samples ∝ σ²) spent
  // more of them on the noisiest pixels.
  RenderDelegate delegate;
  occludedPanelScene(delegate, 20);
  delegate.settings().set("seed", 7);  // the reference's samples are not the renders'
  RenderPass converged(delegate, "/cam", 48, 40);
  converged.execute(1024);
  const std::vector<float> reference = converged.aov("color");
  delegate.settings().set("seed", 1);
  delegate.settings().set("adaptiveThreshold", 0.03);
  delegate.settings().set("adaptiveMinSamples", 8);
  RenderPass adaptive(delegate, "/cam", 48, 40);
  adaptive.execute(256);
  const double meanSamples = adaptive.meanSamples();
  ASSERT_GT(meanSamples, 16);
  ASSERT_LT(meanSamples, 128);
  delegate.settings().set("adaptiveThreshold", 0.0);
  RenderPass uniform(delegate, "/cam", 48, 40);
  uniform.execute(int(std::lround(meanSamples)));
  const double adaptiveError = relativeRmse(adaptive.aov("color"), reference);
  const double uniformError = relativeRmse(uniform.aov("color"), reference);
  // 0.63 (33.1 samples on average); the rule it replaced gives 0.65 here (55.9 samples), so
  // this guards the gain over uniform sampling, and the test above the split of the samples.
  EXPECT_LT(adaptiveError, 0.67 * uniformError) << meanSamples << " samples on average";
}

TEST(Render, CropsAreBitIdenticalToThePixelsOfTheWholeImage) {
  RenderDelegate delegate;
  occludedPanelScene(delegate);
  // AOVs too: filtered (normal), nearest (depth) and nearest the pixel centre (primId).
  const std::vector<std::string> aovs = {"depth", "normal", "primId"};
  RenderPass whole(delegate, "/cam", 48, 40);
  whole.setAovs(aovs);
  whole.execute(16);
  for (const PixelRect& crop : {PixelRect{0, 0, 48, 13}, PixelRect{0, 13, 48, 27},
                                PixelRect{17, 9, 5, 21}, PixelRect{47, 39, 1, 1}}) {
    RenderPass part(delegate, "/cam", 48, 40, crop);
    part.setAovs(aovs);
    part.execute(16);
    ASSERT_EQ(part.width(), crop.width);
    ASSERT_EQ(part.height(), crop.height);
    EXPECT_EQ(part.aov("color"), cropOf(whole.aov("color"), 48, 4, crop));
    EXPECT_EQ(part.aov("Z"), cropOf(whole.aov("Z"), 48, 1, crop));
    EXPECT_EQ(part.aov("depth"), cropOf(whole.aov("depth"), 48, 1, crop));
    EXPECT_EQ(part.aov("normal"), cropOf(whole.aov("normal"), 48, 3, crop));
    EXPECT_EQ(part.aov("primId"), cropOf(whole.aov("primId"), 48, 1, crop));
  }
  EXPECT_THROW(RenderPass(delegate, "/cam", 48, 40, PixelRect{40, 0, 9, 4}), std::invalid_argument);
  EXPECT_THROW(RenderPass(delegate, "/cam", 48, 40, PixelRect{0, 0, 0, 4}), std::invalid_argument);
}

TEST(Render, AdaptiveCropsNeedAMarginAsWideAsTheConvergenceTestsReach) {
  RenderDelegate delegate;
  adaptiveScene(delegate);  // tests at 8, 16, 32, ...
  EXPECT_EQ(RenderPass::adaptiveSamplingReach(8, 8), 0);
  EXPECT_EQ(RenderPass::adaptiveSamplingReach(9, 8), 1);
  EXPECT_EQ(RenderPass::adaptiveSamplingReach(64, 8), 3);  // 8, 16, 32
  EXPECT_EQ(RenderPass::adaptiveSamplingReach(65, 8), 4);
  EXPECT_EQ(RenderPass::adaptiveSamplingReach(1024, 16), 6);  // 16, 32, ..., 512
  EXPECT_EQ(RenderPass::adaptiveSamplingReach(64, 12), 3);    // 12, 16, 32
  const int reach = RenderPass::adaptiveSamplingReach(64, 8);
  RenderPass whole(delegate, "/cam", 48, 40);
  whole.execute(64);
  uint64_t samples = 0;
  for (const PixelRect& crop :
       {PixelRect{0, 0, 48, 10}, PixelRect{0, 10, 48, 20}, PixelRect{0, 30, 48, 10}}) {
    RenderPass part(delegate, "/cam", 48, 40, crop, reach);
    part.execute(64);
    EXPECT_EQ(part.aov("color"), cropOf(whole.aov("color"), 48, 4, crop));
    samples += part.samplesTaken();
  }
  EXPECT_EQ(samples, whole.samplesTaken());
  EXPECT_LT(whole.meanSamples(), 64);  // adaptive sampling did stop pixels

  // A narrower margin would let the crop's edge rows, whose neighbourhoods are cut short,
  // stop pixels the whole image keeps sampling (or the reverse): refused.
  RenderPass narrow(delegate, "/cam", 48, 40, PixelRect{0, 15, 48, 10}, reach - 1);
  EXPECT_THROW(narrow.execute(64), std::invalid_argument);
  RenderPass enough(delegate, "/cam", 48, 40, PixelRect{0, 15, 48, 10}, reach - 1);
  EXPECT_NO_THROW(enough.execute(32));  // fewer samples, fewer tests
}

TEST(Render, IndirectSamplesKeepTheMeanAndCutTheNoiseBeyondTheFirstSurface) {
  // All of the floor's light is found beyond its first surface, where the branches share it out.
  const auto renderWith = [](int indirectSamples, int samples, int seed) {
    RenderDelegate delegate;
    floorLitByCeiling(delegate);
    delegate.settings().set("indirectSamples", indirectSamples);
    delegate.settings().set("seed", seed);
    return render(delegate, 48, 40, samples);
  };
  const std::vector<float> reference = renderWith(1, 1024, 7);
  const std::vector<float> single = renderWith(1, 16, 1), branched = renderWith(4, 16, 1);
  EXPECT_GT(meanChannel(reference, 0), 0.01);
  EXPECT_NEAR(meanChannel(branched, 0) / meanChannel(reference, 0), 1.0, 0.01);
  EXPECT_NEAR(meanChannel(branched, 3), 1.0, 1e-6);
  // Four times the paths beyond the floor, stratified together: 0.31 of the noise (independent
  // paths would leave half of it).
  const double singleError = relativeRmse(single, reference);
  const double branchedError = relativeRmse(branched, reference);
  EXPECT_LT(branchedError, 0.6 * singleError) << singleError;
}

TEST(Render, BranchesThroughDispersiveGlassEachKeepTheirOwnWavelengths) {
  // A white furnace: a white floor beside a dispersive glass sphere, under a white dome, seen
  // from above. Branches from the floor that pass through the glass keep only their hero
  // wavelength, the others all three: each branch's light is turned into RGB with its own
  // wavelengths, else the ones that went through the glass count a third of what they carry.
  RenderDelegate delegate;
  addFloor(delegate, "/floor", 50);
  delegate.mesh("/floor").setDisplayColor({Vec3f(1.0f)}, Interpolation::Constant);
  addSphere(delegate, "/ball", 1);
  delegate.mesh("/ball").setTransform(translation(1.5, 1.2, 0));
  delegate.insertSprim("material", "/glass");
  delegate.material("/glass").setParam("opacity", 0.0f);
  delegate.material("/glass").setParam("roughness", 0.0f);
  delegate.material("/glass").setParam("penumbra:abbeNumber", 20.0f);
  delegate.mesh("/ball").setMaterialId("/glass");
  delegate.insertSprim("domeLight", "/sky");
  addCamera(delegate, facingDown(0, 5, 0));
  for (const char* key : {"maxPathDepth", "maxDiffuseDepth", "maxTransmissionDepth"})
    delegate.settings().set(key, 64);
  delegate.settings().set("indirectSamples", 3);
  const std::vector<float> image = render(delegate, 16, 16, 64);
  for (int channel = 0; channel < 3; ++channel)
    EXPECT_NEAR(meanChannel(image, channel), 1.0, 0.02) << "channel " << channel;
}

TEST(Render, ADispersiveSheetKeepsEveryWavelength) {
  // A dispersive thin sheet (an open quad of smooth glass) under a white dome, seen from above:
  // every wavelength sees the dome (radiance 1) whether the sheet reflects or transmits it, so
  // every pixel's value is 1. Neither direction depends on the wavelength, so the paths keep all
  // three of theirs; a trace of opacity makes the BSDF more than a smooth interface, which keeps
  // the hero alone from the sheet on, and its single wavelength's colour is far noisier.
  const auto renderWith = [](float opacity) {
    RenderDelegate delegate;
    delegate.insertSprim("material", "/glass");
    delegate.material("/glass").setParam("opacity", opacity);
    delegate.material("/glass").setParam("roughness", 0.0f);
    delegate.material("/glass").setParam("penumbra:abbeNumber", 20.0f);
    addFloor(delegate, "/sheet", 50);
    delegate.mesh("/sheet").setMaterialId("/glass");
    delegate.insertSprim("domeLight", "/sky");
    addCamera(delegate, facingDown(0, 5, 0));
    return render(delegate, 24, 24, 8);
  };
  const auto errorFromWhite = [](const std::vector<float>& image) {
    double sum = 0;
    for (size_t i = 0; i < image.size(); i += 4)
      for (size_t c = 0; c < 3; ++c) sum += std::pow(image[i + c] - 1.0, 2);
    return std::sqrt(sum / double(image.size() / 4 * 3));
  };
  const std::vector<float> sheet = renderWith(0);
  for (int channel = 0; channel < 3; ++channel)
    EXPECT_NEAR(meanChannel(sheet, channel), 1.0, 0.01) << "channel " << channel;
  const double error = errorFromWhite(sheet), heroAlone = errorFromWhite(renderWith(0.001f));
  RecordProperty("rmsError",
                 std::to_string(error) + " (hero alone " + std::to_string(heroAlone) + ")");
  EXPECT_LT(error, 0.6 * heroAlone);
}

TEST(Render, ASmoothDispersiveSolidSeenDirectlyRefractsEveryWavelength) {
  // A smooth dispersive glass ball under a white dome, seen from above: refraction into it keeps
  // one wavelength per path, and each camera ray that meets it goes on as one copy per
  // wavelength, so that what is seen through it is as white from sample to sample as the dome.
  // A trace of opacity makes the BSDF more than a smooth interface: the hero alone goes on from
  // the ball, and its colour is far noisier. The means are those of glass without dispersion,
  // with two branches too (six paths then share the sample's weight).
  const auto renderWith = [](float abbeNumber, float opacity, int branches = 1) {
    RenderDelegate delegate;
    addSphere(delegate, "/ball", 1);
    delegate.insertSprim("material", "/glass");
    delegate.material("/glass").setParam("opacity", opacity);
    delegate.material("/glass").setParam("roughness", 0.0f);
    delegate.material("/glass").setParam("penumbra:abbeNumber", abbeNumber);
    delegate.mesh("/ball").setMaterialId("/glass");
    delegate.insertSprim("domeLight", "/sky");
    delegate.settings().set("indirectSamples", branches);
    addCamera(delegate, facingDown(0, 5, 0), 2.5f);
    return render(delegate, 24, 24, 32);
  };
  const auto rmsFromMean = [](const std::vector<float>& image) {
    double sum = 0;
    for (size_t c = 0; c < 3; ++c) {
      const double mean = meanChannel(image, int(c));
      for (size_t i = 0; i < image.size(); i += 4) sum += std::pow(image[i + c] - mean, 2);
    }
    return std::sqrt(sum / double(image.size() / 4 * 3));
  };
  const std::vector<float> dispersive = renderWith(20, 0), plain = renderWith(0, 0),
                           twoBranches = renderWith(20, 0, 2);
  for (int channel = 0; channel < 3; ++channel) {
    EXPECT_NEAR(meanChannel(dispersive, channel) / meanChannel(plain, channel), 1.0, 0.02)
        << "channel " << channel;
    EXPECT_NEAR(meanChannel(twoBranches, channel) / meanChannel(plain, channel), 1.0, 0.02)
        << "channel " << channel << ", two branches";
  }
  const double error = rmsFromMean(dispersive), heroAlone = rmsFromMean(renderWith(20, 0.001f));
  RecordProperty("rmsFromMean",
                 std::to_string(error) + " (hero alone " + std::to_string(heroAlone) + ")");
  EXPECT_LT(error, 0.6 * heroAlone);
}

TEST(Render, AGlowSeenThroughDispersiveGlassKeepsItsBrightness) {
  // A white glowing black ball inside a glass ball, seen from above against black. Refraction into
  // the glass keeps the hero wavelength alone as it is chosen: the glow, found before the path
  // meets the glass again, counts the hero alone too, not a third of it beside two dark channels.
  // Against the same glass without dispersion (rendered in RGB), per channel.
  const auto renderWith = [](float abbeNumber) {
    RenderDelegate delegate;
    addSphere(delegate, "/ball", 1);
    delegate.insertSprim("material", "/glass");
    delegate.material("/glass").setParam("opacity", 0.0f);
    delegate.material("/glass").setParam("roughness", 0.0f);
    delegate.material("/glass").setParam("penumbra:abbeNumber", abbeNumber);
    delegate.mesh("/ball").setMaterialId("/glass");
    addSphere(delegate, "/glow", 0.5f);
    delegate.insertSprim("material", "/white");
    delegate.material("/white").setParam("emissiveColor", Vec3f(1.0f));
    delegate.mesh("/glow").setMaterialId("/white");
    delegate.settings().set("maxTransmissionDepth", 1);
    addCamera(delegate, facingDown(0, 5, 0), 2.5f);
    return render(delegate, 24, 24, 64);
  };
  const std::vector<float> dispersive = renderWith(40), plain = renderWith(0);
  EXPECT_GT(meanChannel(plain, 0), 0.1);
  for (int channel = 0; channel < 3; ++channel)
    EXPECT_NEAR(meanChannel(dispersive, channel) / meanChannel(plain, channel), 1.0, 0.03)
        << "channel " << channel;
}

TEST(Render, IndirectSamplesAreBitIdenticalForAnyThreadCountAndSplit) {
  const auto renderWith = [](int threads, std::vector<int> passes) {
    RenderDelegate delegate;
    occludedPanelScene(delegate);
    delegate.settings().set("indirectSamples", 3);
    delegate.settings().set("threads", threads);
    RenderPass pass(delegate, "/cam", 48, 40);
    for (int samples : passes) pass.execute(samples);
    return pass.aov("color");
  };
  const std::vector<float> one = renderWith(1, {8});
  EXPECT_EQ(one, renderWith(2, {8}));
  EXPECT_EQ(one, renderWith(2, {2, 5, 1}));
  RenderDelegate delegate;
  occludedPanelScene(delegate);
  delegate.settings().set("indirectSamples", 1);
  EXPECT_NE(one, render(delegate, 48, 40, 8));  // the branches are not the unbranched path
  // With path guiding: a crop traces the training samples again over the whole image, branching
  // as they do, without recording them into its film, and its pixels are still the image's.
  delegate.settings().set("indirectSamples", 2);
  delegate.settings().set("guidingTrainingSamples", 4);
  RenderPass whole(delegate, "/cam", 48, 40);
  whole.execute(8);
  const PixelRect crop{17, 9, 5, 21};
  RenderPass part(delegate, "/cam", 48, 40, crop);
  part.execute(8);
  EXPECT_EQ(part.aov("color"), cropOf(whole.aov("color"), 48, 4, crop));
  EXPECT_THROW(delegate.settings().set("indirectSamples", -1), std::invalid_argument);
  EXPECT_THROW(delegate.settings().set("indirectSamples", kMaxIndirectSamples + 1),
               std::invalid_argument);
}

TEST(Render, IndirectClampLimitsOnlyIndirectLight) {
  const auto renderWith = [](int maxPathDepth, float clamp) {
    // A floor and a white ceiling 2 m above it, lit by a panel just under the ceiling: the
    // ceiling sends much of the light back (indirect light).
    RenderDelegate delegate;
    addFloor(delegate, "/floor", 50);
    delegate.mesh("/floor").setDisplayColor({Vec3f(0.7f)}, Interpolation::Constant);
    addFloor(delegate, "/ceiling", 50, 2);
    delegate.mesh("/ceiling").setDoubleSided(true);
    delegate.mesh("/ceiling").setDisplayColor({Vec3f(0.8f)}, Interpolation::Constant);
    delegate.insertSprim("rectLight", "/panel");
    delegate.light("/panel").setParam("intensity", 10.0f);
    delegate.light("/panel").setTransform(facingDown(0, 1.9, 0));
    addCamera(delegate, facingDown(0.5, 1.5, 0), 5);
    delegate.settings().set("maxPathDepth", maxPathDepth);
    delegate.settings().set("indirectClamp", clamp);
    return render(delegate, 24, 20, 64);
  };
  // Direct light (one interaction) is never clamped, however low the limit.
  EXPECT_EQ(renderWith(1, 1e-4f), renderWith(1, 0));
  // Indirect light is: with a tiny limit the image keeps little more than its direct light.
  const double direct = meanChannel(renderWith(1, 0), 0);
  const double full = meanChannel(renderWith(8, 0), 0);
  const double clamped = meanChannel(renderWith(8, 1e-4f), 0);
  ASSERT_GT(full, direct * 1.05);  // measured: 11 % more
  EXPECT_LT(clamped, direct + 0.1 * (full - direct));
  EXPECT_GE(clamped, direct * 0.999);
}

/// A grey floor under a small bulb and a ceiling of `/ceiling`'s material at height 2, seen from
/// above: the floor also receives the bulb's image in the ceiling, a caustic that only
/// BSDF-sampled rays from the floor can find where the ceiling reflects sharply (the path tracer
/// alone: light tracing, caustics.h, would find it from the bulb).
std::vector<float> renderCausticUnderCeiling(const std::function<void(plugin::Material&)>& ceiling,
                                             float glossyFilter, int maxPathDepth, int seed) {
  RenderDelegate delegate;
  floorUnderCeiling(delegate, "/mirror", 2);
  delegate.insertSprim("material", "/ceiling");
  ceiling(delegate.material("/ceiling"));
  delegate.mesh("/mirror").setMaterialId("/ceiling");
  delegate.insertSprim("sphereLight", "/bulb");
  delegate.light("/bulb").setParam("radius", 0.05f);
  delegate.light("/bulb").setParam("intensity", 100.0f);
  delegate.light("/bulb").setTransform(translation(0, 1, 0));
  addCamera(delegate, facingDown(0.5f, 1.5f, 0), 5);
  delegate.settings().set("maxPathDepth", maxPathDepth);
  delegate.settings().set("glossyFilter", glossyFilter);
  delegate.settings().set("seed", seed);
  delegate.settings().set("caustics", 0);
  return render(delegate, 16, 16, 16);
}

/// Per-pixel noise of the red channel between two renders that differ in their seed.
double seedNoise(const std::vector<float>& a, const std::vector<float>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); i += 4) sum += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(sum / double(a.size() / 4) / 2);
}

TEST(Render, GlossyFilterBlursCausticsButNotWhatTheCameraSees) {
  // A mirror ceiling: the glossy filter roughens it for the floor's rays, so light sampling at
  // the mirror finds the bulb: far less noise, a slightly different (biased) mean.
  const auto chrome = [](plugin::Material& material) {
    material.setParam("metallic", 1.0f);
    material.setParam("roughness", 0.0f);
    material.setParam("diffuseColor", Vec3f(1));
  };
  const auto renderWith = [&](float glossyFilter, int maxPathDepth, int seed) {
    return renderCausticUnderCeiling(chrome, glossyFilter, maxPathDepth, seed);
  };
  // What the camera sees first is never filtered.
  EXPECT_EQ(renderWith(1, 1, 1), renderWith(0, 1, 1));
  const std::vector<float> sharp[2] = {renderWith(0, 2, 1), renderWith(0, 2, 2)};
  const std::vector<float> filtered[2] = {renderWith(1, 2, 1), renderWith(1, 2, 2)};
  EXPECT_LT(seedNoise(filtered[0], filtered[1]), 0.3 * seedNoise(sharp[0], sharp[1]));
  EXPECT_NEAR(meanChannel(filtered[0], 0) / meanChannel(sharp[0], 0), 1.0, 0.25);
}

TEST(Render, GlossyFilterBlursTheCausticOfAClearcoatOverARoughBase) {
  // A black, rough base under a mirror coat: the roughness alone is already wider than the
  // filter's, and only the coat's (the filter must raise a coat's roughness as well, though a
  // material without a coat keeps its BSDF as it is).
  const auto coated = [](plugin::Material& material) {
    material.setParam("diffuseColor", Vec3f(0));
    material.setParam("roughness", 1.0f);
    material.setParam("clearcoat", 1.0f);
    material.setParam("clearcoatRoughness", 0.0f);
  };
  const std::vector<float> sharp[2] = {renderCausticUnderCeiling(coated, 0, 2, 1),
                                       renderCausticUnderCeiling(coated, 0, 2, 2)};
  const std::vector<float> filtered[2] = {renderCausticUnderCeiling(coated, 1, 2, 1),
                                          renderCausticUnderCeiling(coated, 1, 2, 2)};
  EXPECT_LT(seedNoise(filtered[0], filtered[1]), 0.5 * seedNoise(sharp[0], sharp[1]));
}
