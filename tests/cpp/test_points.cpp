// Points (UsdGeomPoints) as a kind of geometry: spheres and discs hit where the analytic shapes
// are, their per-point data reaching shading, their validation, and their copies.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "penumbra/points.h"
#include "penumbra/scene.h"
#include "penumbra/surface_hit.h"
#include "transforms.h"
#include "white_furnace.h"

using namespace penumbra;
using penumbra::test::translation;

namespace {

/// One sphere of radius 1 at the origin, or a disc of radius 1 facing `normal` where one is
/// given.
PointsData onePoint(std::vector<Vec3f> normals = {}) {
  PointsData points;
  points.positions = {{0, 0, 0}};
  points.widths = {2};
  points.normals = std::move(normals);
  return points;
}

Ray rayFrom(const Vec3f& origin, const Vec3f& direction, float time = 0) {
  Ray ray;
  ray.origin = origin;
  ray.direction = normalize(direction);
  ray.time = time;
  return ray;
}

Ray downAt(float x, float z) {
  return rayFrom({x, 5, z}, {0, -1, 0});
}

/// A scene holding `points` placed by `objectToWorld`.
struct PointsScene {
  Device device;
  Scene scene{device};
  Geometry::MeshId id;

  explicit PointsScene(PointsData points, const MotionTransform& objectToWorld = Transform()) {
    id = scene.geometry().addMesh();
    scene.geometry().setPointsGeometry(id, std::move(points));
    scene.geometry().setMeshInstance(id, objectToWorld, MaterialTable::kNoMaterial, true);
    scene.commit();
  }
};

/// The message validatePoints throws for `points` (empty: none).
std::string problemOf(const PointsData& points) {
  try {
    validatePoints(points);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return {};
}

}  // namespace

TEST(Points, SphereIsHitAtItsAnalyticDistanceAndNormal) {
  PointsScene s(onePoint(), translation(0, 1, 0));
  // Straight at the centre, 4 away: the surface is r = 1 nearer.
  const std::optional<SurfaceHit> hit = intersectSurface(s.scene, downAt(0, 0), RayKind::Camera);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 3, 1e-5f);
  EXPECT_NEAR(hit->normal.y, 1, 1e-6f);
  EXPECT_NEAR(hit->shadingNormal.y, 1, 1e-6f);
  EXPECT_TRUE(hit->closed);
  // Off the axis by x: the sphere's surface at height sqrt(1 - x²) above its centre.
  const float x = 0.6f;
  const std::optional<SurfaceHit> off = intersectSurface(s.scene, downAt(x, 0), RayKind::Camera);
  ASSERT_TRUE(off);
  EXPECT_NEAR(off->distance, 4 - std::sqrt(1 - x * x), 1e-5f);
  EXPECT_NEAR(off->normal.x, x, 1e-5f);
  EXPECT_NEAR(off->normal.y, std::sqrt(1 - x * x), 1e-5f);
  // The silhouette: just inside the radius hits, just outside misses.
  EXPECT_TRUE(s.scene.geometry().intersect(downAt(0.99f, 0), RayKind::Camera));
  EXPECT_FALSE(s.scene.geometry().intersect(downAt(1.01f, 0), RayKind::Camera));
  EXPECT_FALSE(s.scene.geometry().intersect(downAt(0, -1.01f), RayKind::Secondary));
}

TEST(Points, RayFromInsideASphereMeetsItsFarSide) {
  PointsScene s(onePoint());
  const std::optional<SurfaceHit> hit =
      intersectSurface(s.scene, rayFrom({0, 0, 0}, {1, 0, 0}), RayKind::Secondary);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 1, 1e-5f);
  EXPECT_NEAR(hit->normal.x, 1, 1e-6f);  // outwards, as the ray goes
}

TEST(Points, DiscIsHitOnlyWithinItsRadiusAndFacesItsNormal) {
  PointsScene s(onePoint({{0, 2, 0}}));  // normals need not be unit
  const std::optional<SurfaceHit> above =
      intersectSurface(s.scene, downAt(0.9f, 0), RayKind::Camera);
  ASSERT_TRUE(above);
  EXPECT_NEAR(above->distance, 5, 1e-5f);
  EXPECT_NEAR(above->normal.y, 1, 1e-6f);
  EXPECT_FALSE(above->closed);  // a thin sheet
  EXPECT_FALSE(s.scene.geometry().intersect(downAt(1.1f, 0), RayKind::Camera));
  EXPECT_FALSE(s.scene.geometry().intersect(downAt(0.75f, 0.75f), RayKind::Camera));
  // Seen from below, it is the same disc, its normal still the authored one.
  const std::optional<SurfaceHit> below =
      intersectSurface(s.scene, rayFrom({0.5f, -3, 0}, {0, 1, 0}), RayKind::Camera);
  ASSERT_TRUE(below);
  EXPECT_NEAR(below->distance, 3, 1e-5f);
  EXPECT_NEAR(below->normal.y, 1, 1e-6f);
  // Edge on, a disc is not there.
  EXPECT_FALSE(s.scene.geometry().intersect(rayFrom({-5, 0.01f, 0}, {1, 0, 0}), RayKind::Camera));
}

