// Shader networks at a shading point: UsdTransform2d, primvar readers, ray footprints, and
// cut-outs decided per hit.
#include <gtest/gtest.h>

#include <limits>

#include "penumbra/mesh_shape.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "penumbra/shading.h"
#include "transforms.h"

using namespace penumbra;

namespace {

/// Two triangles covering the unit square in z = 0: corners (0,0), (1,0), (1,1), (0,1).
TriangleMesh unitSquare() {
  MeshData data;
  data.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  data.faceVertexCounts = {3, 3};
  data.faceVertexIndices = {0, 1, 2, 0, 2, 3};
  return triangulate(data);
}

SurfacePoint pointOn(const MeshShape& mesh, uint32_t triangle, float u, float v) {
  SurfacePoint point = mesh.pointAt(triangle, u, v, 0);
  point.normal = point.shadingNormal = {0, 0, 1};
  return point;
}

Material readsPrimvar(MaterialInput input, const std::string& primvar,
                      std::array<float, 3> fallback = {0, 0, 0}) {
  Material material;
  InputConnection connection;
  connection.input = input;
  connection.primvar = PrimvarName(primvar);
  connection.fallback = fallback;
  material.connections.push_back(connection);
  return material;
}

}  // namespace

TEST(Shading, Transform2dScalesThenRotatesThenTranslates) {
  TextureCoordinates coordinates;
  coordinates.scale = {2, 1};
  coordinates.rotation = 90;
  coordinates.translation = {0.5f, 0};
  // (1, 0) → scale (2, 0) → rotate 90° counter-clockwise (0, 2) → translate (0.5, 2).
  const Vec2f st = coordinates.apply({1, 0});
  EXPECT_NEAR(st.x, 0.5f, 1e-6f);
  EXPECT_NEAR(st.y, 2.0f, 1e-6f);
  // Differences ignore the translation.
  const Vec2f d = coordinates.applyLinear({0, 1});
  EXPECT_NEAR(d.x, -1.0f, 1e-6f);
  EXPECT_NEAR(d.y, 0.0f, 1e-6f);
}

TEST(Shading, PrimvarReadersInterpolateEveryInterpolation) {
  TriangleMesh mesh = unitSquare();
  // Vertex: the x coordinate of each point; faceVarying: y; uniform: the face index.
  mesh.primvars = {{"x", {0, 1, 1, 0}, 1, Interpolation::Vertex},
                   {"y", {0, 0, 1, 0, 1, 1}, 1, Interpolation::FaceVarying},
                   {"face", {10, 20}, 1, Interpolation::Uniform},
                   {"tint", {0.1f, 0.2f, 0.3f}, 3, Interpolation::Constant}};
  TextureSystem textures;
  const MeshShape shape(mesh);
  // Triangle 0 has corners (0,0), (1,0), (1,1); u = 0.5, v = 0.25 lies at (0.75, 0.25).
  const SurfacePoint point = pointOn(shape, 0, 0.5f, 0.25f);
  Vec3f normal = point.shadingNormal;
  EXPECT_NEAR(
      evaluateMaterial(readsPrimvar(MaterialInput::Roughness, "x"), textures, point, &normal)
          .roughness,
      0.75f, 1e-6f);
  EXPECT_NEAR(evaluateMaterial(readsPrimvar(MaterialInput::Metallic, "y"), textures, point, &normal)
                  .metallic,
              0.25f, 1e-6f);
  EXPECT_EQ(evaluateMaterial(readsPrimvar(MaterialInput::Ior, "face"), textures,
                             pointOn(shape, 1, 0.3f, 0.3f), &normal)
                .ior,
            20.0f);
  const Vec3f tint =
      evaluateMaterial(readsPrimvar(MaterialInput::DiffuseColor, "tint"), textures, point, &normal)
          .diffuseColor;
  EXPECT_EQ(tint.x, 0.1f);
  EXPECT_EQ(tint.z, 0.3f);
  // A one-channel primvar feeding a colour is grey; a colour feeding a float gives its first
  // channel.
  const Vec3f grey =
      evaluateMaterial(readsPrimvar(MaterialInput::DiffuseColor, "x"), textures, point, &normal)
          .diffuseColor;
  EXPECT_NEAR(grey.x, 0.75f, 1e-6f);
  EXPECT_NEAR(grey.z, 0.75f, 1e-6f);
  EXPECT_EQ(evaluateMaterial(readsPrimvar(MaterialInput::Opacity, "tint"), textures, point, &normal)
                .opacity,
            0.1f);
  // Missing primvars give the reader's fallback; displayColor is found where it is kept.
  const Vec3f fallback =
      evaluateMaterial(readsPrimvar(MaterialInput::EmissiveColor, "absent", {1, 2, 3}), textures,
                       point, &normal)
          .emissiveColor;
  EXPECT_EQ(fallback.y, 2.0f);
  mesh.displayColor = {{0.9f, 0.5f, 0.1f}};
  const MeshShape coloured(mesh);
  EXPECT_EQ(evaluateMaterial(readsPrimvar(MaterialInput::DiffuseColor, "displayColor"), textures,
                             pointOn(coloured, 0, 0.5f, 0.25f), &normal)
                .diffuseColor.y,
            0.5f);
  // Unconnected inputs keep their constants.
  Material constant = readsPrimvar(MaterialInput::Roughness, "x");
  constant.constants.metallic = 0.625f;
  EXPECT_EQ(evaluateMaterial(constant, textures, point, &normal).metallic, 0.625f);
}

