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

TEST(PrimvarName, KeyIsFnv1aOfTheName) {
  // The reference values of FNV-1a, 64 bits (Fowler, Noll and Vo's test vectors).
  EXPECT_EQ(PrimvarName("").key(), 0xcbf29ce484222325ull);
  EXPECT_EQ(PrimvarName("a").key(), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(PrimvarName("foobar").key(), 0x85944171f73967e8ull);
  EXPECT_EQ(PrimvarName(std::string("st")), PrimvarName("st"));
  EXPECT_NE(PrimvarName("st"), PrimvarName("st1"));
  EXPECT_NE(PrimvarName("st"), PrimvarName("ts"));
  EXPECT_TRUE(PrimvarName().empty());
  EXPECT_EQ(PrimvarName("tangent").str(), "tangent");
}

TEST(PrimvarName, FindsThePrimvarOfTheName) {
  std::vector<Primvar> primvars(3);
  primvars[0].name = "st";
  primvars[1].name = "s";
  primvars[2].name = "t";
  EXPECT_EQ(findPrimvar(primvars, "s"), &primvars[1]);
  EXPECT_EQ(findPrimvar(primvars, "t"), &primvars[2]);
  EXPECT_EQ(findPrimvar(primvars, "st"), &primvars[0]);
  EXPECT_EQ(findPrimvar(primvars, "ts"), nullptr);
  EXPECT_EQ(findPrimvar(primvars, ""), nullptr);
}

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

namespace {
/// A unit cube as exporters write it: 4 points of its own per face (24 points), outward quads.
MeshData splitCube() {
  const Vec3f corners[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                            {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                           {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
  MeshData mesh;
  for (const auto& face : faces) {
    mesh.faceVertexCounts.push_back(4);
    for (const int corner : face) {
      mesh.faceVertexIndices.push_back(int(mesh.points.size()));
      mesh.points.push_back(corners[corner]);
    }
  }
  return mesh;
}

bool closed(const MeshData& mesh) {
  return isClosedSurface(mesh.points, mesh.faceVertexCounts, mesh.faceVertexIndices);
}

void removeLastFace(MeshData* mesh) {
  mesh->faceVertexIndices.resize(mesh->faceVertexIndices.size() -
                                 size_t(mesh->faceVertexCounts.back()));
  mesh->faceVertexCounts.pop_back();
}
}  // namespace

TEST(Mesh, ACubeWithSplitVerticesIsClosed) {
  MeshData cube = splitCube();
  EXPECT_TRUE(closed(cube));
  EXPECT_TRUE(triangulate(cube).closed);
  // Exporters' rounding: within the weld tolerance (1e-5 of the size) the cube stays closed.
  cube.points[5].x += 2e-6f;
  EXPECT_TRUE(closed(cube));
  cube.points[5].x += 1e-3f;  // a real gap
  EXPECT_FALSE(closed(cube));
}

TEST(Mesh, ACubeMissingAFaceIsOpen) {
  MeshData cube = splitCube();
  removeLastFace(&cube);
  EXPECT_FALSE(closed(cube));
  EXPECT_FALSE(triangulate(cube).closed);
  EXPECT_FALSE(closed(quadAndPentagon()));
}

TEST(Mesh, ASubdivisionCubeWithAHoleIsOpen) {
  // holeIndices take a face's surface away: the limit surface has an opening there, with the
  // split vertices welded or not.
  MeshData cube = splitCube();
  EXPECT_FALSE(isClosedSurface(cube.points, cube.faceVertexCounts, cube.faceVertexIndices, {5}));
  std::vector<int> shared(cube.faceVertexIndices.size());
  for (size_t i = 0; i < shared.size(); ++i) {  // the same cube with its 8 corners shared
    const Vec3f& p = cube.points[size_t(cube.faceVertexIndices[i])];
    int first = 0;
    while (length(cube.points[size_t(first)] - p) > 0) ++first;
    shared[i] = first;
  }
  EXPECT_TRUE(isClosedSurface(cube.points, cube.faceVertexCounts, shared));
  EXPECT_FALSE(isClosedSurface(cube.points, cube.faceVertexCounts, shared, {2}));
  EXPECT_TRUE(isClosedSurface(cube.points, cube.faceVertexCounts, shared, {-1, 6}));  // no face
}

TEST(Mesh, ZeroAreaFacesAreIgnored) {
  MeshData cube = splitCube();
  // A triangle collapsed onto the cube's edge (0,0,0)-(1,0,0) (collinear corners, one of them
  // new) and a quad
  // collapsed to a point: their edges have no partner, yet they bound nothing.
  cube.points.push_back({0.5f, 0, 0});
  cube.faceVertexCounts.insert(cube.faceVertexCounts.end(), {3, 4});
  cube.faceVertexIndices.insert(cube.faceVertexIndices.end(),
                                {0, 3, int(cube.points.size()) - 1, 6, 6, 6, 6});
  EXPECT_TRUE(closed(cube));
  // A sliver of real area keeps its edges: the mesh is open.
  cube.points.back().y = 0.01f;
  EXPECT_FALSE(closed(cube));
}

TEST(Mesh, SolidsTouchingAlongAnEdgeAreClosed) {
  // Two cubes sharing an edge (by index): four faces on it, two on every other edge.
  MeshData mesh;
  mesh.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1},
                 {0, 1, 1}, {2, 1, 0}, {2, 2, 0}, {1, 2, 0}, {2, 1, 1}, {2, 2, 1}, {1, 2, 1}};
  mesh.faceVertexCounts.assign(12, 4);
  mesh.faceVertexIndices = {0, 3, 2,  1, 4, 5,  6,  7,  0, 1,  5,  4,  2, 3,  7,  6,
                            1, 2, 6,  5, 0, 4,  7,  3,  2, 10, 9,  8,  6, 11, 12, 13,
                            2, 8, 11, 6, 9, 10, 13, 12, 8, 9,  12, 11, 2, 6,  13, 10};
  EXPECT_TRUE(closed(mesh));
  // An inner wall (three faces on its edges) does not bound a solid.
  MeshData walled = splitCube();
  walled.points.insert(walled.points.end(),
                       {{0.5f, 0, 0}, {0.5f, 1, 0}, {0.5f, 1, 1}, {0.5f, 0, 1}});
  walled.faceVertexCounts.push_back(4);
  walled.faceVertexIndices.insert(walled.faceVertexIndices.end(), {24, 25, 26, 27});
  EXPECT_FALSE(closed(walled));
}

TEST(Mesh, WeldingKeepsTheFirstPointOfEachGroup) {
  const std::vector<Vec3f> points = {{0, 0, 0}, {1, 0, 0}, {0, 0, 0}, {1, 0, 1e-7f}, {0, 1, 0}};
  EXPECT_EQ(weldPoints(points, 1e-5f), (std::vector<int>{0, 1, 0, 1, 4}));
  EXPECT_EQ(weldPoints(points, 0), (std::vector<int>{0, 1, 0, 3, 4}));
}
