// Caustics by light tracing (penumbra/caustics.h): what the light tracer adds is what the path
// tracer leaves out, deterministically, and only where it can match the path tracer.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "penumbra/caustics.h"
#include "penumbra/film.h"
#include "penumbra/filter.h"
#include "penumbra/image_io.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "penumbra/render.h"
#include "scene_builders.h"
#include "scratch_directory.h"
#include "transforms.h"

using namespace penumbra;
using namespace penumbra::plugin;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::addSphere;
using penumbra::test::facingDown;
using penumbra::test::translation;

namespace {

constexpr int kSize = 24;

/// A grey floor under a glass ball, lit from the side by a sphere light, seen from above where
/// the ball focuses the light onto the floor (the ball itself at the image's edge). With
/// `metalCeiling`, a metal ceiling above the lamp and the camera: the sphere around it, at
/// which light paths aim too, then holds the lamp.
void glassBallScene(RenderDelegate& delegate, float roughness = 0.1f, bool metalCeiling = false) {
  addFloor(delegate, "/floor", 20);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  addSphere(delegate, "/ball", 0.5f);
  delegate.mesh("/ball").setTransform(translation(0, 1, 0));
  delegate.insertSprim("material", "/glass");
  delegate.material("/glass").setParam("opacity", 0.0f);
  delegate.material("/glass").setParam("ior", 1.5f);
  delegate.material("/glass").setParam("roughness", roughness);
  delegate.mesh("/ball").setMaterialId("/glass");
  delegate.insertSprim("sphereLight", "/bulb");
  delegate.light("/bulb").setParam("radius", 0.3f);
  delegate.light("/bulb").setParam("intensity", 20.0f);
  delegate.light("/bulb").setTransform(translation(-1.5, 2.5, 0));
  addCamera(delegate, facingDown(0.9, 4, 0), 2);
  if (!metalCeiling) return;
  addFloor(delegate, "/ceiling", 6, 5);
  delegate.insertSprim("material", "/metal");
  delegate.material("/metal").setParam("metallic", 1.0f);
  delegate.material("/metal").setParam("roughness", 0.2f);
  delegate.mesh("/ceiling").setMaterialId("/metal");
}

/// A sun 10 degrees across whose light travels along (cos, sin, 0) of `elevation` degrees
/// (negative: downwards).
void addSun(RenderDelegate& delegate, double elevation) {
  delegate.insertSprim("distantLight", "/sun");
  delegate.light("/sun").setParam("angle", 10.0f);
  delegate.light("/sun").setParam("intensity", 2.0f);
  delegate.light("/sun").setParam("normalize", true);  // intensity: the irradiance it gives
  // Local -Z along the light's way, local X along world Z.
  const double c = std::cos(elevation * kPi / 180), s = std::sin(elevation * kPi / 180);
  const double sunToWorld[16] = {0, 0, 1, 0, -s, c, 0, 0, -c, -s, 0, 0, 0, 0, 0, 1};
  delegate.light("/sun").setTransform(Transform::fromRowMajor(sunToWorld));
}

std::vector<float> render(RenderDelegate& delegate, const std::string& caustics, int samples,
                          int threads = 0, int width = kSize) {
  delegate.settings().set("caustics", caustics == "path" ? 0 : caustics == "light" ? 1 : 2);
  delegate.settings().set("threads", threads);
  RenderPass pass(delegate, "/cam", width, width);
  pass.execute(samples);
  return pass.aov("color");
}

/// Mean of channel 0 over the pixels of rows and columns [from, to).
double meanOver(const std::vector<float>& rgba, int from, int to, int width = kSize) {
  double sum = 0;
  for (int y = from; y < to; ++y)
    for (int x = from; x < to; ++x) sum += rgba[size_t(4 * (y * width + x))];
  return sum / double((to - from) * (to - from));
}

}  // namespace