TEST(Points, DiscNormalsFollowTheTransform) {
  const double rotateYToX[16] = {0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  PointsScene s(onePoint({{0, 1, 0}}), Transform::fromRowMajor(rotateYToX));
  const std::optional<SurfaceHit> hit =
      intersectSurface(s.scene, rayFrom({5, 0.5f, 0}, {-1, 0, 0}), RayKind::Camera);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 5, 1e-5f);
  EXPECT_NEAR(std::abs(hit->normal.x), 1, 1e-6f);
}

TEST(Points, DisplayColorPerPointOrConstantReachesTheFallbackSurface) {
  PointsData points;
  points.positions = {{-3, 0, 0}, {3, 0, 0}};
  points.widths = {2, 2};
  points.displayColor = {{1, 0, 0}, {0, 1, 0}};
  points.displayColorInterpolation = Interpolation::Vertex;
  points.primvars = {{"heat", {0.25f, 0.75f}, 1, Interpolation::Vertex},
                     {"st", {0.5f, 0.125f}, 2, Interpolation::Constant}};
  PointsScene s(points);
  const std::optional<SurfaceHit> left = intersectSurface(s.scene, downAt(-3, 0), RayKind::Camera);
  const std::optional<SurfaceHit> right =
      intersectSurface(s.scene, downAt(3.5f, 0), RayKind::Camera);
  ASSERT_TRUE(left && right);
  EXPECT_EQ(left->material().diffuseColor.x, 1);
  EXPECT_EQ(left->material().diffuseColor.y, 0);
  EXPECT_EQ(right->material().diffuseColor.x, 0);
  EXPECT_EQ(right->material().diffuseColor.y, 1);
  EXPECT_EQ(right->primitive, 1u);

  // Primvars: one value per point, or one for all, exactly.
  SurfacePoint point = right->shape->pointAt(right->primitive, right->u, right->v, 0);
  float value[4];
  int width = 0;
  ASSERT_TRUE(primvarAt(point, "heat", value, &width));
  EXPECT_EQ(width, 1);
  EXPECT_EQ(value[0], 0.75f);
  ASSERT_TRUE(primvarAt(point, "st", value, &width));
  EXPECT_EQ(width, 2);
  EXPECT_EQ(value[1], 0.125f);
  EXPECT_FALSE(primvarAt(point, "absent", value, &width));
  EXPECT_EQ(right->shape->elementOf(right->primitive), 1);
  // A point has no tangent frame: no anisotropy direction from st.
  EXPECT_EQ(length(surfaceTangent(point, Transform())), 0.0f);

  points.displayColor = {{0.25f, 0.5f, 0.75f}};
  points.displayColorInterpolation = Interpolation::Constant;
  const uint64_t builds = s.scene.geometry().meshBvhBuilds();
  s.scene.geometry().setPointsGeometry(s.id, points);
  s.scene.commit();
  EXPECT_EQ(s.scene.geometry().meshBvhBuilds(), builds);  // the same spheres: the BVH stands
  const std::optional<SurfaceHit> constant =
      intersectSurface(s.scene, downAt(3, 0), RayKind::Camera);
  ASSERT_TRUE(constant);
  EXPECT_EQ(constant->material().diffuseColor.z, 0.75f);
  EXPECT_EQ(s.scene.geometry().primvarWidth("st"), 2);
}

TEST(Points, InvalidPointsAreRejectedNamingTheArray) {
  PointsData points;
  points.positions = {{0, 0, 0}, {1, 0, 0}};
  points.widths = {1, 1};
  EXPECT_EQ(problemOf(points), "");

  PointsData p = points;
  p.widths = {1};
  EXPECT_NE(problemOf(p).find("widths has 1 values, expected 2"), std::string::npos);
  p.widths = {1, 0};  // an invisible point
  EXPECT_EQ(problemOf(p), "");
  p.widths = {-1, 1};
  EXPECT_NE(problemOf(p).find("widths[0]"), std::string::npos);
  p.widths = {1, std::numeric_limits<float>::quiet_NaN()};
  EXPECT_NE(problemOf(p).find("widths[1]"), std::string::npos);
  p.widths = {1, std::numeric_limits<float>::infinity()};
  EXPECT_NE(problemOf(p).find("widths[1]"), std::string::npos);

  p = points;
  p.positions[1].y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(problemOf(p).find("positions[1] is not finite"), std::string::npos);
  p = points;
  p.positionMotion = {{{0, 0, 0}}};
  EXPECT_NE(problemOf(p).find("positions at motion step 1"), std::string::npos);
  p = points;
  p.normals = {{0, 1, 0}};
  EXPECT_NE(problemOf(p).find("normals has 1 values"), std::string::npos);
  p.normals = {{0, 1, 0}, {0, 0, 0}};
  EXPECT_NE(problemOf(p).find("normals[1]"), std::string::npos);
  p = points;
  p.displayColor = {{1, 0, 0}};
  p.displayColorInterpolation = Interpolation::Vertex;
  EXPECT_NE(problemOf(p).find("displayColor (vertex) has 1 values, expected 2"), std::string::npos);
  p.displayColorInterpolation = Interpolation::Uniform;
  EXPECT_NE(problemOf(p).find("displayColor"), std::string::npos);
  p = points;
  p.primvars = {{"heat", {1, 2, 3}, 1, Interpolation::Vertex}};
  EXPECT_NE(problemOf(p).find("primvar heat"), std::string::npos);
  p.primvars = {{"heat", {1, 2}, 1, Interpolation::FaceVarying}};
  EXPECT_NE(problemOf(p).find("primvar heat"), std::string::npos);

  // The geometry refuses them the same way.
  const Device device;
  Scene scene(device);
  const Geometry::MeshId id = scene.geometry().addMesh();
  p = points;
  p.widths = {1, -1};
  EXPECT_THROW(scene.geometry().setPointsGeometry(id, p), std::invalid_argument);
}

