// Materials and lights sync themselves (docs/architecture.md): an edit of one builds that sprim's
// renderer object alone, material indices stay fixed from insertion to removal, the light list
// is rebuilt (from the lights already built) only when lights join or leave it, problems are
// reported once per change, and the image after edits is bit-identical to that of a fresh
// delegate given the edited scene.
#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>
#include <tuple>
#include <variant>
#include <vector>

#include "penumbra/image_io.h"
#include "penumbra/plugin/light_types.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "scene_builders.h"
#include "scratch_directory.h"
#include "transforms.h"

using namespace penumbra;
using namespace penumbra::plugin;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::facingDown;
using penumbra::test::translation;

namespace {

/// What the scene holds; each test edits a live delegate from one state to another and
/// compares it with a fresh delegate given the second.
struct SceneSpec {
  Vec3f diffuseA{0.8f, 0.2f, 0.2f};
  float opacityA = 1;             // below 0.5 it cuts "/left" out
  bool opacityTexturedA = false;  // the checker's red: cut out where that is below 0.5
  bool materialA = true;          // "/looks/a", bound to "/left"
  bool materialC = false;
  float panelIntensity = 2;
  bool panelVisible = true;
  bool bulb = false;        // a sphere light "/bulb", sorting before the others
  bool rightEmits = false;  // "/right" is a mesh light
};

class SprimSync : public penumbra::test::ScratchDirectoryTest {
 protected:
  void SetUp() override {
    ScratchDirectoryTest::SetUp();
    // A horizontal gradient for the dome (lat-long) and a checker for "/looks/b".
    ImageData sky{8, 4, {"R", "G", "B"}, {}, {}, {}};
    for (int i = 0; i < 32; ++i)
      sky.pixels.insert(sky.pixels.end(), {0.1f * float(i % 8), 0.5f, 0.2f});
    writeImage(path("sky.exr"), sky, {});
    ImageData checker{2,
                      2,
                      {"R", "G", "B"},
                      {0.9f, 0.1f, 0.1f, 0.1f, 0.9f, 0.1f, 0.1f, 0.1f, 0.9f, 0.9f, 0.9f, 0.9f},
                      {},
                      {}};
    writeImage(path("checker.exr"), checker, {});
  }

  void buildScene(RenderDelegate& delegate, const SceneSpec& spec) const {
    addCamera(delegate, facingDown(0, 5, 0));
    CameraParams wide;
    wide.focalLength = 10;
    wide.horizontalAperture = wide.verticalAperture = 10;
    delegate.camera("/cam").setParams(wide);
    for (const auto& [id, x] : {std::pair{"/left", -1.0}, std::pair{"/right", 1.0}}) {
      addFloor(delegate, id, 1);
      delegate.mesh(id).setTransform(translation(x, 0, 0));
      delegate.mesh(id).setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
    }
    delegate.mesh("/left").setMaterialId("/looks/a");
    delegate.mesh("/right").setMaterialId("/looks/b");
    if (spec.materialA) {
      delegate.insertSprim("material", "/looks/a");
      setMaterialA(delegate.material("/looks/a"), spec);
    }
    delegate.insertSprim("material", "/looks/b");
    InputSource checker;
    checker.texture = TextureNode{path("checker.exr"), {}, {}};
    delegate.material("/looks/b").connect("diffuseColor", checker);
    if (spec.materialC) insertMaterialC(delegate);
    // Bound to nothing: its missing texture is reported when it syncs.
    delegate.insertSprim("material", "/looks/missing");
    InputSource missing;
    missing.texture = TextureNode{path("nowhere.exr"), {}, {}};
    delegate.material("/looks/missing").connect("diffuseColor", missing);

    delegate.insertSprim("rectLight", "/panel");
    delegate.light("/panel").setParam("intensity", spec.panelIntensity);
    delegate.light("/panel").setTransform(facingDown(0.5, 2, 0));
    delegate.light("/panel").setVisible(spec.panelVisible);
    delegate.insertSprim("domeLight", "/sky");
    delegate.light("/sky").setParam("intensity", 0.5f);
    delegate.light("/sky").setParam("texture:file", path("sky.exr"));
    delegate.insertSprim("rectLight", "/broken");  // zero area: skipped with a warning
    delegate.light("/broken").setParam("width", 0.0f);
    if (spec.bulb) insertBulb(delegate);
    if (spec.rightEmits) delegate.mesh("/right").setLight(true, {{"intensity", 3.0f}});
  }