TEST(Caustics, CastersAreSmoothGlassMetalAndPlastic) {
  MaterialParams glass;
  glass.opacity = 0;
  glass.roughness = 0.1f;
  EXPECT_TRUE(castsCaustics(glass));
  EXPECT_FALSE(receivesCaustics(glass));
  MaterialParams frosted = glass;
  frosted.roughness = 0.5f;
  EXPECT_FALSE(castsCaustics(frosted));
  MaterialParams tinted = glass;
  tinted.transmissionDepth = 1;  // absorbs inside
  EXPECT_FALSE(castsCaustics(tinted));
  MaterialParams metal;
  metal.metallic = 1;
  metal.roughness = 0.2f;
  EXPECT_TRUE(castsCaustics(metal));
  MaterialParams coated = metal;
  coated.clearcoat = 1;
  coated.clearcoatRoughness = 0.6f;
  EXPECT_FALSE(castsCaustics(coated));
  MaterialParams plastic;
  plastic.roughness = 0.1f;
  EXPECT_FALSE(castsCaustics(plastic));
  EXPECT_TRUE(receivesCaustics(plastic));
  MaterialParams hair = metal;
  hair.hair = true;
  EXPECT_FALSE(castsCaustics(hair));
  EXPECT_FALSE(receivesCaustics(hair));
  // Plastic's smooth layers over its diffuse one cast; a rough coat, a sheen or translucency
  // over them make it no caster.
  EXPECT_EQ(casterKind(glass), CasterKind::Whole);
  EXPECT_EQ(casterKind(metal), CasterKind::Whole);
  EXPECT_EQ(casterKind(plastic), CasterKind::AboveDiffuse);
  MaterialParams lacquer = plastic;
  lacquer.clearcoat = 1;
  lacquer.clearcoatRoughness = 0.05f;
  EXPECT_EQ(casterKind(lacquer), CasterKind::AboveDiffuse);
  MaterialParams roughPlastic = plastic, velvet = plastic, translucent = plastic,
                 roughCoat = plastic;
  roughPlastic.roughness = 0.6f;
  velvet.sheen = 1;
  translucent.opacity = 0.5f;
  roughCoat.clearcoat = 1;
  roughCoat.clearcoatRoughness = 0.6f;
  for (const MaterialParams& other :
       {frosted, coated, hair, roughPlastic, velvet, translucent, roughCoat})
    EXPECT_EQ(casterKind(other), CasterKind::None);
  // Textures may give a plastic's hit a sheen or translucency its constants lack: that hit is
  // then no caster, for both tracers alike.
  const CausticTakeover takeover({CasterKind::AboveDiffuse, CasterKind::Whole}, {}, 3);
  EXPECT_EQ(takeover.casterKindAt(0, plastic), CasterKind::AboveDiffuse);
  EXPECT_EQ(takeover.casterKindAt(0, velvet), CasterKind::None);
  EXPECT_EQ(takeover.casterKindAt(0, translucent), CasterKind::None);
  EXPECT_EQ(takeover.casterKindAt(1, velvet), CasterKind::Whole);
  EXPECT_EQ(takeover.casterKindAt(2, plastic), CasterKind::None);  // no such material
}

TEST(Caustics, AFilmAddsItsLightTracedSumsOverTheLightPaths) {
  Film film(PixelRect{1, 1, 2, 2});
  CameraSample sample;
  sample.radiance = Vec3f(1.0f);
  sample.alpha = 1;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) film.addSample(x, y, 0, sample);
  film.addSplat(1, 1, 0, Vec3f(4, 2, 0));  // the film's pixel (0, 0)
  film.addSplat(2, 2, 0, Vec3f(0, 0, 8));  // its pixel (1, 1)
  film.addSplat(0, 0, 0, Vec3f(100.0f));   // outside its region
  film.addLightPaths(4, 0);
  const std::vector<float> rgba = film.resolveColor();
  EXPECT_EQ(std::vector<float>(rgba.begin(), rgba.begin() + 4),
            (std::vector<float>{2, 1.5f, 1, 1}));
  EXPECT_EQ(std::vector<float>(rgba.begin() + 4, rgba.begin() + 8),
            (std::vector<float>{1, 1, 1, 1}));
  EXPECT_EQ(std::vector<float>(rgba.begin() + 12, rgba.end()), (std::vector<float>{1, 1, 3, 1}));
  film.clear();
  EXPECT_EQ(film.lightPaths(), 0u);
}

TEST(Caustics, FilterDensityIsWhatCameraSamplesDraw) {
  const PixelFilter filter;
  // It integrates to one over the radius...
  double total = 0;
  const int steps = 20000;
  const double step = 2.0 * filter.radius() / steps;
  for (int i = 0; i < steps; ++i)
    total += filter.density1D(float(-filter.radius() + (i + 0.5) * step)) * step;
  EXPECT_NEAR(total, 1.0, 1e-3);
  EXPECT_EQ(filter.density1D(filter.radius() + 0.01f), 0.0f);
  // ... and the share of sampled offsets in a bin is its integral there.
  const int draws = 200000;
  int inBin = 0;
  for (int i = 0; i < draws; ++i) {
    const float offset = filter.sampleOffset({(float(i) + 0.5f) / draws, 0.5f}).x;
    inBin += offset > 0.2f && offset < 0.4f;
  }
  double binMass = 0;
  for (int i = 0; i < 1000; ++i)
    binMass += filter.density1D(0.2f + (float(i) + 0.5f) * 2e-4f) * 2e-4;
  EXPECT_NEAR(double(inBin) / draws, binMass, 2e-3);
}

