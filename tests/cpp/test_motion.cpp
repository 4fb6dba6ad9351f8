#include <gtest/gtest.h>

#include "penumbra/camera.h"
#include "penumbra/motion.h"
#include "penumbra/scene.h"
#include "penumbra/surface_hit.h"

using namespace penumbra;

namespace {

Transform rotationY(double degrees, double tx = 0, double ty = 0, double tz = 0) {
  const double a = degrees * M_PI / 180, c = std::cos(a), s = std::sin(a);
  // Row-vector convention: rows are the images of the X, Y, Z axes.
  const double m[16] = {c, 0, -s, 0, 0, 1, 0, 0, s, 0, c, 0, tx, ty, tz, 1};
  return Transform::fromRowMajor(m);
}

void expectTransformsNear(const Transform& a, const Transform& b, double tolerance) {
  for (size_t i = 0; i < 16; ++i) EXPECT_NEAR(a.m[i], b.m[i], tolerance) << "element " << i;
}

/// A unit-ish square in the XZ plane around `centre`, facing +Y.
TriangleMesh square(const Vec3f& centre, float half) {
  MeshData data;
  data.points = {centre + Vec3f(-half, 0, -half), centre + Vec3f(-half, 0, half),
                 centre + Vec3f(half, 0, half), centre + Vec3f(half, 0, -half)};
  data.faceVertexCounts = {4};
  data.faceVertexIndices = {0, 1, 2, 3};
  data.doubleSided = true;
  return triangulate(data);
}

Ray downAt(float x, float z, float time) {
  Ray ray;
  ray.origin = {x, 5, z};
  ray.direction = {0, -1, 0};
  ray.time = time;
  return ray;
}

}  // namespace

TEST(Motion, DecompositionRoundTripsIncludingShearAndMirror) {
  const double m[16] = {2, 0.3, 0, 0, -0.5, 1.5, 0.2, 0, 0.1, 0, -0.7, 0, 4, 5, 6, 1};
  const Transform original = Transform::fromRowMajor(m);
  const TransformDecomposition d = decompose(original);
  expectTransformsNear(compose(d), original, 1e-12);
  EXPECT_LT(d.scaleShear[5], 0);  // the mirror went into the last scale
  const Quaternion& q = d.rotation;
  EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-12);
}

TEST(Motion, RotationsInterpolateOnArcs) {
  const MotionTransform turn({rotationY(0), rotationY(90)});
  expectTransformsNear(turn.at(0.5f), rotationY(45), 1e-6);
  expectTransformsNear(turn.at(1.0f / 3), rotationY(30), 1e-6);
  // A point at arm length 2 stays at distance 2 from the axis all along the turn.
  for (float t : {0.1f, 0.4f, 0.77f})
    EXPECT_NEAR(length(turn.at(t).applyToPoint({2, 0, 0})), 2, 1e-5);
}

TEST(Motion, StepsAreUniformlySpaced) {
  const MotionTransform path({rotationY(0, 0, 0, 0), rotationY(0, 1, 0, 0), rotationY(0, 3, 0, 0)});
  EXPECT_NEAR(path.at(0.25f).applyToPoint({0, 0, 0}).x, 0.5f, 1e-6f);
  EXPECT_NEAR(path.at(0.75f).applyToPoint({0, 0, 0}).x, 2.0f, 1e-6f);
  EXPECT_THROW(MotionTransform(std::vector<Transform>{}), std::invalid_argument);
}

TEST(Motion, EmbreeInstanceMotionFollowsTheArc) {
  Device device;
  Scene scene(device);
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setMeshGeometry(id, square({2, 0, 0}, 0.05f));
  scene.geometry().setMeshInstance(id, MotionTransform({rotationY(0), rotationY(90)}),
                                   MaterialTable::kNoMaterial, true);
  scene.commit();
  // rotationY maps +X towards -Z: at t = 0.5 the square sits at 45° on the circle of radius 2.
  const float r = 2 / std::sqrt(2.0f);
  EXPECT_TRUE(intersectSurface(scene, downAt(2, 0, 0), RayKind::Camera));
  EXPECT_FALSE(intersectSurface(scene, downAt(2, 0, 0.5f), RayKind::Camera));
  EXPECT_TRUE(intersectSurface(scene, downAt(r, -r, 0.5f), RayKind::Camera));
  // The chord's midpoint (radius 1.41) is not on the path.
  EXPECT_FALSE(intersectSurface(scene, downAt(1, -1, 0.5f), RayKind::Camera));
  const auto end = intersectSurface(scene, downAt(0, -2, 1), RayKind::Camera);
  ASSERT_TRUE(end);
  EXPECT_NEAR(end->normal.y, 1, 1e-5f);
}

TEST(Motion, DeformationMotionInterpolatesPoints) {
  Device device;
  Scene scene(device);
  const Geometry::MeshId id = scene.geometry().addMesh();
  TriangleMesh mesh = square({0, 0, 0}, 0.05f);
  std::vector<Vec3f> moved = mesh.points, further = mesh.points;
  for (Vec3f& p : moved) p.x += 1;
  for (Vec3f& p : further) p.x += 3;
  mesh.pointMotion = {moved, further};
  scene.geometry().setMeshGeometry(id, std::move(mesh));
  scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
  scene.commit();
  EXPECT_TRUE(intersectSurface(scene, downAt(0, 0, 0), RayKind::Camera));
  EXPECT_TRUE(intersectSurface(scene, downAt(0.5f, 0, 0.25f), RayKind::Camera));
  EXPECT_TRUE(intersectSurface(scene, downAt(2, 0, 0.75f), RayKind::Camera));
  EXPECT_FALSE(intersectSurface(scene, downAt(1.5f, 0, 0.25f), RayKind::Camera));
}

TEST(Motion, MismatchedPointSamplesAreRejected) {
  MeshData data;
  data.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  data.pointMotion = {{{0, 0, 0}}};
  data.faceVertexCounts = {3};
  data.faceVertexIndices = {0, 1, 2};
  EXPECT_THROW(triangulate(data), std::invalid_argument);
}

TEST(Motion, CameraRaysUseTheTransformAndLensAtTheirTime) {
  CameraParams params;
  params.focalLength = 10;
  params.horizontalAperture = params.verticalAperture = 10;
  params.cameraToWorld = MotionTransform({rotationY(0, 0, 0, 0), rotationY(0, 4, 0, 0)});
  params.focalLengthSteps = {10, 20};
  params.focusDistanceSteps = {5, 5};
  const Camera camera(params, 10, 10);
  const Ray start = camera.generateRay(10, 5, {0.5f, 0.5f}, 0);
  const Ray end = camera.generateRay(10, 5, {0.5f, 0.5f}, 1);
  EXPECT_NEAR(start.origin.x, 0, 1e-6f);
  EXPECT_NEAR(end.origin.x, 4, 1e-6f);
  EXPECT_EQ(end.time, 1.0f);
  // Right edge of the film: x = 5 tenths over focal length 10, then 20.
  EXPECT_NEAR(start.direction.x / -start.direction.z, 0.5f, 1e-6f);
  EXPECT_NEAR(end.direction.x / -end.direction.z, 0.25f, 1e-6f);
}