namespace {

ExpressionNode leaf(ExpressionOp op, std::array<float, 4> value, std::string primvar = {}) {
  ExpressionNode node;
  node.op = op;
  node.value = value;
  node.primvar = PrimvarName(std::move(primvar));
  return node;
}
ExpressionNode operation(ExpressionOp op, std::array<uint8_t, 3> operands,
                         std::array<uint8_t, 4> channels = {0, 1, 2, 3}) {
  ExpressionNode node;
  node.op = op;
  node.operands = operands;
  node.channels = channels;
  return node;
}

/// The diffuse colour a program gives at `point`.
Vec3f programValue(std::vector<ExpressionNode> nodes, const SurfacePoint& point) {
  Material material;
  ExpressionProgram program;
  program.nodes = std::move(nodes);
  EXPECT_EQ(program.problem(0), "");
  material.programs.push_back(std::move(program));
  InputConnection connection;
  connection.input = MaterialInput::DiffuseColor;
  connection.program = 0;
  material.connections.push_back(connection);
  TextureSystem textures;
  Vec3f normal = point.shadingNormal;
  return evaluateMaterial(material, textures, point, &normal).diffuseColor;
}

}  // namespace

TEST(Shading, ProgramsEvaluateEveryOperationExactly) {
  TriangleMesh mesh = unitSquare();
  mesh.primvars = {{"x", {0, 1, 1, 0}, 1, Interpolation::Vertex}};
  const MeshShape shape(mesh);
  const SurfacePoint point = pointOn(shape, 0, 0.5f, 0.25f);  // x = 0.75
  const auto value = [&](ExpressionNode last) {
    return programValue({leaf(ExpressionOp::Constant, {0.5f, 2, 4, 8}),
                         leaf(ExpressionOp::Primvar, {9, 9, 9, 9}, "x"),
                         leaf(ExpressionOp::Constant, {0, 1, 0.25f, 0}), last},
                        point);
  };
  const auto expectColor = [](const Vec3f& c, float x, float y, float z) {
    EXPECT_FLOAT_EQ(c.x, x);
    EXPECT_FLOAT_EQ(c.y, y);
    EXPECT_FLOAT_EQ(c.z, z);
  };
  // The primvar is zero-padded: (0.75, 0, 0, 0).
  expectColor(value(operation(ExpressionOp::Add, {0, 1, 0})), 1.25f, 2, 4);
  expectColor(value(operation(ExpressionOp::Subtract, {0, 1, 0})), -0.25f, 2, 4);
  expectColor(value(operation(ExpressionOp::Multiply, {0, 1, 0})), 0.375f, 0, 0);
  expectColor(value(operation(ExpressionOp::Divide, {1, 0, 0})), 1.5f, 0, 0);
  expectColor(value(operation(ExpressionOp::Divide, {0, 2, 0})), 0, 2, 16);  // x / 0 = 0
  // mix(fg, bg, amount) = bg + (fg − bg) × amount.
  expectColor(value(operation(ExpressionOp::Mix, {0, 1, 2})), 0.75f, 2, 1);
  expectColor(value(operation(ExpressionOp::Clamp, {1, 2, 0})), 0.5f, 1, 0.25f);
  expectColor(value(operation(ExpressionOp::Swizzle, {0, 0, 0}, {3, 3, 0, 0})), 8, 8, 0.5f);
  expectColor(value(operation(ExpressionOp::Concatenate, {1, 0, 0}, {1, 0, 0, 0})), 0.75f, 0.5f, 2);
  // Where the mesh lacks the primvar, its fallback.
  expectColor(programValue({leaf(ExpressionOp::Primvar, {1, 2, 3, 4}, "absent")}, point), 1, 2, 3);
}