namespace {

/// Image means, of the middle (the caustic) and of the whole, of a path-traced render and of one
/// split between the path tracer and many more light paths than its samples (light paths cost a
/// ray or two: the light tracer's own noise is then far below the tests' tolerances).
struct SplitMeans {
  double causticPath, causticLight, allPath, allLight;
  double causticLeftOut;  // what the path tracer found there in the split render
};

SplitMeans splitMeans(RenderDelegate& delegate, uint32_t lightSamples, uint32_t pathSamples = 2048,
                      uint32_t splitSamples = 1024) {
  const penumbra::Camera camera = test::syncedCamera(delegate, kSize);
  const Scene& scene = delegate.scene();
  RenderSettings settings;
  Film pathTraced(kSize, kSize);
  EXPECT_TRUE(renderSamples(scene, camera, pathTraced, 0, pathSamples, settings));
  const PixelFilter filter;
  const CausticTracer tracer(scene, camera, filter, settings.integrator);
  EXPECT_TRUE(tracer.active());
  settings.integrator.caustics = &tracer.takeover();
  Film split(kSize, kSize);
  EXPECT_TRUE(renderSamples(scene, camera, split, 0, splitSamples, settings));
  const std::vector<float> leftOut = split.resolveColor();
  EXPECT_TRUE(tracer.trace(0, lightSamples, split, 0));
  const std::vector<float> path = pathTraced.resolveColor(), light = split.resolveColor();
  return {meanOver(path, 8, 16), meanOver(light, 8, 16), meanOver(path, 0, kSize),
          meanOver(light, 0, kSize), meanOver(leftOut, 8, 16)};
}

/// The split render is the path-traced one: within 4 % on the caustic (the path tracer's
/// estimate there is the noisier), 1.5 % on the whole image. Each test gives what its seeds gave.
void expectTheSameImage(const SplitMeans& means) {
  EXPECT_NEAR(means.causticLight / means.causticPath, 1.0, 0.04);
  EXPECT_NEAR(means.allLight / means.allPath, 1.0, 0.015);
}

/// The caustic is at least `brighter` times the image's mean, the path tracer leaves most of it
/// to the light tracer, and the split render is the path-traced one (expectTheSameImage).
void expectTheCausticTakenOver(const SplitMeans& means, double brighter) {
  ASSERT_GT(means.causticPath, brighter * means.allPath);
  EXPECT_LT(means.causticLeftOut, 0.5 * means.causticPath);
  expectTheSameImage(means);
}

}  // namespace

TEST(Caustics, LightTracingAddsWhatThePathTracerLeavesOut) {
  RenderDelegate delegate;
  glassBallScene(delegate);
  // The caustic: the middle of the image, about three times the image's mean, most of which is
  // the light tracer's. Six seeds gave 0.978-1.017 and 0.993-1.004.
  expectTheCausticTakenOver(splitMeans(delegate, 32768), 2.5);
}

TEST(Caustics, SunlightThroughTheBallIsLightTracedToo) {
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.removePrim("/bulb");
  // From the lamp's side: its light paths start beyond the scene, on the disk across the ball.
  addSun(delegate, -45);
  const SplitMeans means = splitMeans(delegate, 32768, 4096);
  // The middle of the image: the ball's shadow, where the light it focuses is nearly all.
  EXPECT_LT(means.causticLeftOut, 0.05 * means.causticPath);
  // Five seeds gave 0.966-1.030 on the caustic (the path tracer's estimate moving, the light
  // tracer's within 0.4 %) and 0.994-1.003 on the image's mean.
  expectTheSameImage(means);
  // Under a roof the sun lights nothing, through the ball or not: its light paths start above
  // the roof, not at the ball.
  addFloor(delegate, "/roof", 50, 8);
  const std::vector<float> roofed = render(delegate, "light", 8);
  EXPECT_EQ(*std::max_element(roofed.begin(), roofed.end()), 1.0f);  // alpha; no colour
  for (size_t i = 0; i < roofed.size(); i += 4) ASSERT_EQ(roofed[i], 0.0f) << i / 4;
}

TEST(Caustics, LampsTooDimForTheLightPathsChoiceStayWithThePathTracer) {
  // Beside a sun 10^5 times as bright, the bulb's share of the light paths (about 6e-6) is
  // near the resolution of the float that chooses a start: chosen with a probability off the
  // one its paths are weighed by, or never, its caustic would be lost (the path tracer leaves
  // the caustics of the lamps light tracing takes).
  RenderDelegate delegate;
  glassBallScene(delegate);
  addSun(delegate, -45);
  const auto takes = [&](LightType type) {
    const penumbra::Camera camera = test::syncedCamera(delegate, kSize);
    const PixelFilter filter;
    const CausticTracer tracer(delegate.scene(), camera, filter, RenderSettings().integrator);
    const std::vector<penumbra::Light>& lights = delegate.scene().lights().all();
    for (size_t index = 0; index < lights.size(); ++index)
      if (lights[index].type() == type) return tracer.takeover().takesLight(index);
    ADD_FAILURE() << "no light of type " << int(type);
    return false;
  };
  EXPECT_TRUE(takes(LightType::Sphere));
  EXPECT_TRUE(takes(LightType::Distant));
  delegate.light("/sun").setParam("intensity", 2e5f);
  EXPECT_FALSE(takes(LightType::Sphere));
  EXPECT_TRUE(takes(LightType::Distant));
}

TEST(Caustics, PlasticsSmoothLayerIsLightTracedAndItsDiffuseOnePathTraced) {
  // A red plastic ball in a sun level with the floor (its centre 2 degrees below the horizon,
  // so that it lights the floor little): on the floor beside the ball, the sunlight its smooth
  // layer reflects there is the light tracer's, the light its diffuse layer sends there the path
  // tracer's.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.removePrim("/bulb");
  addSun(delegate, 2);
  delegate.insertSprim("material", "/plastic");
  delegate.material("/plastic").setParam("diffuseColor", Vec3f(0.3f, 0.02f, 0.02f));
  delegate.material("/plastic").setParam("roughness", 0.4f);
  delegate.mesh("/ball").setMaterialId("/plastic");
  const SplitMeans means = splitMeans(delegate, 32768, 8192);
  // The light tracer's share there is some 13 %.
  EXPECT_GT(means.causticLeftOut, 0.5 * means.causticPath);
  EXPECT_LT(means.causticLeftOut, 0.95 * means.causticPath);
  // Six seeds gave 0.987-1.029 and 0.995-1.007.
  expectTheSameImage(means);
}

