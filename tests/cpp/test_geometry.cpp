// The geometry aggregate's raw hits (which mesh, placement and triangle, where on it), and
// shading them (intersectSurface): the surface a kind of geometry reports, displayColor on
// meshes without a material.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "penumbra/mesh_shape.h"
#include "penumbra/points.h"
#include "penumbra/scene.h"
#include "penumbra/surface_hit.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::translation;

namespace {

/// A square of side 2 in the XZ plane around the origin, facing +Y, red where nothing is bound.
TriangleMesh redSquare() {
  MeshData data;
  data.points = {{-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}};
  data.faceVertexCounts = {4};
  data.faceVertexIndices = {0, 1, 2, 3};
  data.displayColor = {{1, 0, 0}};
  return triangulate(data);
}

Ray downAt(float x, float z) {
  Ray ray;
  ray.origin = {x, 5, z};
  ray.direction = {0, -1, 0};
  return ray;
}

/// Rays from 10^4 units away, from a spread of directions above, aimed at the points `aimAt`
/// gives for a 9 × 9 grid over [-1, 1]².
template <typename AimAt>
std::vector<Ray> raysFromAfar(AimAt aimAt) {
  std::vector<Ray> rays;
  for (int i = 0; i < 9; ++i)
    for (int j = 0; j < 9; ++j) {
      const float a = float(i) / 4 - 1, b = float(j) / 4 - 1;
      const Vec3f target = aimAt(a, b);
      Ray ray;
      ray.origin = target + Vec3f{3000.0f * a + 700, 9000, 2000.0f * b - 1300};
      ray.direction = normalize(target - ray.origin);
      rays.push_back(ray);
    }
  return rays;
}

}  // namespace

TEST(Geometry, RawHitsSayWhichPlacementAndTriangle) {
  const Device device;
  Scene scene(device);
  Geometry& geometry = scene.geometry();
  const Geometry::MeshId id = geometry.addMesh();
  geometry.setMeshGeometry(id, redSquare());
  geometry.setMeshInstance(id, translation(0, 1, 0), MaterialTable::kNoMaterial, true);
  geometry.setInstances(geometry.addInstancer(), id, {translation(10, 0, 0), translation(20, 0, 0)},
                        true);
  scene.commit();

  const std::optional<GeometryHit> own = geometry.intersect(downAt(0.5f, 0.5f), RayKind::Camera);
  ASSERT_TRUE(own);
  EXPECT_EQ(own->meshId, id);
  EXPECT_EQ(own->instance, -1);
  EXPECT_FLOAT_EQ(own->distance, 4);
  EXPECT_EQ(own->materialIndex, MaterialTable::kNoMaterial);
  ASSERT_NE(dynamic_cast<const MeshShape*>(own->shape), nullptr);
  EXPECT_LT(own->primitive, 2u);
  const SurfaceGeometry surface = own->shape->surfaceAt(
      own->primitive, own->u, own->v, 0, own->geometricNormal, own->objectToWorld->at(0));
  EXPECT_NEAR(surface.normal.y, 1, 1e-6f);

  const std::optional<GeometryHit> copy = geometry.intersect(downAt(20, 0.5f), RayKind::Camera);
  ASSERT_TRUE(copy);
  EXPECT_EQ(copy->meshId, id);
  EXPECT_EQ(copy->instance, 1);
  EXPECT_FLOAT_EQ(copy->distance, 5);
  EXPECT_FALSE(geometry.intersect(downAt(5, 0), RayKind::Camera));
}

TEST(Geometry, ShadingAHitWithoutAMaterialUsesDisplayColor) {
  const Device device;
  Scene scene(device);
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setMeshGeometry(id, redSquare());
  scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
  scene.commit();

  const std::optional<SurfaceHit> hit =
      intersectSurface(scene, downAt(0.5f, 0.5f), RayKind::Camera);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->meshId, id);
  // Rebuilt from the square's corners: on it exactly, however Embree's kernels round the
  // distance (4.9999995 on an AMD EPYC with AVX2, 5 on the Intel Xeons).
  EXPECT_EQ(hit->position.y, 0);
  EXPECT_EQ(hit->material().diffuseColor.x, 1);
  EXPECT_EQ(hit->material().diffuseColor.y, 0);
  EXPECT_EQ(hit->lightIndex, -1);
  // A mesh light of an index past the lights emits nothing.
  scene.lights().setMeshLight(id, 3);
  EXPECT_EQ(intersectSurface(scene, downAt(0.5f, 0.5f), RayKind::Camera)->lightIndex, -1);
}