TEST(Shading, ProgramsWithProblemsAreNamed) {
  ExpressionProgram program;
  EXPECT_NE(program.problem(0), "");
  program.nodes = {leaf(ExpressionOp::Constant, {1, 0, 0, 0}),
                   operation(ExpressionOp::Add, {0, 1, 0})};
  EXPECT_EQ(program.problem(0), "program node 1: an operand is not an earlier node");
  program.nodes = {leaf(ExpressionOp::Texture, {0, 0, 0, 0})};
  EXPECT_EQ(program.problem(0), "program node 0: no such texture");
  program.nodes[0].texture = 0;
  EXPECT_EQ(program.problem(1), "");
}

TEST(Shading, SurfaceTangentFollowsTheTangentPrimvarElseSt) {
  TriangleMesh mesh = unitSquare();
  const Transform identity;
  // No st: no tangent (the BSDF picks one).
  EXPECT_EQ(length(surfaceTangent(pointOn(MeshShape(mesh), 0, 0.3f, 0.3f), identity)), 0.0f);
  // st turned by 90°: s grows along +y.
  mesh.primvars = {{"st", {0, 0, 0, -1, 1, -1, 1, 0}, 2, Interpolation::Vertex}};
  const Vec3f fromSt = normalize(surfaceTangent(pointOn(MeshShape(mesh), 1, 0.3f, 0.3f), identity));
  EXPECT_NEAR(fromSt.y, 1.0f, 1e-6f);
  mesh.primvars.push_back({"tangent", {1, 1, 0}, 3, Interpolation::Constant});
  const Vec3f fromPrimvar = surfaceTangent(pointOn(MeshShape(mesh), 1, 0.3f, 0.3f), identity);
  EXPECT_EQ(fromPrimvar.x, 1.0f);
  EXPECT_EQ(fromPrimvar.y, 1.0f);
}

TEST(Shading, FootprintsStretchAlongTheDirectionAtGrazingIncidence) {
  Vec3f dpdx, dpdy;
  footprintOnSurface({0, 0, -1}, {0, 0, 1}, 0.01f, &dpdx, &dpdy);
  EXPECT_NEAR(length(dpdx), 0.01f, 1e-7f);
  EXPECT_NEAR(length(dpdy), 0.01f, 1e-7f);
  EXPECT_NEAR(dot(dpdx, dpdy), 0.0f, 1e-9f);
  // At 60° from the normal, the footprint is twice as long along the ray's projection.
  const float s = std::sin(3.14159265f / 3), c = std::cos(3.14159265f / 3);
  footprintOnSurface({s, 0, -c}, {0, 0, 1}, 0.01f, &dpdx, &dpdy);
  EXPECT_NEAR(length(dpdx), 0.02f, 1e-6f);
  EXPECT_NEAR(std::abs(dpdx.x), 0.02f, 1e-6f);
  EXPECT_NEAR(length(dpdy), 0.01f, 1e-7f);
  EXPECT_NEAR(dpdx.z, 0.0f, 1e-7f);
}