TEST(Caustics, DispersiveGlassIsLightTracedInEveryWavelength) {
  // Flint-like glass (Abbe number 20): the scene's paths carry wavelengths, and light paths
  // take the lamp's spectrum through the ball, each refraction keeping the hero wavelength.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.material("/glass").setParam("penumbra:abbeNumber", 20.0f);
  // Colours that spectra carry otherwise than RGB does: the light's and the floor's upsampled.
  delegate.light("/bulb").setParam("color", Vec3f(1.0f, 0.7f, 0.4f));
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.6f, 0.3f, 0.5f)}, Interpolation::Constant);
  // The path tracer's estimates through dispersive glass are the noisier: more samples.
  // Seven seeds gave 0.968-1.023 and 0.988-1.010. Leaving the light's or the floor's colour as
  // RGB gives 1.05 and 1.03.
  expectTheCausticTakenOver(splitMeans(delegate, 32768, 16384, 4096), 2.5);
}

TEST(Caustics, ShapedLampsAreLightTracedByTheirShapedLight) {
  // The bulb faces down, its light shaped into a soft 60-degree cone: the ball, 45 degrees off
  // its axis, receives the cone's falling edge.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.light("/bulb").setTransform(facingDown(-1.5, 2.5, 0));
  delegate.light("/bulb").setParam("shaping:cone:angle", 60.0f);
  delegate.light("/bulb").setParam("shaping:cone:softness", 0.5f);
  const SplitMeans means = splitMeans(delegate, 32768);
  ASSERT_GT(means.causticPath, 2 * means.allPath);
  // Seven seeds gave 0.990-1.016 and 0.992-1.011; the light's unshaped radiance, 2.09 and 1.39.
  expectTheSameImage(means);
}

TEST(Caustics, CylinderLampsAreLightTracedFromTheirSide) {
  // A tube in the bulb's place, its axis across the ball's view of it (along Z): light paths
  // start on its side, uniformly by area.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.removePrim("/bulb");
  delegate.insertSprim("cylinderLight", "/tube");
  delegate.light("/tube").setParam("radius", 0.1f);
  delegate.light("/tube").setParam("length", 0.6f);
  delegate.light("/tube").setParam("intensity", 30.0f);
  const double toZ[16] = {0, 0, 1, 0, 0, 1, 0, 0, -1, 0, 0, 0, -1.5, 2.5, 0, 1};
  delegate.light("/tube").setTransform(Transform::fromRowMajor(toZ));
  // Seven seeds gave 0.976-1.008 and 0.988-1.008; against 32,768 path-traced samples, two
  // seeds gave 1.000 and 1.005, 1.004 and 1.001.
  expectTheCausticTakenOver(splitMeans(delegate, 32768), 2);
}

TEST(Caustics, MeshLightsAreLightTracedFromTheirFront) {
  // A glowing panel facing down in the bulb's place: light paths start on its triangles,
  // uniformly by area, and the path tracer leaves the light its rays meet there, as that of
  // next-event estimation, to them.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.removePrim("/bulb");
  delegate.insertRprim("mesh", "/panel");
  Mesh& panel = delegate.mesh("/panel");
  panel.setPoints(
      {{-1.8f, 2.5f, -0.3f}, {-1.2f, 2.5f, -0.3f}, {-1.2f, 2.5f, 0.3f}, {-1.8f, 2.5f, 0.3f}});
  panel.setTopology({4}, {0, 1, 2, 3}, false, "none");  // counter-clockwise from below
  panel.setLight(true, {{"intensity", 60.0f}});
  panel.setVisible(true);
  // Seven seeds gave 0.982-1.015 and 0.988-1.006; against 32,768 path-traced samples, two
  // seeds gave 0.989 and 1.001, 0.995 and 1.001. With the path tracer adding the light its rays
  // meet on the panel all the same, 1.97 and 1.45.
  expectTheCausticTakenOver(splitMeans(delegate, 32768), 2);
}

using CausticsOfTexturedLamps = penumbra::test::ScratchDirectoryTest;

TEST_F(CausticsOfTexturedLamps, StartLightPathsByTheirTexture) {
  // A rect lamp facing down in the bulb's place, its texture a bright warm row over dim blue:
  // light paths start where the texture is bright and carry its colour there.
  ImageData texture{4, 4, {"R", "G", "B"}, {}, {}, {}};
  for (int i = 0; i < 16; ++i) {
    const bool bright = i < 4;
    texture.pixels.insert(texture.pixels.end(),
                          {bright ? 6.0f : 0.1f, bright ? 4.0f : 0.2f, bright ? 2.0f : 0.8f});
  }
  writeImage(path("panel.exr"), texture, {});
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.removePrim("/bulb");
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setParam("width", 0.6f);
  delegate.light("/panel").setParam("height", 0.6f);
  delegate.light("/panel").setParam("intensity", 20.0f);
  delegate.light("/panel").setParam("texture:file", path("panel.exr"));
  delegate.light("/panel").setTransform(facingDown(-1.5, 2.5, 0));
  // The path tracer's caustic, lit by the bright row alone, is the noisier: more samples.
  const SplitMeans means = splitMeans(delegate, 32768, 8192);
  ASSERT_GT(means.causticPath, 2 * means.allPath);
  // Seven seeds gave 0.969-1.026 and 0.992-1.009; the texture's colour left out, 0.65 and 0.82;
  // its density left out, 3.3 and 2.1.
  expectTheSameImage(means);
}

