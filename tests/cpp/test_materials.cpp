// UsdPreviewSurface through the whole renderer: white furnaces and glossy blur.
#include <gtest/gtest.h>

#include <cmath>
#include <type_traits>

#include "penumbra/material_inputs.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"

using namespace penumbra;
using namespace penumbra::plugin;
using penumbra::test::addSphere;

namespace {

void addFloor(RenderDelegate& delegate, const PrimId& id) {
  delegate.insertRprim("mesh", id);
  delegate.mesh(id).setPoints({{-50, 0, -50}, {-50, 0, 50}, {50, 0, 50}, {50, 0, -50}});
  delegate.mesh(id).setTopology({4}, {0, 1, 2, 3}, false, "none");
}

/// Camera at height 3 looking straight down with a field of view narrow enough to see only the
/// middle of a unit sphere at the origin.
void addCameraAbove(RenderDelegate& delegate) {
  delegate.insertSprim("camera", "/cam");
  CameraParams params;
  params.focalLength = 50;
  params.horizontalAperture = params.verticalAperture = 10;
  delegate.camera("/cam").setParams(params);
  const double down[16] = {1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 3, 0, 1};
  delegate.camera("/cam").setTransform(Transform::fromRowMajor(down));
}

/// Mean radiance of a white object in a uniform dome of radiance 1, recorded as `label`.
double furnace(const std::map<std::string, ParamValue>& material, bool sphere,
               const std::string& label) {
  RenderDelegate delegate;
  if (sphere)
    addSphere(delegate, "/object", 1);
  else
    addFloor(delegate, "/object");
  delegate.insertSprim("material", "/white");
  for (const auto& [name, value] : material) delegate.material("/white").setParam(name, value);
  delegate.mesh("/object").setMaterialId("/white");
  delegate.insertSprim("domeLight", "/furnace");
  addCameraAbove(delegate);
  for (const char* key :
       {"maxPathDepth", "maxDiffuseDepth", "maxGlossyDepth", "maxTransmissionDepth"})
    delegate.settings().set(key, 64);
  RenderPass pass(delegate, "/cam", 8, 8);
  pass.execute(512);
  const std::vector<float> rgba = pass.aov("color");
  double sum = 0;
  for (size_t i = 0; i < rgba.size(); i += 4) sum += rgba[i + 1];
  const double value = sum / double(rgba.size() / 4);
  ::testing::Test::RecordProperty(label, std::to_string(value));  // in the test's XML output
  return value;
}

}  // namespace

TEST(Materials, WhiteFurnaceLambertian) {
  EXPECT_NEAR(furnace({{"diffuseColor", Vec3f(1.0f)}}, false, "lambertian"), 1.0, 0.01);
}

TEST(Materials, WhiteFurnaceSmoothMetal) {
  EXPECT_NEAR(furnace({{"diffuseColor", Vec3f(1.0f)}, {"metallic", 1.0f}, {"roughness", 0.0f}},
                      false, "smoothMetal"),
              1.0, 0.01);
}

TEST(Materials, WhiteFurnaceRoughMetalLosesAtMostThreePercent) {
  for (float roughness : {0.5f, 1.0f}) {
    const double value =
        furnace({{"diffuseColor", Vec3f(1.0f)}, {"metallic", 1.0f}, {"roughness", roughness}},
                false, "roughMetal" + std::to_string(roughness));
    EXPECT_GE(value, 0.97) << "roughness " << roughness;
    EXPECT_LE(value, 1.01) << "roughness " << roughness;
  }
}

TEST(Materials, WhiteFurnaceGlassSphere) {
  for (float roughness : {0.0f, 0.3f}) {
    const double value = furnace({{"opacity", 0.0f}, {"ior", 1.5f}, {"roughness", roughness}}, true,
                                 "glassSphere" + std::to_string(roughness));
    EXPECT_NEAR(value, 1.0, 0.02) << "roughness " << roughness;
  }
}