TEST(Render, OpacityBelowTheThresholdCutsOutPerHit) {
  using namespace penumbra::plugin;
  RenderDelegate delegate;
  // A floor of two faces (x < 0 and x > 0), wider than the view; a uniform primvar "mask" is 0 on
  // the first.
  delegate.insertRprim("mesh", "/floor");
  Mesh& floor = delegate.mesh("/floor");
  floor.setPoints({{-2, 0, -2}, {-2, 0, 2}, {0, 0, 2}, {0, 0, -2}, {2, 0, 2}, {2, 0, -2}});
  floor.setTopology({4, 4}, {0, 1, 2, 3, 3, 2, 4, 5}, false, "none");
  floor.setPrimvars({{"mask", {0, 1}, 1, Interpolation::Uniform}});
  delegate.insertSprim("material", "/cutout");
  delegate.material("/cutout").setParam("opacityThreshold", 0.5f);
  plugin::InputSource mask;
  mask.primvar = "mask";
  delegate.material("/cutout").connect("opacity", mask);
  floor.setMaterialId("/cutout");
  delegate.insertSprim("camera", "/cam");
  CameraParams camera;
  camera.projection = Projection::Orthographic;
  camera.horizontalAperture = camera.verticalAperture = 20;  // 2 units
  delegate.camera("/cam").setParams(camera);
  delegate.camera("/cam").setTransform(test::facingDown(0, 5, 0));

  RenderPass pass(delegate, "/cam", 8, 8);
  pass.execute(4);
  const std::vector<float> rgba = pass.aov("color");
  for (int y = 0; y < 8; ++y) {
    EXPECT_EQ(rgba[size_t(y * 8 + 1) * 4 + 3], 0.0f) << "row " << y << ": left half is cut out";
    EXPECT_EQ(rgba[size_t(y * 8 + 6) * 4 + 3], 1.0f) << "row " << y << ": right half stays";
  }

  // Without a threshold the same opacity is translucency, not a cut-out.
  delegate.material("/cutout").setParam("opacityThreshold", 0.0f);
  RenderPass translucent(delegate, "/cam", 8, 8);
  translucent.execute(4);
  EXPECT_EQ(translucent.aov("color")[size_t(8 + 1) * 4 + 3], 1.0f);
}

