// The scene's overlay (Geometry::commit): meshes moved, shown or hidden after the scene was built
// wait in a small BVH of their own instead of rebuilding the top level, and rays meet exactly
// what they meet in a scene built afresh in the edited state.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "penumbra/mesh.h"
#include "penumbra/scene.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::translation;

namespace {

constexpr size_t kMeshes = Geometry::kOverlayThreshold + 76;
constexpr int kColumns = 34;

/// A box of side `size` with its lower corner at the origin; single-sided or not.
TriangleMesh box(float size, bool doubleSided) {
  MeshData data;
  for (int corner = 0; corner < 8; ++corner)
    data.points.push_back({corner & 4 ? size : 0, corner & 2 ? size : 0, corner & 1 ? size : 0});
  data.faceVertexCounts.assign(6, 4);
  data.faceVertexIndices = {0, 1, 3, 2, 2, 3, 7, 6, 6, 7, 5, 4, 4, 5, 1, 0, 1, 5, 7, 3, 4, 0, 2, 6};
  data.doubleSided = doubleSided;
  return triangulate(data);
}

/// What the test scenes hold: where each mesh is and whether it shows, and an instancer's copies
/// of mesh 3 in a row in front of the grid.
struct Layout {
  std::vector<MotionTransform> placements;
  std::vector<bool> visible;
  std::vector<bool> doubleSided;

  Layout() {
    for (size_t i = 0; i < kMeshes; ++i) {
      placements.push_back(translation(double(i % kColumns), 0, double(i / kColumns)));
      visible.push_back(true);
      doubleSided.push_back(i % 3 == 0);
    }
    placements.back() = translation(60, 0, 5);  // far out: it decides the scene's extent
  }
};

std::vector<MotionTransform> copiesOfMesh3() {
  std::vector<MotionTransform> copies;
  for (int k = 0; k < 5; ++k) copies.emplace_back(translation(3.0 * k, 0, -3));
  return copies;
}

/// Builds `layout` into `scene` and commits it.
void build(Scene& scene, const Layout& layout) {
  for (size_t i = 0; i < kMeshes; ++i) {
    const Geometry::MeshId id = scene.geometry().addMesh();
    scene.geometry().setMeshGeometry(id, box(0.5f + 0.04f * float(i % 7), layout.doubleSided[i]));
    scene.geometry().setMeshInstance(id, layout.placements[i], MaterialTable::kNoMaterial,
                                     layout.visible[i]);
  }
  scene.geometry().setInstances(scene.geometry().addInstancer(), 3, copiesOfMesh3(), true);
  scene.commit();
}

/// Rays straight down and slanted over the whole grid, the copies and the far mesh, at the
/// shutter's start, middle and end.
std::vector<Ray> probes() {
  std::vector<Ray> rays;
  for (float x = -1.5f; x < 62; x += 0.37f)
    for (float z = -4.5f; z < 36; z += 0.41f)
      for (const Vec3f& direction : {Vec3f{0, -1, 0}, normalize(Vec3f{0.4f, -1, 0.25f})}) {
        Ray ray;
        ray.origin = {x, 4, z};
        ray.direction = direction;
        for (const float time : {0.0f, 0.5f, 1.0f}) {
          ray.time = time;
          rays.push_back(ray);
        }
      }
  return rays;
}

/// Counts the rays whose hits (camera and secondary), hit distances or occlusion differ.
int differences(const Scene& a, const Scene& b) {
  int different = 0;
  for (const Ray& ray : probes()) {
    for (const RayKind kind : {RayKind::Camera, RayKind::Secondary}) {
      const auto hitA = a.geometry().intersect(ray, kind), hitB = b.geometry().intersect(ray, kind);
      if (bool(hitA) != bool(hitB) ||
          (hitA && (hitA->distance != hitB->distance || hitA->meshId != hitB->meshId ||
                    hitA->instance != hitB->instance || hitA->primitive != hitB->primitive ||
                    hitA->u != hitB->u || hitA->v != hitB->v)) ||
          a.geometry().hitDistance(ray, kind) != b.geometry().hitDistance(ray, kind))
        ++different;
    }
    if (a.geometry().occluded(ray) != b.geometry().occluded(ray)) ++different;
  }
  return different;
}

/// differences() from a scene built afresh from `layout`.
int differencesFromFresh(const Device& device, const Scene& scene, const Layout& layout) {
  Scene fresh(device);
  build(fresh, layout);
  return differences(scene, fresh);
}

/// Moves mesh `i` to `placement`, in the scene and in the layout it is to match.
void move(Scene& scene, Layout& layout, size_t i, const MotionTransform& placement) {
  layout.placements[i] = placement;
  scene.geometry().setMeshInstance(Geometry::MeshId(i), placement, MaterialTable::kNoMaterial,
                                   layout.visible[i]);
}

/// Hits that would differ if an edit had not reached the rays at all.
int hitsOnMesh(const Scene& scene, Geometry::MeshId mesh) {
  int hits = 0;
  for (const Ray& ray : probes())
    if (const auto hit = scene.geometry().intersect(ray, RayKind::Camera);
        hit && hit->meshId == mesh)
      ++hits;
  return hits;
}

/// A scene built from the default layout.
class Overlay : public ::testing::Test {
 protected:
  void SetUp() override { build(scene, layout); }
  /// Commits, and expects the overlay folded and the rays to meet what they meet in the layout
  /// built afresh.
  void expectFoldedAsFresh() {
    scene.commit();
    EXPECT_EQ(scene.geometry().overlaidPlacements(), 0u);
    EXPECT_EQ(differencesFromFresh(device, scene, layout), 0);
  }