TEST(Geometry, PlacementsReachingBeyondFloatRangeAreNotRendered) {
  const Device device;
  Scene scene(device);
  Geometry& geometry = scene.geometry();
  const Geometry::MeshId id = geometry.addMesh();
  geometry.setMeshGeometry(id, redSquare());
  const double huge[16] = {1e30, 0, 0, 0, 0, 1e30, 0, 0, 0, 0, 1e30, 0, 0, 0, 0, 1};
  geometry.setMeshInstance(id, Transform::fromRowMajor(huge), MaterialTable::kNoMaterial, true);
  const Geometry::InstancerId copies = geometry.addInstancer();
  geometry.setInstances(copies, id, {translation(0, 1, 0), Transform::fromRowMajor(huge)}, true);
  scene.commit();

  EXPECT_TRUE(geometry.beyondReach(id));
  EXPECT_EQ(geometry.copiesBeyondReach(copies), 1u);
  // Only the copy within reach is hit, and the scene's extent is that copy's.
  const std::optional<GeometryHit> hit = geometry.intersect(downAt(0.5f, 0.5f), RayKind::Camera);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->instance, 0);
  EXPECT_FLOAT_EQ(hit->distance, 4);
  EXPECT_FLOAT_EQ(geometry.extent(), 2);

  geometry.setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
  EXPECT_FALSE(geometry.beyondReach(id));
}

