// UsdPreviewSurface through the whole renderer: white furnaces and glossy blur.
#include <gtest/gtest.h>

#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"

using namespace penumbra;
using namespace penumbra::plugin;

namespace {

/// A closed UV sphere (shared seam and pole vertices, so every edge has two faces).
void addSphere(RenderDelegate& delegate, const PrimId& id, float radius, int stacks = 32,
               int slices = 64) {
  std::vector<Vec3f> points{{0, radius, 0}};
  for (int i = 1; i < stacks; ++i) {
    const float theta = kPi * float(i) / float(stacks);
    for (int j = 0; j < slices; ++j) {
      const float phi = 2 * kPi * float(j) / float(slices);
      points.push_back({radius * std::sin(theta) * std::cos(phi), radius * std::cos(theta),
                        -radius * std::sin(theta) * std::sin(phi)});
    }
  }
  points.push_back({0, -radius, 0});
  const int bottom = int(points.size()) - 1;
  const auto ring = [&](int i, int j) { return 1 + (i - 1) * slices + (j % slices); };
  std::vector<int> counts, indices;
  for (int j = 0; j < slices; ++j) {
    counts.push_back(3);
    indices.insert(indices.end(), {0, ring(1, j), ring(1, j + 1)});
    counts.push_back(3);
    indices.insert(indices.end(), {bottom, ring(stacks - 1, j + 1), ring(stacks - 1, j)});
  }
  for (int i = 1; i + 1 < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      counts.push_back(4);
      indices.insert(indices.end(),
                     {ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
  delegate.insertRprim("mesh", id);
  delegate.mesh(id).setPoints(std::move(points));
  delegate.mesh(id).setTopology(std::move(counts), std::move(indices), false, "none");
}

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

double furnace(const std::map<std::string, ParamValue>& material, bool sphere) {
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
  return sum / double(rgba.size() / 4);
}

}  // namespace

TEST(Materials, WhiteFurnaceLambertian) {
  EXPECT_NEAR(furnace({{"diffuseColor", Vec3f(1.0f)}}, false), 1.0, 0.01);
}

TEST(Materials, WhiteFurnaceSmoothMetal) {
  EXPECT_NEAR(
      furnace({{"diffuseColor", Vec3f(1.0f)}, {"metallic", 1.0f}, {"roughness", 0.0f}}, false), 1.0,
      0.01);
}

TEST(Materials, WhiteFurnaceRoughMetalLosesAtMostThreePercent) {
  for (float roughness : {0.5f, 1.0f}) {
    const double value = furnace(
        {{"diffuseColor", Vec3f(1.0f)}, {"metallic", 1.0f}, {"roughness", roughness}}, false);
    EXPECT_GE(value, 0.97) << "roughness " << roughness;
    EXPECT_LE(value, 1.01) << "roughness " << roughness;
  }
}

TEST(Materials, WhiteFurnaceGlassSphere) {
  for (float roughness : {0.0f, 0.3f}) {
    const double value =
        furnace({{"opacity", 0.0f}, {"ior", 1.5f}, {"roughness", roughness}}, true);
    EXPECT_NEAR(value, 1.0, 0.02) << "roughness " << roughness;
  }
}