TEST(Caustics, LampsAmongTheCastersLightEveryWay) {
  // Light paths aim at the ball (a cone from the lamp) and at the ceiling, whose sphere holds
  // the lamp (every direction): a direction towards the ball may come from either, and weighs
  // both densities. Counting the ball's alone makes the caustic 1.7 times too bright.
  RenderDelegate delegate;
  glassBallScene(delegate, 0.1f, true);
  const SplitMeans means = splitMeans(delegate, 32768);
  ASSERT_GT(means.causticPath, 2.5 * means.allPath);
  // Six seeds gave 0.973-1.022 and 0.990-1.007.
  expectTheSameImage(means);
}

namespace {

/// The colour of a 20 x 16 render of the scene `build` makes, with `caustics` (0 path, 1 light,
/// 2 photons) on `threads` threads, its samples rendered in calls of `passes` samples.
template <typename Build>
std::vector<float> renderInPasses(Build build, int caustics, int threads,
                                  const std::vector<int>& passes) {
  RenderDelegate delegate;
  build(delegate);
  delegate.settings().set("caustics", caustics);
  delegate.settings().set("threads", threads);
  RenderPass pass(delegate, "/cam", 20, 16);
  for (int samples : passes) pass.execute(samples);
  return pass.aov("color");
}

}  // namespace

TEST(Caustics, LightTracedImagesAreBitIdenticalForAnyThreadCountAndSplit) {
  const auto scene = [](RenderDelegate& delegate) { glassBallScene(delegate); };
  const std::vector<float> one = renderInPasses(scene, 1, 1, {8});
  EXPECT_EQ(one, renderInPasses(scene, 1, 2, {8}));
  EXPECT_EQ(one, renderInPasses(scene, 1, 2, {2, 4, 2}));
  EXPECT_NE(one, renderInPasses(scene, 0, 2, {8}));
}

TEST(Caustics, WhatLightTracingCannotMatchIsLeftToThePathTracer) {
  // Clamping changes the path tracer's caustics; rough glass is no caster. Either way the light
  // tracer takes nothing, and the image is the path tracer's, bit for bit.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.settings().set("indirectClamp", 10);
  EXPECT_EQ(render(delegate, "light", 4), render(delegate, "path", 4));
  RenderDelegate frosted;
  glassBallScene(frosted, 0.6f);
  EXPECT_EQ(render(frosted, "light", 4), render(frosted, "path", 4));
  // The light tracer's rays would see the ball, which diffuse rays pass.
  RenderDelegate hidden;
  glassBallScene(hidden);
  PassVisibility noDiffuse;
  noDiffuse.diffuse = false;
  hidden.mesh("/ball").setPassVisibility(noDiffuse);
  EXPECT_EQ(render(hidden, "light", 4), render(hidden, "path", 4));
  // A lamp whose diffuse and specular multipliers differ lights plastic as the path tracer
  // weighs each lobe: its light through plastic stays with the path tracer.
  RenderDelegate weighed;
  glassBallScene(weighed);
  weighed.insertSprim("material", "/plastic");
  weighed.material("/plastic").setParam("roughness", 0.2f);
  weighed.mesh("/ball").setMaterialId("/plastic");
  weighed.light("/bulb").setParam("diffuse", 0.5f);
  EXPECT_EQ(render(weighed, "light", 4), render(weighed, "path", 4));
  weighed.light("/bulb").setParam("diffuse", 1.0f);
  EXPECT_NE(render(weighed, "light", 4), render(weighed, "path", 4));
  // Where it takes the lamp, it changes the image.
  RenderDelegate taken;
  glassBallScene(taken);
  EXPECT_NE(render(taken, "light", 4), render(taken, "path", 4));
}