TEST(Points, InstancerCopiesPlaceThePoints) {
  PointsScene s(onePoint());
  Geometry& geometry = s.scene.geometry();
  geometry.setMeshInstance(s.id, Transform(), MaterialTable::kNoMaterial, false);  // a prototype
  geometry.setInstances(geometry.addInstancer(), s.id,
                        {translation(10, 0, 0), translation(20, 0, 0)}, true);
  s.scene.commit();
  EXPECT_FALSE(geometry.intersect(downAt(0, 0), RayKind::Camera));
  for (int copy = 0; copy < 2; ++copy) {
    const std::optional<GeometryHit> hit =
        geometry.intersect(downAt(10.0f * float(copy + 1), 0), RayKind::Camera);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->instance, copy);
    EXPECT_NEAR(hit->distance, 4, 1e-5f);
  }
  EXPECT_FALSE(geometry.intersect(downAt(11.1f, 0), RayKind::Camera));
}

TEST(Points, MovingPointsAreWhereTheShutterTimeSays) {
  PointsData points = onePoint();
  points.positionMotion = {{{4, 0, 0}}};
  PointsScene s(points);
  EXPECT_TRUE(s.scene.geometry().intersect(rayFrom({0, 5, 0}, {0, -1, 0}, 0), RayKind::Camera));
  EXPECT_FALSE(s.scene.geometry().intersect(rayFrom({0, 5, 0}, {0, -1, 0}, 1), RayKind::Camera));
  const std::optional<SurfaceHit> late =
      intersectSurface(s.scene, rayFrom({4, 5, 0}, {0, -1, 0}, 1), RayKind::Camera);
  ASSERT_TRUE(late);
  EXPECT_NEAR(late->distance, 4, 1e-5f);
  EXPECT_NEAR(late->normal.y, 1, 1e-5f);
}

TEST(Points, WhiteSpheresUnderAWhiteDomeAreWhite) {
  // White furnace: white Lambertian spheres under a uniform dome of radiance 1 look like it.
  PointsData points;
  points.positions = {{-1.5f, 0, 0}, {0, 0, 0}, {1.5f, 0.5f, -1}};
  points.widths = {1, 1.2f, 1};
  points.displayColor = {Vec3f(1.0f)};
  PointsScene s(points);
  const test::FurnaceImage image = test::renderUnderWhiteDome(s.scene);
  EXPECT_GT(image.coverage, 1.0 / 5);  // the spheres fill much of the image
  EXPECT_NEAR(image.meanRadiance, 1.0, 0.01);
}

TEST(Points, MaterialsReadPerPointPrimvarsAndCutPointsOut) {
  PointsData points;
  points.positions = {{-3, 0, 0}, {3, 0, 0}};
  points.widths = {2, 2};
  points.primvars = {{"rough", {0.25f, 0.75f}, 1, Interpolation::Vertex},
                     {"keep", {0, 1}, 1, Interpolation::Vertex}};
  PointsScene s(points);
  Material material;
  InputConnection roughness;
  roughness.input = MaterialInput::Roughness;
  roughness.primvar = PrimvarName("rough");
  InputConnection opacity;
  opacity.input = MaterialInput::Opacity;
  opacity.primvar = PrimvarName("keep");
  material.connections = {roughness, opacity};
  material.constants.opacityThreshold = 0.5f;
  s.scene.setMaterial(0, material);
  s.scene.geometry().setMeshInstance(s.id, Transform(), 0, true);
  s.scene.commit();
  // Point 0's opacity is below the threshold: rays pass through it, for shadows too.
  EXPECT_FALSE(s.scene.geometry().intersect(downAt(-3, 0), RayKind::Camera));
  EXPECT_FALSE(s.scene.geometry().occluded(downAt(-3, 0)));
  const std::optional<SurfaceHit> kept = intersectSurface(s.scene, downAt(3, 0), RayKind::Camera);
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->material().roughness, 0.75f);
  EXPECT_EQ(kept->material().opacity, 1);
}