namespace {

/// A glossy plastic floor under a rect light and a dome, from above, with one of the three
/// direct-lighting estimators; returns the green channel per pixel.
std::vector<double> directLightingImage(int mode) {
  RenderDelegate delegate;
  addFloor(delegate, "/floor");
  delegate.insertSprim("material", "/plastic");
  delegate.material("/plastic").setParam("diffuseColor", Vec3f(0.4f, 0.5f, 0.6f));
  delegate.material("/plastic").setParam("roughness", 0.3f);
  delegate.mesh("/floor").setMaterialId("/plastic");
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setParam("intensity", 4.0f);
  const double facingDown[16] = {1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0.5, 1.5, 0, 1};
  delegate.light("/panel").setTransform(Transform::fromRowMajor(facingDown));
  delegate.insertSprim("domeLight", "/sky");
  delegate.light("/sky").setParam("intensity", 0.3f);
  addCameraAbove(delegate);
  delegate.camera("/cam").setParams([] {
    CameraParams params;
    params.focalLength = 10;
    params.horizontalAperture = params.verticalAperture = 20;
    return params;
  }());
  delegate.settings().set("maxPathDepth", 1);
  delegate.settings().set("directLighting", mode);
  RenderPass pass(delegate, "/cam", 24, 24);
  pass.execute(64);
  const std::vector<float> rgba = pass.aov("color");
  std::vector<double> green;
  for (size_t i = 1; i < rgba.size(); i += 4) green.push_back(rgba[i]);
  return green;
}

/// Mean of a − b over pixels and its standard error (pixels are independent estimates).
std::pair<double, double> meanDifference(const std::vector<double>& a,
                                         const std::vector<double>& b) {
  double sum = 0, sumSquares = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = a[i] - b[i];
    sum += d;
    sumSquares += d * d;
  }
  const double n = double(a.size()), mean = sum / n;
  return {mean, std::sqrt((sumSquares / n - mean * mean) / (n - 1))};
}

}  // namespace

TEST(Materials, MisLightOnlyAndBsdfOnlyAgreeInTheMean) {
  const std::vector<double> mis = directLightingImage(0), light = directLightingImage(1),
                            bsdf = directLightingImage(2);
  double total = 0;
  for (double v : mis) total += v;
  ASSERT_GT(total / double(mis.size()), 0.05);
  for (const auto& other : {light, bsdf}) {
    const auto [mean, standardError] = meanDifference(mis, other);
    EXPECT_LT(std::fabs(mean), 3 * standardError + 1e-6) << "mean difference " << mean;
  }
}

TEST(Materials, GlossyReflectionsBlurMoreWithRoughness) {
  const auto highlightSpread = [](float roughness) {
    RenderDelegate delegate;
    addFloor(delegate, "/mirror");
    delegate.insertSprim("material", "/metal");
    delegate.material("/metal").setParam("metallic", 1.0f);
    delegate.material("/metal").setParam("diffuseColor", Vec3f(1.0f));
    delegate.material("/metal").setParam("roughness", roughness);
    delegate.mesh("/mirror").setMaterialId("/metal");
    delegate.insertSprim("sphereLight", "/bulb");
    delegate.light("/bulb").setParam("radius", 0.05f);
    delegate.light("/bulb").setParam("intensity", 100.0f);
    const double above[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 5, 0, 1};
    delegate.light("/bulb").setTransform(Transform::fromRowMajor(above));
    addCameraAbove(delegate);
    delegate.camera("/cam").setParams([] {
      CameraParams params;
      params.focalLength = 10;
      params.horizontalAperture = params.verticalAperture = 10;
      return params;
    }());
    delegate.settings().set("maxPathDepth", 1);
    const int size = 48;
    RenderPass pass(delegate, "/cam", size, size);
    pass.execute(32);
    const std::vector<float> rgba = pass.aov("color");
    // Intensity-weighted RMS distance of the highlight from the image centre, in pixels.
    double weight = 0, moment = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double value = rgba[size_t(4 * (y * size + x) + 1)];
        const double dx = x + 0.5 - size / 2.0, dy = y + 0.5 - size / 2.0;
        weight += value;
        moment += value * (dx * dx + dy * dy);
      }
    return std::sqrt(moment / weight);
  };
  const double sharp = highlightSpread(0.1f), medium = highlightSpread(0.25f),
               rough = highlightSpread(0.5f);
  EXPECT_LT(sharp * 1.3, medium);
  EXPECT_LT(medium * 1.3, rough);
}