  void setMaterialA(plugin::Material& material, const SceneSpec& spec) const {
    material.resetParams();
    material.setParam("diffuseColor", spec.diffuseA);
    material.setParam("opacityThreshold", 0.5f);
    material.setParam("opacity", spec.opacityA);
    if (spec.opacityTexturedA) {
      InputSource red;
      red.texture = TextureNode{path("checker.exr"), {}, {}};
      red.texture->reader.coordinates.fallback = {0.25f, 0.75f};  // the red texel
      red.output = "r";
      material.connect("opacity", red);
    }
  }
  /// Bright and bound to nothing: a mesh given its index by mistake would show it.
  static void insertMaterialC(RenderDelegate& delegate) {
    delegate.insertSprim("material", "/looks/c");
    delegate.material("/looks/c").setParam("emissiveColor", Vec3f(5.0f));
  }
  static void insertBulb(RenderDelegate& delegate) {
    delegate.insertSprim("sphereLight", "/bulb");
    delegate.light("/bulb").setParam("intensity", 4.0f);
    delegate.light("/bulb").setParam("radius", 0.2f);
    delegate.light("/bulb").setTransform(translation(-1, 1.5, 0.5));
  }

  static std::vector<float> render(RenderDelegate& delegate) {
    RenderPass pass(delegate, "/cam", 16, 16);
    pass.execute(4);
    return pass.aov("color");
  }
  std::vector<float> freshRender(const SceneSpec& spec) const {
    RenderDelegate fresh;
    buildScene(fresh, spec);
    return render(fresh);
  }
  static std::map<PrimId, int> syncCounts(RenderDelegate& delegate) {
    std::map<PrimId, int> counts;
    for (const PrimId& id : delegate.primIds()) counts[id] = delegate.prim(id).syncCount();
    return counts;
  }
  /// The prims whose sync count changed between two snapshots.
  static std::vector<PrimId> synced(const std::map<PrimId, int>& before,
                                    const std::map<PrimId, int>& after) {
    std::vector<PrimId> ids;
    for (const auto& [id, count] : after)
      if (!before.count(id) || before.at(id) != count) ids.push_back(id);
    return ids;
  }
};

}  // namespace

TEST_F(SprimSync, AMaterialEditBuildsThatMaterialAlone) {
  RenderDelegate delegate;
  buildScene(delegate, {});
  const std::vector<float> before = render(delegate);
  const std::vector<std::string> warnings = delegate.takeWarnings();
  ASSERT_EQ(warnings.size(), 2u);  // the missing texture and the broken light, once each
  EXPECT_EQ(warnings[0].rfind("/looks/missing: ", 0), 0u) << warnings[0];
  EXPECT_EQ(warnings[1].rfind("/broken: ", 0), 0u) << warnings[1];
  const auto counts = syncCounts(delegate);
  const auto stats = delegate.syncStatistics();
  EXPECT_EQ(stats.materialBuilds, 3u);
  EXPECT_EQ(stats.materialTextureOpens, 2u);

  SceneSpec edited;
  edited.diffuseA = {0.2f, 0.2f, 0.8f};
  setMaterialA(delegate.material("/looks/a"), edited);
  const std::vector<float> after = render(delegate);
  EXPECT_EQ(synced(counts, syncCounts(delegate)), std::vector<PrimId>{"/looks/a"});
  EXPECT_EQ(delegate.syncStatistics().materialBuilds, stats.materialBuilds + 1);
  EXPECT_EQ(delegate.syncStatistics().materialTextureOpens, stats.materialTextureOpens);
  EXPECT_TRUE(delegate.takeWarnings().empty());  // the others' problems are not reported again
  EXPECT_NE(after, before);
  EXPECT_EQ(after, freshRender(edited));

  // The textured material opens its own texture again, and only it.
  delegate.material("/looks/missing").setParam("roughness", 0.3f);
  render(delegate);
  EXPECT_EQ(delegate.syncStatistics().materialTextureOpens, stats.materialTextureOpens + 1);
  EXPECT_EQ(delegate.takeWarnings().size(), 1u);  // it changed: its problem is reported again
}