  Device device;
  Layout layout;
  Scene scene{device};
};

}  // namespace

TEST_F(Overlay, EditedMeshesAreMetAsInASceneBuiltAfresh) {
  Scene& edited = scene;
  const uint64_t builtBefore = edited.geometry().topLevelBvhPrimitives();
  ASSERT_GT(hitsOnMesh(edited, kMeshes - 1), 0);  // the probes reach the far mesh

  // Moved up, moved sideways onto another mesh's row, hidden, the far one moved in (the
  // scene's extent shrinks), and mesh 3, which an instancer copies, moved.
  layout.placements[5] = translation(5, 1.5, 0);
  layout.placements[40] = translation(6.3, 0.2, 1.1);
  layout.visible[77] = false;
  layout.placements[kMeshes - 1] = translation(10, 2, 10);
  layout.placements[3] = translation(3, 0.7, 0.2);
  for (const size_t i : {size_t(5), size_t(40), size_t(77), kMeshes - 1, size_t(3)})
    edited.geometry().setMeshInstance(Geometry::MeshId(i), layout.placements[i],
                                      MaterialTable::kNoMaterial, layout.visible[i]);
  edited.commit();
  EXPECT_EQ(edited.geometry().overlaidPlacements(), 5u);
  // Only the overlay's five instances were built, not a top level over every mesh.
  EXPECT_EQ(edited.geometry().topLevelBvhPrimitives() - builtBefore, 5u);

  Scene fresh(device);
  build(fresh, layout);
  EXPECT_EQ(differences(edited, fresh), 0);
  EXPECT_EQ(edited.rayEpsilon({0.01f, 0, 0.01f}), fresh.rayEpsilon({0.01f, 0, 0.01f}));
  EXPECT_EQ(hitsOnMesh(edited, 77), 0);
  EXPECT_GT(hitsOnMesh(edited, 5), 0);

  // Moved again, and set moving across the shutter: still the overlay alone.
  move(edited, layout, 5, translation(5, 2.5, 0.3));
  move(edited, layout, 40, MotionTransform({translation(8, 1, 2), translation(8, 1, 9)}));
  edited.commit();
  EXPECT_EQ(edited.geometry().overlaidPlacements(), 5u);
  EXPECT_EQ(differencesFromFresh(device, edited, layout), 0);
}

TEST_F(Overlay, FoldsIntoTheTopLevelWhenThatIsRebuiltOrRaysAreMany) {
  move(scene, layout, 12, translation(12, 1, 0));
  scene.commit();
  ASSERT_EQ(scene.geometry().overlaidPlacements(), 1u);

  // A few samples keep the overlay; many fold it (one rebuild of the top level).
  EXPECT_FALSE(scene.geometry().prepareForSamples(100));
  EXPECT_TRUE(scene.geometry().prepareForSamples(100'000'000));
  expectFoldedAsFresh();

  // An overlaid mesh whose sidedness changes has its BVH committed again, which Embree wants its
  // instances and the top level to follow: the overlay is folded into that rebuild.
  move(scene, layout, 20, translation(20, 1, 0));
  scene.commit();
  ASSERT_EQ(scene.geometry().overlaidPlacements(), 1u);
  ASSERT_FALSE(layout.doubleSided[22]);
  layout.doubleSided[22] = true;
  scene.geometry().setMeshGeometry(22, box(0.5f + 0.04f * float(22 % 7), true));
  expectFoldedAsFresh();
}

TEST_F(Overlay, HoldsABoundedNumberOfMeshesAndForgetsRemovedOnes) {
  for (size_t i = 100; i < 100 + Geometry::kMaxOverlaid; ++i)
    move(scene, layout, i, translation(double(i % kColumns), 0.3, double(i / kColumns)));
  scene.commit();
  EXPECT_EQ(scene.geometry().overlaidPlacements(), Geometry::kMaxOverlaid);
  // One more moves top_'s own instance, and the rebuild takes the others back.
  const size_t last = 100 + Geometry::kMaxOverlaid;
  move(scene, layout, last, translation(double(last % kColumns), 0.3, double(last / kColumns)));
  expectFoldedAsFresh();

  // A mesh removed while overlaid leaves nothing behind.
  move(scene, layout, 7, translation(7, 1, 0));
  scene.commit();
  ASSERT_EQ(scene.geometry().overlaidPlacements(), 1u);
  scene.geometry().removeMesh(7);
  scene.commit();
  EXPECT_EQ(scene.geometry().overlaidPlacements(), 0u);
  EXPECT_EQ(hitsOnMesh(scene, 7), 0);
  layout.visible[7] = false;  // the fresh scene keeps ids aligned with a hidden mesh 7
  EXPECT_EQ(differencesFromFresh(device, scene, layout), 0);
}

TEST(OverlayThreshold, SmallScenesRebuildTheirTopLevel) {
  Device device;
  Scene scene(device);
  for (int i = 0; i < 10; ++i) {
    const Geometry::MeshId id = scene.geometry().addMesh();
    scene.geometry().setMeshGeometry(id, box(0.5f, false));
    scene.geometry().setMeshInstance(id, translation(i, 0, 0), MaterialTable::kNoMaterial, true);
  }
  scene.commit();
  const uint64_t before = scene.geometry().topLevelBvhPrimitives();
  scene.geometry().setMeshInstance(4, translation(4, 1, 0), MaterialTable::kNoMaterial, true);
  scene.commit();
  EXPECT_EQ(scene.geometry().overlaidPlacements(), 0u);
  EXPECT_EQ(scene.geometry().topLevelBvhPrimitives() - before, 10u);
}