TEST(Geometry, PlacementsScaledFlatAreNotPlaced) {
  const Device device;
  Scene scene(device);
  Geometry& geometry = scene.geometry();
  const Geometry::MeshId id = geometry.addMesh();
  geometry.setMeshGeometry(id, redSquare());
  // Scale 0 along Z: the square becomes a segment, and the transform has no inverse.
  const double flat[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  // Scale 1e-18 along X: an inverse, but one that sends a ray meeting the sliver's bounds
  // beyond Embree's range (which aborted the process).
  const double nearlyFlat[16] = {1e-18, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  geometry.setMeshInstance(id, Transform::fromRowMajor(flat), MaterialTable::kNoMaterial, true);
  const Geometry::InstancerId copies = geometry.addInstancer();
  geometry.setInstances(
      copies, id,
      {translation(10, 0, 0), Transform::fromRowMajor(flat), Transform::fromRowMajor(nearlyFlat)},
      true);
  scene.commit();

  // Not placed (Embree would abort on the non-finite rays its inverse gives), and nothing to
  // report: it would show nothing.
  EXPECT_FALSE(geometry.beyondReach(id));
  EXPECT_EQ(geometry.copiesBeyondReach(copies), 0u);
  EXPECT_FALSE(geometry.intersect(downAt(0.5f, 0), RayKind::Camera));
  EXPECT_FALSE(geometry.intersect(downAt(0, 0.5f), RayKind::Camera));  // through the sliver
  // The scene's extent is the other copy's alone.
  EXPECT_FLOAT_EQ(geometry.extent(), 2);
  const std::optional<GeometryHit> hit = geometry.intersect(downAt(10.5f, 0), RayKind::Camera);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->instance, 0);
  EXPECT_FLOAT_EQ(hit->distance, 5);
}

// A hit's point lies on the surface to within the rounding of its own coordinates, far inside
// the offset that rays leave it by, however far the ray came from. As origin + distance ·
// direction it was off by the rounding of the ray's length (about 10^-3 from 10^4 units against
// an offset of 2 · 10^-5 here), so under a telephoto camera shadow rays started below the
// surface half the time: shadow acne.
TEST(Geometry, HitPointsLieOnTheSurfaceHoweverFarTheRayCameFrom) {
  const Device device;
  Scene scene(device);
  MeshData tilted;  // the plane y = 0.2 x + 0.2 z + 0.1 in object space
  tilted.points = {{-1, -0.3f, -1}, {-1, 0.1f, 1}, {1, 0.5f, 1}, {1, 0.1f, -1}};
  tilted.faceVertexCounts = {4};
  tilted.faceVertexIndices = {0, 1, 2, 3};
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setMeshGeometry(id, triangulate(tilted));
  const Vec3f offset{0.25f, -0.5f, 0.75f};
  scene.geometry().setMeshInstance(id, translation(offset.x, offset.y, offset.z),
                                   MaterialTable::kNoMaterial, true);
  scene.commit();

  const Vec3f normal = normalize(Vec3f{-0.2f, 1, -0.2f});
  int hits = 0;
  for (const Ray& ray : raysFromAfar([&](float x, float z) {
         return offset + Vec3f{x * 0.9f, 0.2f * x * 0.9f + 0.2f * z * 0.9f + 0.1f, z * 0.9f};
       })) {
    const std::optional<SurfaceHit> hit = intersectSurface(scene, ray, RayKind::Camera);
    ASSERT_TRUE(hit);
    ++hits;
    const float fromPlane = dot(hit->position - offset - Vec3f{0, 0.1f, 0}, normal);
    EXPECT_LT(std::abs(fromPlane), 0.05f * scene.rayEpsilon(hit->position))
        << "from " << ray.origin.x << ", " << ray.origin.z;
  }
  EXPECT_EQ(hits, 81);
}

TEST(Geometry, HitPointsLieOnASphereHoweverFarTheRayCameFrom) {
  const Device device;
  Scene scene(device);
  PointsData ball;
  const Vec3f centre{0.3f, 0.6f, -0.2f};
  ball.positions = {centre};
  ball.widths = {2};
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setPointsGeometry(id, std::move(ball));
  scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
  scene.commit();

  int hits = 0;
  for (const Ray& ray :
       raysFromAfar([&](float x, float z) { return centre + Vec3f{0.65f * x, 0, 0.65f * z}; })) {
    const std::optional<SurfaceHit> hit = intersectSurface(scene, ray, RayKind::Camera);
    ASSERT_TRUE(hit);
    ++hits;
    EXPECT_LT(std::abs(length(hit->position - centre) - 1),
              0.05f * scene.rayEpsilon(hit->position));
  }
  EXPECT_EQ(hits, 81);
}

TEST(Geometry, HitPointsLieOnADiscHoweverFarTheRayCameFrom) {
  // A tilted disc: Embree gives no point of it, only its distance along the ray, which from
  // 10^4 units away put hits up to 10^-3 either side of it (then the shadow rays of a third of
  // them started behind it). They are moved onto its plane.
  const Device device;
  Scene scene(device);
  PointsData disc;
  const Vec3f centre{0.3f, 0.6f, -0.2f};
  const Vec3f normal = normalize(Vec3f{-0.2f, 1, 0.3f});
  disc.positions = {centre};
  disc.widths = {2};
  disc.normals = {normal};
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setPointsGeometry(id, std::move(disc));
  scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
  scene.commit();

  const Vec3f across = normalize(cross(normal, Vec3f{0, 0, 1}));
  const Vec3f along = cross(across, normal);
  int hits = 0;
  for (const Ray& ray : raysFromAfar(
           [&](float x, float z) { return centre + across * (0.65f * x) + along * (0.65f * z); })) {
    const std::optional<SurfaceHit> hit = intersectSurface(scene, ray, RayKind::Camera);
    ASSERT_TRUE(hit);
    ++hits;
    EXPECT_LT(std::abs(dot(hit->position - centre, normal)),
              0.05f * scene.rayEpsilon(hit->position));
    EXPECT_LT(length(hit->position - centre), 0.95f);  // moved onto the plane, not across it
  }
  EXPECT_EQ(hits, 81);
}

TEST(Geometry, FaceMaterialsBindTheirFacesAndCutThemOutAlone) {
  const Device device;
  Scene scene(device);
  Geometry& geometry = scene.geometry();
  penumbra::Material plain;
  penumbra::Material hole;
  hole.constants.opacity = 0;
  hole.constants.opacityThreshold = 0.5f;
  scene.setMaterial(0, plain);
  scene.setMaterial(1, plain);
  // Two faces side by side: x < 0 is face 0, x > 0 face 1.
  MeshData data;
  data.points = {{-1, 0, -1}, {-1, 0, 1}, {0, 0, 1}, {0, 0, -1}, {1, 0, 1}, {1, 0, -1}};
  data.faceVertexCounts = {4, 4};
  data.faceVertexIndices = {0, 1, 2, 3, 3, 2, 4, 5};
  const Geometry::MeshId id = geometry.addMesh();
  geometry.setMeshGeometry(id, triangulate(data));
  geometry.setMeshInstance(id, Transform(), 0, true);
  geometry.setMeshFaceMaterials(id, {0, 1}, {1});
  geometry.setInstances(geometry.addInstancer(), id, {translation(10, 0, 0)}, true);
  scene.commit();
  const auto materialAt = [&](float x) {
    const std::optional<GeometryHit> hit = geometry.intersect(downAt(x, 0.5f), RayKind::Camera);
    return hit ? hit->materialIndex : -100;
  };
  EXPECT_EQ(materialAt(-0.5f), 0);
  EXPECT_EQ(materialAt(0.5f), 1);
  EXPECT_EQ(materialAt(10.5f), 1);  // copies render so too
  EXPECT_EQ(geometry.intersect(downAt(-0.5f, 0.5f), RayKind::Camera)->faceSlot, 0u);
  EXPECT_EQ(geometry.intersect(downAt(10.5f, 0.5f), RayKind::Camera)->faceSlot, 1u);
  EXPECT_THROW(geometry.setMeshFaceMaterials(id, {0, 2}, {1}), std::invalid_argument);

  // The faces' material cutting out whole hides those faces alone, from every ray.
  scene.setMaterial(1, hole);
  scene.commit();
  EXPECT_EQ(materialAt(-0.5f), 0);
  EXPECT_EQ(materialAt(0.5f), -100);
  EXPECT_EQ(materialAt(10.5f), -100);
  Ray shadow = downAt(0.5f, 0.5f);
  shadow.tFar = 10;
  EXPECT_FALSE(geometry.occluded(shadow));
  shadow.origin.x = -0.5f;
  EXPECT_TRUE(geometry.occluded(shadow));

  // The mesh's own material cutting out whole leaves the faces bound otherwise.
  geometry.setMeshInstance(id, Transform(), 1, true);
  geometry.setMeshFaceMaterials(id, {0, 1}, {0});
  scene.commit();
  EXPECT_EQ(materialAt(-0.5f), -100);
  EXPECT_EQ(materialAt(0.5f), 0);
  // Without face materials, the whole mesh goes.
  geometry.setMeshFaceMaterials(id, {}, {});
  scene.commit();
  EXPECT_EQ(materialAt(0.5f), -100);
}