TEST_F(SprimSync, MaterialIndicesStayFixedAcrossRemovalAndReuse) {
  RenderDelegate delegate;
  buildScene(delegate, {});
  render(delegate);
  const auto counts = syncCounts(delegate);

  // "/looks/c" takes the index "/looks/a" had: "/left", still bound to "/looks/a", falls back
  // to its displayColor rather than showing "/looks/c".
  delegate.removePrim("/looks/a");
  insertMaterialC(delegate);
  SceneSpec edited;
  edited.materialA = false;
  edited.materialC = true;
  EXPECT_EQ(render(delegate), freshRender(edited));
  // Meshes are placed again, not synced; the other materials are not built again.
  EXPECT_EQ(synced(counts, syncCounts(delegate)), std::vector<PrimId>{"/looks/c"});

  delegate.insertSprim("material", "/looks/a");
  setMaterialA(delegate.material("/looks/a"), {});
  edited.materialA = true;
  EXPECT_EQ(render(delegate), freshRender(edited));
}

TEST_F(SprimSync, ALightEditBuildsThatLightAlone) {
  RenderDelegate delegate;
  buildScene(delegate, {});
  const std::vector<float> before = render(delegate);
  EXPECT_EQ(delegate.takeWarnings().size(), 2u);
  const auto counts = syncCounts(delegate);
  const auto stats = delegate.syncStatistics();
  EXPECT_EQ(stats.lightTextureLoads, 1u);

  SceneSpec edited;
  edited.panelIntensity = 6;
  delegate.light("/panel").setParam("intensity", edited.panelIntensity);
  const std::vector<float> after = render(delegate);
  EXPECT_EQ(synced(counts, syncCounts(delegate)), std::vector<PrimId>{"/panel"});
  EXPECT_EQ(delegate.syncStatistics().lightBuilds, stats.lightBuilds + 1);
  EXPECT_EQ(delegate.syncStatistics().lightTextureLoads, stats.lightTextureLoads);
  EXPECT_TRUE(delegate.takeWarnings().empty());  // "/broken" is not reported again
  EXPECT_NE(after, before);
  EXPECT_EQ(after, freshRender(edited));
}

TEST_F(SprimSync, LightsJoinAndLeaveTheListInIdOrder) {
  RenderDelegate delegate;
  buildScene(delegate, {});
  render(delegate);
  const auto stats = delegate.syncStatistics();
  SceneSpec edited;

  // "/bulb" sorts first: every other light moves one place along, none is built again.
  insertBulb(delegate);
  edited.bulb = true;
  EXPECT_EQ(render(delegate), freshRender(edited));
  EXPECT_EQ(delegate.syncStatistics().lightBuilds, stats.lightBuilds + 1);

  delegate.light("/panel").setVisible(false);
  edited.panelVisible = false;
  EXPECT_EQ(render(delegate), freshRender(edited));

  delegate.mesh("/right").setLight(true, {{"intensity", 3.0f}});
  edited.rightEmits = true;
  EXPECT_EQ(render(delegate), freshRender(edited));

  delegate.removePrim("/bulb");
  delegate.light("/panel").setVisible(true);
  delegate.mesh("/right").setLight(false, {});
  EXPECT_EQ(render(delegate), freshRender({}));
  // The dome kept its texture throughout.
  EXPECT_EQ(delegate.syncStatistics().lightTextureLoads, stats.lightTextureLoads);
}