namespace {

/// Horizontal centroids (in pixels) of the red and blue light of a white slit seen through a
/// glass sphere of Abbe number `abbe` (0: no dispersion).
std::pair<double, double> slitCentroids(float abbe) {
  RenderDelegate delegate;
  addSphere(delegate, "/lens", 1);
  delegate.insertSprim("material", "/glass");
  delegate.material("/glass").setParam("opacity", 0.0f);
  delegate.material("/glass").setParam("ior", 1.6f);
  delegate.material("/glass").setParam("roughness", 0.0f);
  delegate.material("/glass").setParam("penumbra:abbeNumber", abbe);
  delegate.mesh("/lens").setMaterialId("/glass");
  // A white slit behind the sphere, off its axis, hidden from the camera except through it.
  delegate.insertRprim("mesh", "/slit");
  delegate.mesh("/slit").setPoints(
      {{0.55f, -0.3f, -3}, {0.6f, -0.3f, -3}, {0.6f, 0.3f, -3}, {0.55f, 0.3f, -3}});
  delegate.mesh("/slit").setTopology({4}, {0, 1, 2, 3}, false, "none");
  delegate.mesh("/slit").setDoubleSided(true);
  delegate.insertSprim("material", "/white");
  delegate.material("/white").setParam("emissiveColor", Vec3f(5.0f));
  delegate.material("/white").setParam("diffuseColor", Vec3f(0.0f));
  delegate.mesh("/slit").setMaterialId("/white");
  delegate.insertSprim("camera", "/cam");
  CameraParams params;
  params.focalLength = 50;
  params.horizontalAperture = params.verticalAperture = 20;
  delegate.camera("/cam").setParams(params);
  const double back[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1};
  delegate.camera("/cam").setTransform(Transform::fromRowMajor(back));
  for (const char* key : {"maxPathDepth", "maxTransmissionDepth"}) delegate.settings().set(key, 16);
  const int size = 64;
  RenderPass pass(delegate, "/cam", size, size);
  pass.execute(256);
  const std::vector<float> rgba = pass.aov("color");
  double red = 0, redX = 0, blue = 0, blueX = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const float* p = &rgba[size_t(4 * (y * size + x))];
      red += p[0];
      redX += p[0] * (x + 0.5);
      blue += p[2];
      blueX += p[2] * (x + 0.5);
    }
  EXPECT_GT(red, 0.1);
  EXPECT_GT(blue, 0.1);
  return {redX / red, blueX / blue};
}

}  // namespace

TEST(Materials, DispersionSplitsAWhiteSlitIntoColours) {
  const auto [red, blue] = slitCentroids(20);
  RecordProperty("separationPixelsAbbe20", std::to_string(std::fabs(red - blue)));
  EXPECT_GT(std::fabs(red - blue), 1.0) << "red " << red << " blue " << blue;
  const auto [redPlain, bluePlain] = slitCentroids(0);
  RecordProperty("separationPixelsAbbe0", std::to_string(std::fabs(redPlain - bluePlain)));
  EXPECT_LT(std::fabs(redPlain - bluePlain), 0.3) << "red " << redPlain << " blue " << bluePlain;
}

TEST(Materials, EveryTableInputRoundTripsThroughSetParamAndConnect) {
  RenderDelegate delegate;
  delegate.insertSprim("material", "/m");
  plugin::Material& material = delegate.material("/m");
  for (const MaterialInputInfo& info : materialInputs()) {
    const std::string name(info.name);
    SCOPED_TRACE(name);
    EXPECT_EQ(findMaterialInput(name), &info);
    std::visit(
        [&](auto member) {
          using Member = decltype(member);
          if constexpr (std::is_same_v<Member, std::monostate>) {
            EXPECT_EQ(info.kind, MaterialInputKind::Vector);  // the normal: connections only
            EXPECT_THROW(material.setParam(name, Vec3f(0, 0, 1)), std::invalid_argument);
          } else if constexpr (std::is_same_v<Member, float MaterialParams::*>) {
            EXPECT_EQ(info.kind, MaterialInputKind::Float);
            material.setParam(name, 0.375f);
            EXPECT_EQ(material.params().*member, 0.375f);
            if (info.mustBeFinite) {
              EXPECT_THROW(material.setParam(name, NAN), std::invalid_argument);
            }
          } else if constexpr (std::is_same_v<Member, Vec3f MaterialParams::*>) {
            EXPECT_EQ(info.kind, MaterialInputKind::Vector);
            material.setParam(name, Vec3f(0.25f, 0.5f, 0.75f));
            const Vec3f value = material.params().*member;
            EXPECT_EQ(value.x, 0.25f);
            EXPECT_EQ(value.y, 0.5f);
            EXPECT_EQ(value.z, 0.75f);
            if (info.mustBeFinite) {
              EXPECT_THROW(material.setParam(name, Vec3f(0, INFINITY, 0)), std::invalid_argument);
            }
          } else if constexpr (std::is_same_v<Member, bool MaterialParams::*> ||
                               std::is_same_v<Member, std::optional<bool> MaterialParams::*>) {
            EXPECT_EQ(info.kind, MaterialInputKind::Bool);
            material.setParam(name, true);
            EXPECT_TRUE(bool(material.params().*member));
          } else {
            static_assert(std::is_same_v<Member, AnisotropyModel MaterialParams::*>);
            EXPECT_EQ(info.kind, MaterialInputKind::Token);
            material.setParam(name, std::string("standardSurface"));
            EXPECT_EQ(material.params().*member, AnisotropyModel::StandardSurface);
          }
        },
        info.member);
    InputSource source;
    source.primvar = "st";
    if (info.connectable) {
      material.connect(name, source);
      EXPECT_EQ(material.connections().back().first, *info.connectable);
      EXPECT_EQ(&materialInputInfo(*info.connectable), &info);
    } else {
      EXPECT_THROW(material.connect(name, source), std::invalid_argument);
    }
  }
  EXPECT_EQ(findMaterialInput("displacement"), nullptr);
}

