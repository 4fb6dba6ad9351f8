#include <gtest/gtest.h>

#include "penumbra/mesh.h"

using namespace penumbra;

namespace {
MeshData quadAndPentagon() {
  MeshData mesh;
  mesh.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0}, {3, 1, 0}, {2, 2, 0}};
  mesh.faceVertexCounts = {4, 5};
  mesh.faceVertexIndices = {0, 1, 2, 3, 1, 4, 5, 6, 2};
  return mesh;
}
}  // namespace

TEST(Mesh, PolygonsAreTriangulatedAsFans) {
  const TriangleMesh mesh = triangulate(quadAndPentagon());
  ASSERT_EQ(mesh.triangles.size(), 3u * 5);
  EXPECT_EQ(mesh.triangles, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 6, 1, 6, 2}));
  EXPECT_EQ(mesh.sourceFace, (std::vector<uint32_t>{0, 0, 1, 1, 1}));
  EXPECT_EQ(mesh.cornerFaceVertex[3 * 2], 4u);
}

TEST(Mesh, LeftHandedOrientationReversesWinding) {
  MeshData data = quadAndPentagon();
  data.leftHanded = true;
  const TriangleMesh mesh = triangulate(data);
  EXPECT_EQ(std::vector<uint32_t>(mesh.triangles.begin(), mesh.triangles.begin() + 3),
            (std::vector<uint32_t>{0, 2, 1}));
}

TEST(Mesh, DegeneratePolygonsAreSkipped) {
  MeshData data;
  data.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}};
  data.faceVertexCounts = {2, 3};
  data.faceVertexIndices = {0, 1, 0, 1, 2};
  EXPECT_EQ(triangulate(data).triangles.size(), 3u);
}

TEST(Mesh, InvalidTopologyIsReportedPrecisely) {
  MeshData data = quadAndPentagon();
  data.faceVertexIndices[5] = 12;
  try {
    triangulate(data);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "faceVertexIndices[5] = 12 is out of range for 7 points");
  }
  data = quadAndPentagon();
  data.faceVertexCounts = {4, 4};
  EXPECT_THROW(triangulate(data), std::invalid_argument);
  data = quadAndPentagon();
  data.displayColor = {{1, 0, 0}, {0, 1, 0}};
  data.displayColorInterpolation = Interpolation::Vertex;
  EXPECT_THROW(triangulate(data), std::invalid_argument);
  data = quadAndPentagon();
  data.points[2].y = NAN;
  EXPECT_THROW(triangulate(data), std::invalid_argument);
}

TEST(Mesh, DisplayColorFollowsItsInterpolation) {
  MeshData data = quadAndPentagon();
  data.displayColor = {{1, 0, 0}, {0, 0, 1}};
  data.displayColorInterpolation = Interpolation::Uniform;
  TriangleMesh mesh = triangulate(data);
  const auto colorAt = [&](uint32_t triangle, float u, float v) {
    return mesh.interpolate(mesh.displayColor, mesh.displayColorInterpolation, triangle, u, v);
  };
  EXPECT_EQ(colorAt(3, 0.2f, 0.2f).z, 1);
  data.displayColor.assign(7, {0, 0, 0});
  data.displayColor[2] = {1, 1, 1};
  data.displayColorInterpolation = Interpolation::Vertex;
  mesh = triangulate(data);
  // Triangle 0 is (0, 1, 2): Embree's v weights corner 2.
  EXPECT_FLOAT_EQ(colorAt(0, 0.25f, 0.5f).x, 0.5f);
  EXPECT_EQ(colorAt(0, 0, 0).x, 0);
}