TEST_F(SprimSync, AMaterialEditCutsItsMeshOutAndBackIn) {
  RenderDelegate delegate;
  buildScene(delegate, {});
  const std::vector<float> whole = render(delegate);
  const auto counts = syncCounts(delegate);
  SceneSpec edited;
  edited.opacityA = 0.2f;  // "/left" is cut out whole
  setMaterialA(delegate.material("/looks/a"), edited);
  const std::vector<float> cutOut = render(delegate);
  EXPECT_NE(cutOut, whole);
  EXPECT_EQ(cutOut, freshRender(edited));
  edited.opacityA = 0;
  edited.opacityTexturedA = true;  // cut out per hit, where the texel's red is below 0.5
  setMaterialA(delegate.material("/looks/a"), edited);
  const std::vector<float> perHit = render(delegate);
  EXPECT_NE(perHit, cutOut);  // the texel is red: nothing is cut out
  EXPECT_EQ(perHit, freshRender(edited));
  setMaterialA(delegate.material("/looks/a"), {});
  EXPECT_EQ(render(delegate), whole);
  // The mesh followed its material without being synced.
  EXPECT_EQ(synced(counts, syncCounts(delegate)), std::vector<PrimId>{"/looks/a"});
}

TEST_F(SprimSync, EveryLightInputOfTheTableSetsItsParameter) {
  RenderDelegate delegate;
  addCamera(delegate, facingDown(0, 5, 0));
  delegate.insertSprim("domeLight", "/light");
  plugin::Light& light = delegate.light("/light");
  // The message setParam throws, or "" when it takes the value.
  const auto problem = [&](const std::string& name, const ParamValue& value) -> std::string {
    try {
      light.setParam(name, value);
      return "";
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
  };
  for (const LightInputInfo& input : lightInputs()) {
    SCOPED_TRACE(input.name);
    EXPECT_EQ(findLightInput(input.name), &input);
    EXPECT_EQ(input.lightTypes.empty(), input.origin != LightInputOrigin::LightSchema);
    ParamValue value, wrong = 1.0f;
    std::string expects;
    switch (input.kind) {
      case LightInputKind::Float:
        value = 0.25f;  // no input's default
        wrong = std::string("0.25");
        expects = "expects a number";
        break;
      case LightInputKind::Color:
        value = Vec3f(0.25f, 0.5f, 0.75f);
        expects = "expects a 3-component colour";
        break;
      case LightInputKind::Bool:
        if (const auto* member = std::get_if<bool LightParams::*>(&input.member))
          value = !(light.params().*(*member));
        else
          value = true;
        expects = "expects a bool or an int";
        break;
      case LightInputKind::Asset:
        value = path("sky.exr");
        expects = "expects a string";
        break;
    }
    light.setParam(input.name, value);
    const LightParams& params = light.params();
    if (const auto* member = std::get_if<float LightParams::*>(&input.member)) {
      EXPECT_EQ(params.*(*member), std::get<float>(value));
    }
    if (const auto* member = std::get_if<bool LightParams::*>(&input.member)) {
      EXPECT_EQ(params.*(*member), std::get<bool>(value));
    }
    if (const auto* member = std::get_if<Vec3f LightParams::*>(&input.member)) {
      const Vec3f set = params.*(*member), given = std::get<Vec3f>(value);
      EXPECT_EQ(std::tie(set.x, set.y, set.z), std::tie(given.x, given.y, given.z));
    }
    EXPECT_EQ(problem(input.name, wrong), "/light: " + input.name + " " + expects);
  }
  render(delegate);
  EXPECT_NE(light.params().texture, nullptr);  // texture:file was loaded
  EXPECT_EQ(problem("inputs:intensity", 1.0f),
            "/light: unknown light parameter 'inputs:intensity'");
}