TEST(Materials, EveryConnectableInputIsInTheTableOnce) {
  for (size_t i = 0; i <= size_t(MaterialInput::Normal); ++i) {
    const auto input = MaterialInput(i);
    const MaterialInputInfo& info = materialInputInfo(input);
    EXPECT_EQ(info.connectable, input) << info.name;
    EXPECT_EQ(isVectorInput(input), info.kind == MaterialInputKind::Vector) << info.name;
  }
}

TEST(Materials, TableSetsUpTheBsdfOnceOnlyForMaterialsThatDoNotVary) {
  MaterialTable table("");
  penumbra::Material plastic;
  plastic.constants.diffuseColor = Vec3f(0.8f, 0.2f, 0.1f);
  plastic.constants.roughness = 0.4f;
  plastic.constants.opacity = 0.5f;
  table.replace(0, plastic);
  const Vec3f up(0, 0, 1), wo = normalize(Vec3f(0.2f, 0.1f, 0.9f));
  const Vec3f wi = normalize(Vec3f(-0.3f, 0.2f, 0.8f)), through = normalize(Vec3f(-0.3f, 0, -0.9f));
  for (const DielectricKind kind : {DielectricKind::Solid, DielectricKind::ThinSheet}) {
    const PreviewSurfaceBsdf* prototype = table.bsdfPrototype(0, kind);
    ASSERT_NE(prototype, nullptr);
    const PreviewSurfaceBsdf direct(plastic.constants, up, plastic.constants.ior, kind);
    for (const Vec3f& w : {wi, through}) {
      EXPECT_EQ(prototype->evaluate(wo, w).y, direct.evaluate(wo, w).y);
      EXPECT_EQ(prototype->pdf(wo, w), direct.pdf(wo, w));
    }
  }
  // Solid and sheet transmit differently: each kind has its own.
  EXPECT_NE(table.bsdfPrototype(0, DielectricKind::Solid)->evaluate(wo, through).y,
            table.bsdfPrototype(0, DielectricKind::ThinSheet)->evaluate(wo, through).y);
  // As shading sees the constants: with a threshold, what is present is opaque.
  penumbra::Material cutOut = plastic;
  cutOut.constants.opacityThreshold = 0.2f;
  table.replace(0, cutOut);
  EXPECT_FALSE(table.bsdfPrototype(0, DielectricKind::Solid)->hasTransmission());
  // What depends on the hit has none, and a replaced material follows (live edits).
  penumbra::Material anisotropic = plastic;
  anisotropic.constants.anisotropy = 0.5f;
  penumbra::Material hair = plastic;
  hair.constants.hair = true;
  penumbra::Material textured = plastic;
  InputConnection fromPrimvar;
  fromPrimvar.input = MaterialInput::DiffuseColor;
  fromPrimvar.primvar = PrimvarName("tint");
  textured.connections.push_back(fromPrimvar);
  for (const penumbra::Material& perHit : {anisotropic, hair, textured}) {
    table.replace(0, perHit);
    EXPECT_EQ(table.bsdfPrototype(0, DielectricKind::Solid), nullptr);
    EXPECT_EQ(table.bsdfPrototype(0, DielectricKind::ThinSheet), nullptr);
  }
  table.replace(0, plastic);
  EXPECT_NE(table.bsdfPrototype(0, DielectricKind::Solid), nullptr);
  EXPECT_EQ(table.bsdfPrototype(MaterialTable::kNoMaterial, DielectricKind::Solid), nullptr);
  EXPECT_EQ(table.bsdfPrototype(1, DielectricKind::Solid), nullptr);
}