namespace {

/// The glass ball's caustic on the floor (glassBallScene), seen through a clear glass pane of
/// index `ior` between the camera and the floor (just wider than the view, so that few light
/// paths aim at it): the light tracer cannot join its paths to the camera through the pane.
/// With `smallBulb`, a bulb a sixth as wide and as bright in all: a sharp caustic.
void causticBehindAPane(RenderDelegate& delegate, float ior, bool smallBulb = false) {
  glassBallScene(delegate);
  addFloor(delegate, "/pane", 0.3f, 3.5f);
  delegate.mesh("/pane").setTransform(translation(0.9, 0, 0));
  delegate.insertSprim("material", "/clear");
  delegate.material("/clear").setParam("opacity", 0.0f);
  delegate.material("/clear").setParam("ior", ior);
  delegate.material("/clear").setParam("roughness", 0.0f);
  delegate.mesh("/pane").setMaterialId("/clear");
  if (!smallBulb) return;
  delegate.light("/bulb").setParam("radius", 0.05f);
  delegate.light("/bulb").setParam("intensity", 720.0f);
}

/// The mean of renders with seeds 1 to `seeds`.
std::vector<float> seedsMean(RenderDelegate& delegate, const std::string& caustics, int samples,
                             int seeds) {
  std::vector<float> sum;
  for (int seed = 1; seed <= seeds; ++seed) {
    delegate.settings().set("seed", seed);
    const std::vector<float> image = render(delegate, caustics, samples);
    sum.resize(image.size());
    for (size_t i = 0; i < image.size(); ++i) sum[i] += image[i] / float(seeds);
  }
  delegate.settings().set("seed", 0);
  return sum;
}

/// The variance over seeds of each pixel of the caustic (rows and columns [8, 16)), averaged,
/// over the caustic's mean squared.
double causticRelativeVariance(RenderDelegate& delegate, const std::string& caustics, int samples) {
  constexpr int kSeeds = 4;
  std::vector<std::vector<float>> images;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    delegate.settings().set("seed", seed);
    images.push_back(render(delegate, caustics, samples));
  }
  delegate.settings().set("seed", 0);
  double variance = 0, mean = 0;
  for (int y = 8; y < 16; ++y)
    for (int x = 8; x < 16; ++x) {
      const size_t i = size_t(4 * (y * kSize + x));
      double sum = 0, squares = 0;
      for (const std::vector<float>& image : images) {
        sum += image[i];
        squares += double(image[i]) * image[i];
      }
      const double pixelMean = sum / kSeeds;
      variance += squares / kSeeds - pixelMean * pixelMean;
      mean += pixelMean;
    }
  mean /= 64;
  return variance / 64 / (mean * mean);
}

}  // namespace

TEST(CausticPhotons, CausticsSeenThroughGlassAreGatheredFromPhotons) {
  // A pane of index 1 bends and reflects nothing (the images without it agree to 1e-6: the
  // floor's direct light 0.0547734 and 0.0547735), but it is glass: behind it, the caustic is
  // gathered from photons, which the light tracer's image without it must match.
  RenderDelegate delegate;
  causticBehindAPane(delegate, 1.0f);
  RenderDelegate bare;
  glassBallScene(bare);
  const std::vector<float> light = seedsMean(bare, "light", 2048, 2);
  const std::vector<float> photons = seedsMean(delegate, "photons", 2048, 2);
  // The caustic, about three times the image's mean, keeps its light as its blur shrinks:
  // within 4 % there and 1.5 % over the image, as the light tracer's own tests. Five pairs of
  // seeds gave 0.982-0.999 and 0.994-1.000.
  ASSERT_GT(meanOver(light, 8, 16), 2.5 * meanOver(light, 0, kSize));
  EXPECT_NEAR(meanOver(photons, 8, 16) / meanOver(light, 8, 16), 1.0, 0.04);
  EXPECT_NEAR(meanOver(photons, 0, kSize) / meanOver(light, 0, kSize), 1.0, 0.015);
  // Without photons the path tracer finds it behind the pane (the light tracer's image is
  // another estimate of the same).
  EXPECT_NEAR(meanOver(seedsMean(delegate, "light", 512, 1), 0, kSize) / meanOver(light, 0, kSize),
              1.0, 0.03);
}

TEST(CausticPhotons, SharpCausticsBehindGlassLoseTheirFireflies) {
  // Behind real glass, a small bulb's caustic: the path tracer meets the bulb through the ball
  // rarely and brightly; photons gather it smoothly.
  RenderDelegate delegate;
  causticBehindAPane(delegate, 1.5f, true);
  const double photons = causticRelativeVariance(delegate, "photons", 64);
  const double light = causticRelativeVariance(delegate, "light", 64);
  // Measured: 0.075 against 17 to 34.
  EXPECT_LT(photons, 0.01 * light);
  EXPECT_LT(photons, 0.2);
}

TEST(CausticPhotons, ImagesAreBitIdenticalForAnyThreadCountAndSplit) {
  const auto scene = [](RenderDelegate& delegate) { causticBehindAPane(delegate, 1.5f); };
  // More samples than the pass holds photons for at once, split across that boundary.
  const std::vector<float> one = renderInPasses(scene, 2, 1, {20});
  EXPECT_EQ(one, renderInPasses(scene, 2, 2, {20}));
  EXPECT_EQ(one, renderInPasses(scene, 2, 2, {3, 9, 8}));
  EXPECT_NE(one, renderInPasses(scene, 1, 2, {20}));
}

