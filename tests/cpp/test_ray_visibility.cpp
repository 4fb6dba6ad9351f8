// Per-object ray visibility (PassVisibility's shadow, diffuse, glossy, transmission, with the
// camera): the ray masks of placements and rays, and which traces see an object shown so.
#include <gtest/gtest.h>

#include "penumbra/scene.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::translation;

namespace {

constexpr RayKind kBounces[] = {RayKind::Diffuse, RayKind::Glossy, RayKind::Transmission};

/// A square of side 2 in the XZ plane around the origin, facing +Y.
TriangleMesh square() {
  MeshData data;
  data.points = {{-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}};
  data.faceVertexCounts = {4};
  data.faceVertexIndices = {0, 1, 2, 3};
  return triangulate(data);
}

Ray downAt(float x, float z) {
  Ray ray;
  ray.origin = {x, 5, z};
  ray.direction = {0, -1, 0};
  ray.tFar = kInfinity;
  return ray;
}

/// Whether a ray of `kind` sees a placement shown as `pass`, by the masks alone.
bool masksMeet(RayKind kind, const PassVisibility& pass) {
  return (ray_mask::ofRay(kind) & ray_mask::ofPlacement(pass)) != 0;
}

/// `PassVisibility` with one ray kind (by member) turned off.
PassVisibility hiding(bool PassVisibility::* member) {
  PassVisibility pass;
  pass.*member = false;
  return pass;
}

}  // namespace

TEST(RayVisibility, EachRayKindHasItsOwnBit) {
  const unsigned bits[] = {ray_mask::kCamera,  ray_mask::kAny,    ray_mask::kShadow,
                           ray_mask::kDiffuse, ray_mask::kGlossy, ray_mask::kTransmission};
  unsigned all = 0;
  for (const unsigned bit : bits) {
    EXPECT_EQ(all & bit, 0u);
    all |= bit;
  }
  EXPECT_EQ(ray_mask::ofPlacement(PassVisibility{}), all);
}

TEST(RayVisibility, MasksHideAnObjectFromExactlyTheRaysItSays) {
  const PassVisibility shown;
  for (const RayKind kind : {RayKind::Camera, RayKind::Secondary, RayKind::Diffuse, RayKind::Glossy,
                             RayKind::Transmission})
    EXPECT_TRUE(masksMeet(kind, shown));
  const PassVisibility noCamera = hiding(&PassVisibility::camera);
  EXPECT_FALSE(masksMeet(RayKind::Camera, noCamera));
  for (const RayKind kind : kBounces) EXPECT_TRUE(masksMeet(kind, noCamera));
  EXPECT_NE(ray_mask::ofPlacement(noCamera) & ray_mask::kShadow, 0u);

  const PassVisibility noShadow = hiding(&PassVisibility::shadow);
  EXPECT_EQ(ray_mask::ofPlacement(noShadow) & ray_mask::kShadow, 0u);
  for (const RayKind kind :
       {RayKind::Camera, RayKind::Diffuse, RayKind::Glossy, RayKind::Transmission})
    EXPECT_TRUE(masksMeet(kind, noShadow));

  bool PassVisibility::* const bounceMembers[] = {&PassVisibility::diffuse, &PassVisibility::glossy,
                                                  &PassVisibility::transmission};
  for (size_t hidden = 0; hidden < 3; ++hidden) {
    const PassVisibility pass = hiding(bounceMembers[hidden]);
    for (size_t kind = 0; kind < 3; ++kind)
      EXPECT_EQ(masksMeet(kBounces[kind], pass), kind != hidden) << hidden << " " << kind;
    EXPECT_TRUE(masksMeet(RayKind::Camera, pass));
    EXPECT_NE(ray_mask::ofPlacement(pass) & ray_mask::kShadow, 0u);
  }
  // Secondary rays (walks inside an object) see an object hidden from every kind of ray.
  PassVisibility none{false, false, false, false, false, false};
  EXPECT_TRUE(masksMeet(RayKind::Secondary, none));
  EXPECT_FALSE(masksMeet(RayKind::Camera, none));
}

TEST(RayVisibility, TracesPassThroughObjectsHiddenFromThem) {
  const Device device;
  Scene scene(device);
  Geometry& geometry = scene.geometry();
  const Geometry::MeshId id = geometry.addMesh();
  geometry.setMeshGeometry(id, square());
  geometry.setMeshInstance(id, translation(0, 0, 0), MaterialTable::kNoMaterial, true);
  const Geometry::InstancerId copies = geometry.addInstancer();
  geometry.setInstances(copies, id, {translation(10, 0, 0)}, true);
  scene.commit();

  const auto sees = [&](float x, RayKind kind) {
    return bool(geometry.intersect(downAt(x, 0), kind));
  };
  const auto shadowed = [&](float x) { return geometry.occluded(downAt(x, 0)); };
  for (const float x : {0.0f, 10.0f}) {
    EXPECT_TRUE(shadowed(x));
    for (const RayKind kind : kBounces) EXPECT_TRUE(sees(x, kind));
    EXPECT_TRUE(sees(x, RayKind::Camera));
  }

  // The mesh's own placement casts no shadow and is hidden from glossy rays; its copy is not.
  PassVisibility own;
  own.shadow = false;
  own.glossy = false;
  geometry.setMeshPassVisibility(id, own);
  scene.commit();
  EXPECT_FALSE(shadowed(0));
  EXPECT_FALSE(sees(0, RayKind::Glossy));
  EXPECT_TRUE(sees(0, RayKind::Camera));
  EXPECT_TRUE(sees(0, RayKind::Diffuse));
  EXPECT_TRUE(sees(0, RayKind::Transmission));
  EXPECT_TRUE(sees(0, RayKind::Secondary));
  EXPECT_TRUE(shadowed(10));
  EXPECT_TRUE(sees(10, RayKind::Glossy));

  // The copies: hidden from the camera and from diffuse rays, they still cast shadows.
  PassVisibility copied;
  copied.camera = false;
  copied.diffuse = false;
  geometry.setInstancerPassVisibility(copies, copied);
  scene.commit();
  EXPECT_FALSE(sees(10, RayKind::Camera));
  EXPECT_FALSE(sees(10, RayKind::Diffuse));
  EXPECT_TRUE(sees(10, RayKind::Glossy));
  EXPECT_TRUE(shadowed(10));
  const std::optional<GeometryHit> hit = geometry.intersect(downAt(10, 0), RayKind::Glossy);
  ASSERT_TRUE(hit);
  EXPECT_FALSE(hit->pass.diffuse);
  EXPECT_EQ(hit->instance, 0);

  geometry.setMeshPassVisibility(id, PassVisibility{});
  scene.commit();
  EXPECT_TRUE(shadowed(0));
  EXPECT_TRUE(sees(0, RayKind::Glossy));
}