TEST(Render, PerInstancePrimvarsOverrideThePrototypes) {
  using namespace penumbra::plugin;
  RenderDelegate delegate;
  delegate.insertRprim("mesh", "/proto");
  Mesh& proto = delegate.mesh("/proto");
  proto.setPoints({{-0.25f, 0, -0.25f}, {-0.25f, 0, 0.25f}, {0.25f, 0, 0.25f}, {0.25f, 0, -0.25f}});
  proto.setTopology({4}, {0, 1, 2, 3}, false, "none");
  proto.setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  proto.setVisible(false);
  delegate.insertRprim("instancer", "/copies");
  delegate.instancer("/copies").setInstances(
      "/proto", {test::translation(-1, 0, 0), test::translation(1, 0, 0)});
  delegate.insertSprim("camera", "/cam");
  CameraParams camera;
  camera.projection = Projection::Orthographic;
  camera.horizontalAperture = camera.verticalAperture = 40;  // x in [-2, 2]
  delegate.camera("/cam").setParams(camera);
  delegate.camera("/cam").setTransform(test::facingDown(0, 5, 0));
  const auto colorAt = [&](RenderPass& pass, float x) {
    pass.execute(16);
    const std::vector<float> rgba = pass.aov("color");
    const size_t pixel = size_t(20 * 40 + int((x + 2) / 4 * 40));
    return Vec3f(rgba[4 * pixel], rgba[4 * pixel + 1], rgba[4 * pixel + 2]);
  };

  // Copies without a material are coloured by their own displayColor.
  delegate.insertSprim("domeLight", "/sky");
  delegate.instancer("/copies").setPrimvars(
      {{"displayColor", {1, 0, 0, 0, 0, 1}, 3, Interpolation::Vertex}});
  RenderPass pass(delegate, "/cam", 40, 40);
  const Vec3f left = colorAt(pass, -1);
  EXPECT_GT(left.x, 0.1f);
  EXPECT_LT(left.z, 0.01f);
  RenderPass again(delegate, "/cam", 40, 40);
  const Vec3f right = colorAt(again, 1);
  EXPECT_LT(right.x, 0.01f);
  EXPECT_GT(right.z, 0.1f);

  // Material primvar readers see the copy's value first, then the prototype's (unlit: only
  // emission shows).
  delegate.removePrim("/sky");
  delegate.insertSprim("material", "/glow");
  delegate.material("/glow").setParam("diffuseColor", Vec3f(0.0f));
  plugin::InputSource heat;
  heat.primvar = "heat";
  delegate.material("/glow").connect("emissiveColor", heat);
  proto.setMaterialId("/glow");
  proto.setPrimvars({{"heat", {0.25f}, 1, Interpolation::Constant}});
  delegate.instancer("/copies").setPrimvars(
      {{"heat", {2}, 1, Interpolation::Vertex}, {"unused", {0, 0}, 1, Interpolation::Vertex}});
  RenderPass wrongCount(delegate, "/cam", 40, 40);
  EXPECT_NEAR(colorAt(wrongCount, -1).x, 0.25f, 1e-6f);  // the count does not match: ignored
  EXPECT_EQ(delegate.takeWarnings().size(), 1u);
  delegate.instancer("/copies").setPrimvars({{"heat", {2, 3}, 1, Interpolation::Vertex}});
  RenderPass emissive(delegate, "/cam", 40, 40);
  EXPECT_NEAR(colorAt(emissive, -1).y, 2.0f, 1e-5f);
  RenderPass emissiveRight(delegate, "/cam", 40, 40);
  EXPECT_NEAR(colorAt(emissiveRight, 1).y, 3.0f, 1e-5f);

  // A copy whose value is NaN has none of its own: the prototype's applies.
  const float none = std::numeric_limits<float>::quiet_NaN();
  delegate.instancer("/copies").setPrimvars({{"heat", {none, 3}, 1, Interpolation::Vertex}});
  RenderPass partial(delegate, "/cam", 40, 40);
  EXPECT_NEAR(colorAt(partial, -1).y, 0.25f, 1e-6f);

  // Cut-outs see the copy's own values too (for every ray: the hit filter).
  delegate.material("/glow").setParam("opacityThreshold", 0.5f);
  plugin::InputSource keep;
  keep.primvar = "keep";
  keep.fallback = {1, 1, 1};
  delegate.material("/glow").connect("opacity", keep);
  delegate.instancer("/copies").setPrimvars({{"keep", {0, 1}, 1, Interpolation::Vertex}});
  RenderPass cut(delegate, "/cam", 40, 40);
  cut.execute(4);
  const std::vector<float> rgba = cut.aov("color");
  const auto alphaAt = [&](float x) {
    return rgba[4 * size_t(20 * 40 + int((x + 2) / 4 * 40)) + 3];
  };
  EXPECT_EQ(alphaAt(-1), 0.0f);
  EXPECT_EQ(alphaAt(1), 1.0f);
}