TEST(CausticPhotons, RadiusShrinksAsProgressivePhotonMappingAsks) {
  // r_i² / r_{i-1}² = (i + α) / (i + 1), α = 2/3: the product of those steps, in index order...
  const auto radiusScale = [](uint32_t sampleIndex) {
    double product = 1;
    for (uint32_t index = 1; index <= sampleIndex; ++index)
      product *= (index + CausticPhotons::kAlpha) / (index + 1.0);
    return std::sqrt(product);
  };
  EXPECT_DOUBLE_EQ(radiusScale(0), 1.0);
  for (const uint32_t i : {1u, 2u, 10u, 1000u}) {
    const double ratio = std::pow(radiusScale(i), 2) / std::pow(radiusScale(i - 1), 2);
    EXPECT_NEAR(ratio, (i + 2.0 / 3.0) / (i + 1.0), 1e-9) << i;
  }
  // ...is what the photons held for each index are gathered within, bit for bit, also when the
  // indices held start over (a new pass).
  CausticPhotons held;
  for (const uint32_t first : {0u, 990u, 4u}) {
    held.hold(first, std::vector<CausticPhotons::Arrivals>(11));
    for (uint32_t i = first; i < first + 11; ++i)
      EXPECT_EQ(held.radius(i, 1.0f), CausticPhotons::kFootprints * float(radiusScale(i))) << i;
  }
  // A photon counts once however the cells around it share buckets, and none beyond the
  // radius does.
  std::vector<Photon> photons;
  for (int i = 0; i < 200; ++i)
    photons.push_back(
        {Vec3f(0.01f * float(i) - 1, 0, 0), Vec3f(0, 1, 0), Vec3f(0, 1, 0), Vec3f(1.0f), 1});
  const PhotonGrid grid(photons, 0.05f);
  int within = 0;
  grid.forEachWithin(Vec3f(0, 0, 0), 0.255f, [&](const Photon& photon) {
    EXPECT_LE(std::abs(photon.position.x), 0.255f);
    ++within;
  });
  EXPECT_EQ(within, 51);
}

TEST(Caustics, LightPathsRaysCountOnceAcrossTheImagesRegions) {
  RenderDelegate delegate;
  glassBallScene(delegate);
  const penumbra::Camera camera = test::syncedCamera(delegate, kSize);
  const PixelFilter filter;
  const RenderSettings settings;
  const CausticTracer tracer(delegate.scene(), camera, filter, settings.integrator);
  Film whole(kSize, kSize);
  ASSERT_TRUE(tracer.trace(0, 4, whole, 0));
  // 58 light paths a sample index; those that leave the bulb (most: a point drawn on its far
  // side sees no ball) trace a ray to their first hit, at most one more to each caster, and one
  // back from the camera.
  const uint64_t paths = whole.lightPaths();
  ASSERT_EQ(paths, 4u * 58u);
  EXPECT_GE(whole.raysTraced(), paths / 2);
  EXPECT_LE(whole.raysTraced(), paths * uint64_t(tracer.takeover().maxCasters() + 2));
  // A farm band counts the rays of the light paths that are its own: the bands add up to the
  // whole image's count.
  Film top(PixelRect{0, 0, kSize, 7}), bottom(PixelRect{0, 7, kSize, kSize - 7});
  ASSERT_TRUE(tracer.trace(0, 4, top, 0));
  ASSERT_TRUE(tracer.trace(0, 4, bottom, 0));
  EXPECT_GT(top.raysTraced(), 0u);
  EXPECT_EQ(top.raysTraced() + bottom.raysTraced(), whole.raysTraced());
}

TEST(Caustics, AdaptiveSamplingWeighsTheLightTracedPartsNoise) {
  // Camera samples that agree exactly: only the light-traced part can keep a pixel active.
  const auto filmWithSplats = [](bool noisy) {
    Film film(3, 3);
    CameraSample sample;
    sample.radiance = Vec3f(1.0f);
    sample.alpha = 1;
    for (uint32_t index = 0; index < 16; ++index) {
      for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) film.addSample(x, y, index, sample);
      // The centre pixel's light: 1 a sample index on average, either every index or in
      // the even ones alone.
      if (!noisy || index % 2 == 0) film.addSplat(1, 1, index, Vec3f(noisy ? 20.0f : 10.0f));
      film.addLightPaths(10, index);
    }
    film.updateConvergence(0.05f);
    return film;
  };
  const Film steady = filmWithSplats(false);
  EXPECT_EQ(steady.activePixels(), 0u);
  EXPECT_EQ(steady.resolveColor()[4 * 4], 2.0f);
  // A stopped pixel takes no more light paths: its value is that of the samples it took.
  Film stopped = filmWithSplats(false);
  stopped.addSplat(1, 1, 16, Vec3f(100.0f));
  stopped.addLightPaths(10, 16);
  EXPECT_EQ(stopped.resolveColor(), steady.resolveColor());
  EXPECT_EQ(stopped.lightPaths(), 170u);  // what the image traced
  const Film noisy = filmWithSplats(true);
  EXPECT_EQ(noisy.resolveColor()[4 * 4], 2.0f);  // the same mean
  // The centre's light-traced halves are 2 and 0: e = 1 against a value of 2, a relative error
  // of 0.5 at n = 16 where the threshold asks 0.05, averaged over each 3×3 neighbourhood, which
  // every pixel's holds.
  EXPECT_EQ(noisy.activePixels(), 9u);
}

TEST(Caustics, AdaptiveSamplingSpendsSamplesWhereTheLightTracedCausticIsNoisy) {
  // A sharp caustic (a small bulb focused by the ball) that the light tracer takes: the path
  // tracer's samples there are smooth, and only the light-traced part's noise can tell adaptive
  // sampling that the caustic is not done. Before it was measured, caustic pixels stopped at
  // the first tests (8.75 samples on average against 14.7 elsewhere, seeds 1 and 2) with an
  // rRMSE of 0.13 and 0.22 where the threshold allows them 0.037.
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.light("/bulb").setParam("radius", 0.05f);
  delegate.light("/bulb").setParam("intensity", 720.0f);
  delegate.settings().set("seed", 9);
  const std::vector<float> reference = render(delegate, "light", 4096);
  constexpr double kThreshold = 0.05;
  delegate.settings().set("adaptiveThreshold", kThreshold);
  delegate.settings().set("adaptiveMinSamples", 8);
  const auto inCaustic = [](int x, int y) { return x >= 8 && x < 16 && y >= 8 && y < 16; };
  for (int seed = 1; seed <= 2; ++seed) {
    delegate.settings().set("seed", seed);
    RenderPass pass(delegate, "/cam", kSize, kSize);
    pass.execute(256);
    const std::vector<float> image = pass.aov("color");
    const std::vector<float> samples = pass.aov("sampleCount");
    double causticSamples = 0, otherSamples = 0, causticError = 0;
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        const size_t pixel = size_t(y * kSize + x);
        if (!inCaustic(x, y)) {
          otherSamples += samples[pixel];
          continue;
        }
        causticSamples += samples[pixel];
        for (size_t channel = 4 * pixel; channel < 4 * pixel + 3; ++channel) {
          const double error = image[channel] - reference[channel];
          causticError += error * error / (reference[channel] * reference[channel] + 0.01);
        }
      }
    causticSamples /= 64;
    otherSamples /= kSize * kSize - 64;
    EXPECT_GT(causticSamples, 2 * otherSamples) << "seed " << seed;
    // A pixel stops once its relative error is below threshold·√(n/16) (Film::updateConvergence).
    const double allowed = kThreshold * std::sqrt(causticSamples / 16);
    EXPECT_LT(std::sqrt(causticError / (3 * 64)), 2 * allowed) << "seed " << seed;
  }
}

TEST(Caustics, AdaptiveFarmBandsResolveAsTheWholeImage) {
  // A tall image whose floor the metal ceiling's light paths reach all over: bands far from the
  // caustic stop early while the whole image goes on. Before a pixel counted the light paths
  // of its own sample indices alone, those bands resolved the light paths traced so far, not
  // the whole image's (3,201 floats of 9,216 differed).
  constexpr int kTall = 96, kBand = 8, kSamples = 256;
  RenderDelegate delegate;
  glassBallScene(delegate, 0.1f, true);
  delegate.settings().set("caustics", 1);
  delegate.settings().set("adaptiveThreshold", 0.3);
  delegate.settings().set("adaptiveMinSamples", 4);
  RenderPass whole(delegate, "/cam", kSize, kTall);
  whole.execute(kSamples);
  const std::vector<float> image = whole.aov("color");
  const int margin = RenderPass::adaptiveSamplingReach(kSamples, 4);
  uint64_t bandsRays = 0;
  for (int band = 0; band < kTall / kBand; ++band) {
    RenderPass part(delegate, "/cam", kSize, kTall, PixelRect{0, band * kBand, kSize, kBand},
                    margin);
    part.execute(kSamples);
    const auto first = image.begin() + band * kBand * kSize * 4;
    EXPECT_EQ(part.aov("color"), std::vector<float>(first, first + kBand * kSize * 4))
        << "band " << band;
    bandsRays += part.raysTraced();
  }
  // Each pixel counts the rays of its own light paths too (Film::addRays).
  EXPECT_EQ(bandsRays, whole.raysTraced());
}

TEST(Caustics, TheVarianceAovHoldsTheLightTracedPartsVariance) {
  // Where the light tracer takes the caustic over, the path tracer's samples there are smooth:
  // the variance of the pixel's mean is the light-traced part's. The AOV's estimate, averaged
  // over the caustic and the seeds, against the variance of the colour between the seeds: 1.23
  // here (0.73–1.11 with seeds 9–40 in fours of eight), 0.00008 before it counted the
  // light-traced part.
  constexpr int kSeeds = 8, kSamples = 16;
  RenderDelegate delegate;
  glassBallScene(delegate);
  delegate.settings().set("caustics", 1);
  std::vector<std::vector<float>> colors;
  double estimated = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    delegate.settings().set("seed", seed);
    RenderPass pass(delegate, "/cam", kSize, kSize);
    pass.setAovs({"variance"});
    pass.execute(kSamples);
    colors.push_back(pass.aov("color"));
    const std::vector<float> variance = pass.aov("variance");
    for (int y = 8; y < 16; ++y)
      for (int x = 8; x < 16; ++x) estimated += variance[size_t(3 * (y * kSize + x))];
  }
  double between = 0;  // the red channel's variance between the seeds, summed over the pixels
  for (int y = 8; y < 16; ++y)
    for (int x = 8; x < 16; ++x) {
      double sum = 0, squares = 0;
      for (const std::vector<float>& color : colors) {
        const double red = color[size_t(4 * (y * kSize + x))];
        sum += red;
        squares += red * red;
      }
      between += (squares - sum * sum / kSeeds) / (kSeeds - 1);
    }
  EXPECT_NEAR(estimated / kSeeds / between, 1.0, 0.35);
}
