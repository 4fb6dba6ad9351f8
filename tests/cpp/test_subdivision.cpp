// Subdivision surfaces: limit positions against an independent Catmull-Clark / Loop
// implementation, tags (creases, corners, holes, boundaries), primvars, winding, tessellation
// error bounds and input validation.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>

#include "penumbra/subdivision.h"

namespace penumbra {
namespace {

// A 2-unit cube centred at the origin, faces counter-clockwise seen from outside:
// -z, +z, -y, +y, -x, +x.
MeshData cube() {
  MeshData mesh;
  mesh.points = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                 {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
  mesh.faceVertexCounts = {4, 4, 4, 4, 4, 4};
  mesh.faceVertexIndices = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 3, 7, 6, 2, 0, 4, 7, 3, 1, 2, 6, 5};
  return mesh;
}
constexpr int kTopFace = 1;    // +z: 4 5 6 7
constexpr int kRightFace = 5;  // +x: 1 2 6 5

MeshData octahedron() {
  MeshData mesh;
  mesh.points = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  mesh.faceVertexCounts.assign(8, 3);
  mesh.faceVertexIndices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return mesh;
}

// A prism over a regular pentagon: two pentagons and five quads, closed.
MeshData pentagonalPrism() {
  MeshData mesh;
  for (float z : {-1.0f, 1.0f})
    for (int i = 0; i < 5; ++i) {
      const float angle = 2 * kPi * float(i) / 5;
      mesh.points.push_back({std::cos(angle), std::sin(angle), z});
    }
  mesh.faceVertexCounts = {5, 5, 4, 4, 4, 4, 4};
  mesh.faceVertexIndices = {4, 3, 2, 1, 0, 5, 6, 7, 8, 9};
  for (int i = 0; i < 5; ++i) {
    const int next = (i + 1) % 5;
    for (int index : {i, next, next + 5, i + 5}) mesh.faceVertexIndices.push_back(index);
  }
  return mesh;
}

// ---- An independent Catmull-Clark: one refinement step of a closed manifold polygon mesh, and
// the limit-point mask of an all-quad mesh (Halstead et al. 1993), in double precision.
using Point = std::array<double, 3>;
struct PolygonMesh {
  std::vector<Point> points;
  std::vector<std::vector<int>> faces;
};

Point add(Point a, const Point& b, double weight = 1.0) {
  for (int i = 0; i < 3; ++i) a[i] += weight * b[i];
  return a;
}
Point scale(Point a, double s) {
  for (double& x : a) x *= s;
  return a;
}

PolygonMesh toPolygonMesh(const MeshData& mesh) {
  PolygonMesh result;
  for (const Vec3f& p : mesh.points) result.points.push_back({p.x, p.y, p.z});
  size_t start = 0;
  for (int count : mesh.faceVertexCounts) {
    result.faces.emplace_back(mesh.faceVertexIndices.begin() + long(start),
                              mesh.faceVertexIndices.begin() + long(start + size_t(count)));
    start += size_t(count);
  }
  return result;
}

PolygonMesh catmullClarkStep(const PolygonMesh& mesh) {
  const size_t vertexCount = mesh.points.size(), faceCount = mesh.faces.size();
  std::map<std::pair<int, int>, int> edgeIndex;
  std::vector<std::pair<int, int>> edges;
  std::vector<std::vector<int>> edgeFaces;
  auto edgeOf = [&](int a, int b) {
    const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
    auto [it, inserted] = edgeIndex.emplace(key, int(edges.size()));
    if (inserted) {
      edges.push_back(key);
      edgeFaces.emplace_back();
    }
    return it->second;
  };
  std::vector<Point> facePoints(faceCount);
  for (size_t f = 0; f < faceCount; ++f) {
    const std::vector<int>& face = mesh.faces[f];
    Point sum{};
    for (size_t k = 0; k < face.size(); ++k) {
      sum = add(sum, mesh.points[size_t(face[k])]);
      edgeFaces[size_t(edgeOf(face[k], face[(k + 1) % face.size()]))].push_back(int(f));
    }
    facePoints[f] = scale(sum, 1.0 / double(face.size()));
  }
  std::vector<Point> edgePoints(edges.size());
  std::vector<Point> faceSum(vertexCount), midpointSum(vertexCount);
  std::vector<int> valence(vertexCount, 0), faceValence(vertexCount, 0);
  for (size_t e = 0; e < edges.size(); ++e) {
    const Point& a = mesh.points[size_t(edges[e].first)];
    const Point& b = mesh.points[size_t(edges[e].second)];
    Point sum = add(a, b);
    for (int f : edgeFaces[e]) sum = add(sum, facePoints[size_t(f)]);
    edgePoints[e] = scale(sum, 0.25);
    for (int v : {edges[e].first, edges[e].second}) {
      midpointSum[size_t(v)] = add(midpointSum[size_t(v)], scale(add(a, b), 0.5));
      ++valence[size_t(v)];
    }
  }
  for (size_t f = 0; f < faceCount; ++f)
    for (int v : mesh.faces[f]) {
      faceSum[size_t(v)] = add(faceSum[size_t(v)], facePoints[f]);
      ++faceValence[size_t(v)];
    }
  PolygonMesh refined;
  for (size_t v = 0; v < vertexCount; ++v) {
    const double n = valence[v];
    const Point q = scale(faceSum[v], 1.0 / faceValence[v]);
    const Point r = scale(midpointSum[v], 1.0 / n);
    refined.points.push_back(scale(add(add(q, r, 2.0), mesh.points[v], n - 3.0), 1.0 / n));
  }
  const int firstEdgePoint = int(refined.points.size());
  refined.points.insert(refined.points.end(), edgePoints.begin(), edgePoints.end());
  const int firstFacePoint = int(refined.points.size());
  refined.points.insert(refined.points.end(), facePoints.begin(), facePoints.end());
  for (size_t f = 0; f < faceCount; ++f) {
    const std::vector<int>& face = mesh.faces[f];
    const size_t n = face.size();
    for (size_t k = 0; k < n; ++k)
      refined.faces.push_back({face[k], firstEdgePoint + edgeOf(face[k], face[(k + 1) % n]),
                               firstFacePoint + int(f),
                               firstEdgePoint + edgeOf(face[(k + n - 1) % n], face[k])});
  }
  return refined;
}

// Limit positions of every vertex of a closed all-quad mesh: (n^2 v + 4 sum(edge neighbours) +
// sum(diagonal neighbours)) / (n (n + 5)).
std::vector<Point> catmullClarkLimitPoints(const PolygonMesh& mesh) {
  std::vector<Point> weighted(mesh.points.size());
  std::vector<int> valence(mesh.points.size(), 0);
  for (const std::vector<int>& face : mesh.faces)
    for (size_t k = 0; k < 4; ++k) {
      const size_t v = size_t(face[k]);
      weighted[v] = add(weighted[v], mesh.points[size_t(face[(k + 1) % 4])], 4.0);
      weighted[v] = add(weighted[v], mesh.points[size_t(face[(k + 2) % 4])], 1.0);
      ++valence[v];
    }
  std::vector<Point> limit;
  for (size_t v = 0; v < mesh.points.size(); ++v) {
    const double n = valence[v];
    limit.push_back(scale(add(weighted[v], mesh.points[v], n * n), 1.0 / (n * (n + 5))));
  }
  return limit;
}

double distance(const Point& a, const Vec3f& b) {
  return std::sqrt((a[0] - b.x) * (a[0] - b.x) + (a[1] - b.y) * (a[1] - b.y) +
                   (a[2] - b.z) * (a[2] - b.z));
}

double nearestDistance(const Point& point, const std::vector<Vec3f>& points) {
  double best = INFINITY;
  for (const Vec3f& p : points) best = std::min(best, distance(point, p));
  return best;
}

float angleDegrees(const Vec3f& a, const Vec3f& b) {
  return std::acos(std::clamp(dot(normalize(a), normalize(b)), -1.0f, 1.0f)) * 180.0f / kPi;
}

// Each triangle edge of a closed surface is used by exactly two triangles, by position: points
// duplicated along sharp creases must coincide exactly.
void expectWatertight(const TriangleMesh& mesh) {
  using Position = std::array<float, 3>;
  std::map<std::pair<Position, Position>, int> uses;
  for (size_t t = 0; t < mesh.triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      const Vec3f& a = mesh.points[mesh.triangles[t + size_t(k)]];
      const Vec3f& b = mesh.points[mesh.triangles[t + size_t(k + 1) % 3]];
      const Position pa{a.x, a.y, a.z}, pb{b.x, b.y, b.z};
      ++uses[{std::min(pa, pb), std::max(pa, pb)}];
    }
  for (const auto& [edge, count] : uses)
    ASSERT_EQ(count, 2) << "edge (" << edge.first[0] << ", " << edge.first[1] << ", "
                        << edge.first[2] << ") - (" << edge.second[0] << ", " << edge.second[1]
                        << ", " << edge.second[2] << ")";
}

// Every triangle's winding agrees with the shading normals at its corners.
void expectWindingMatchesNormals(const TriangleMesh& mesh) {
  for (size_t t = 0; t < mesh.triangles.size(); t += 3) {
    const Vec3f& a = mesh.points[mesh.triangles[t]];
    const Vec3f& b = mesh.points[mesh.triangles[t + 1]];
    const Vec3f& c = mesh.points[mesh.triangles[t + 2]];
    const Vec3f normalSum = mesh.normals[mesh.triangles[t]] + mesh.normals[mesh.triangles[t + 1]] +
                            mesh.normals[mesh.triangles[t + 2]];
    ASSERT_GT(dot(cross(b - a, c - a), normalSum), 0.0f) << "triangle " << t / 3;
  }
}

void expectInvalid(const std::function<void()>& call, const std::string& fragment) {
  try {
    call();
    ADD_FAILURE() << "no exception; expected one mentioning \"" << fragment << "\"";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos)
        << "message \"" << error.what() << "\" does not mention \"" << fragment << "\"";
  }
}

TEST(Subdivision, ParsesSchemeTokens) {
  EXPECT_EQ(parseSubdivisionScheme("catmullClark"), SubdivisionScheme::CatmullClark);
  EXPECT_EQ(parseSubdivisionScheme("loop"), SubdivisionScheme::Loop);
  EXPECT_EQ(parseSubdivisionScheme("bilinear"), SubdivisionScheme::Bilinear);
  EXPECT_EQ(parseSubdivisionScheme("none"), std::nullopt);
  expectInvalid([] { parseSubdivisionScheme("catmark"); }, "catmark");
}

TEST(Subdivision, CubeFaceCentreMatchesIndependentLimitMask) {
  // The +z face's centre is the face point of one refinement; its limit mask gives the
  // known 0.8395 (= (16 + 16 * 0.75 + 4 * 5/9) / 36).
  const PolygonMesh once = catmullClarkStep(toPolygonMesh(cube()));
  const std::vector<Point> limit = catmullClarkLimitPoints(once);
  const Point& faceCentre = limit[8 + 12 + kTopFace];  // vertex, then edge, then face points
  EXPECT_NEAR(faceCentre[2], 0.83951, 1e-5);
  EXPECT_NEAR(faceCentre[0], 0.0, 1e-12);

  const std::vector<LimitSample> sample =
      LimitSurfaceTessellator(cube(), SubdivisionScheme::CatmullClark, {})
          .evaluate(cube().points, kTopFace, {{0.5f, 0.5f}});
  EXPECT_NEAR(sample[0].position.z, faceCentre[2], 1e-6);
  EXPECT_NEAR(sample[0].normal.z, 1.0f, 1e-6);

  const TriangleMesh mesh =
      tessellateLimitSurface(cube(), SubdivisionScheme::CatmullClark, {}, {2});
  EXPECT_LT(nearestDistance(faceCentre, mesh.points), 1e-6);
}

TEST(Subdivision, CubeTessellationLiesOnIndependentLimitPoints) {
  // At rate 4 the tessellation vertices are exactly the limit points of two refinements.
  const std::vector<Point> reference =
      catmullClarkLimitPoints(catmullClarkStep(catmullClarkStep(toPolygonMesh(cube()))));
  const TriangleMesh mesh =
      tessellateLimitSurface(cube(), SubdivisionScheme::CatmullClark, {}, {4});
  ASSERT_EQ(mesh.points.size(), reference.size());  // 8 + 12 * 3 + 6 * 9, shared
  double worst = 0;
  for (const Point& point : reference) worst = std::max(worst, nearestDistance(point, mesh.points));
  EXPECT_LT(worst, 2e-6);

  ASSERT_EQ(mesh.normals.size(), mesh.points.size());
  EXPECT_EQ(mesh.triangles.size(), 6u * 16 * 2 * 3);
  for (size_t i = 0; i < mesh.points.size(); ++i) {
    const Vec3f& p = mesh.points[i];
    EXPECT_LE(maxComponent({std::abs(p.x), std::abs(p.y), std::abs(p.z)}), 1.0f);
    EXPECT_NEAR(length(mesh.normals[i]), 1.0f, 1e-5f);
    EXPECT_GT(dot(mesh.normals[i], normalize(p)), 0.5f) << "normal " << i << " points inward";
  }
  for (size_t t = 0; t < mesh.sourceFace.size(); ++t) ASSERT_LT(mesh.sourceFace[t], 6u);
  expectWatertight(mesh);
  expectWindingMatchesNormals(mesh);
}

TEST(Subdivision, TessellationErrorStaysWithinToleranceOfRate) {
  const MeshData cage = cube();
  const LimitSurfaceTessellator tessellator(cage, SubdivisionScheme::CatmullClark, {});
  const std::vector<float> bounds = tessellator.curvatureBounds(cage.points);
  ASSERT_EQ(bounds.size(), 6u);
  for (float bound : bounds) EXPECT_GT(bound, 0.0f);

  // The surface, densely: the distance to it is that to the nearest dense point's tangent plane.
  const TriangleMesh dense = tessellator.tessellate(cage.points, {48});
  constexpr float kCell = 0.1f;  // > dense spacing + the largest tolerance tried
  auto cellOf = [](const Vec3f& p) {
    return std::array<int, 3>{int(std::floor(p.x / kCell)), int(std::floor(p.y / kCell)),
                              int(std::floor(p.z / kCell))};
  };
  std::map<std::array<int, 3>, std::vector<size_t>> cells;
  for (size_t i = 0; i < dense.points.size(); ++i) cells[cellOf(dense.points[i])].push_back(i);
  auto surfaceDistance = [&](const Vec3f& p) {
    const std::array<int, 3> centre = cellOf(p);
    size_t nearest = 0;
    float best = INFINITY;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto cell = cells.find({centre[0] + dx, centre[1] + dy, centre[2] + dz});
          if (cell == cells.end()) continue;
          for (size_t i : cell->second) {
            const Vec3f d = dense.points[i] - p;
            if (dot(d, d) < best) best = dot(d, d), nearest = i;
          }
        }
    return std::abs(dot(dense.normals[nearest], p - dense.points[nearest]));
  };
  auto maxError = [&](const TriangleMesh& mesh) {
    float worst = 0;
    for (size_t t = 0; t < mesh.triangles.size(); t += 3) {
      const Vec3f a = mesh.points[mesh.triangles[t]], b = mesh.points[mesh.triangles[t + 1]],
                  c = mesh.points[mesh.triangles[t + 2]];
      for (const Vec3f& p : {(a + b + c) / 3.0f, (a + b) * 0.5f, (b + c) * 0.5f, (c + a) * 0.5f})
        worst = std::max(worst, surfaceDistance(p));
    }
    return worst;
  };

  int previousRate = 0;
  for (float tolerance : {0.05f, 0.01f, 0.002f}) {
    std::vector<int> rates;
    for (float bound : bounds) rates.push_back(tessellationRateFor(bound, tolerance));
    EXPECT_GT(rates[0], previousRate) << "tolerance " << tolerance;
    previousRate = rates[0];
    const float error = maxError(tessellator.tessellate(cage.points, rates));
    EXPECT_LE(error, tolerance) << "rate " << rates[0];
    EXPECT_GT(error, tolerance / 20) << "rate " << rates[0] << " is needlessly fine";
  }
  EXPECT_EQ(tessellationRateFor(1e9f, 1e-6f), kMaxTessellationRate);
  EXPECT_EQ(tessellationRateFor(0.0f, 1e-3f), 1);
  expectInvalid([] { tessellationRateFor(1.0f, 0.0f); }, "tolerance");
}

// The limit normal on both sides of the cube's edge 5-6 (between +z and +x), at the edge's
// midpoint and `inset` (face parameter units) away from it.
std::pair<float, float> normalAnglesAcrossEdge(const SubdivisionTags& tags, float inset) {
  const MeshData cage = cube();
  const LimitSurfaceTessellator tessellator(cage, SubdivisionScheme::CatmullClark, tags);
  // Edge 5 -> 6 is edge 1 of the +z face (u = 1) and edge 2 of the +x face (v = 1).
  const auto top = tessellator.evaluate(cage.points, kTopFace, {{1, 0.5f}, {1 - inset, 0.5f}});
  const auto side = tessellator.evaluate(cage.points, kRightFace, {{0.5f, 1}, {0.5f, 1 - inset}});
  EXPECT_LT(length(top[0].position - side[0].position), 1e-5f);
  return {angleDegrees(top[0].normal, side[0].normal), angleDegrees(top[1].normal, side[1].normal)};
}

TEST(Subdivision, CreasesKeepSharpEdges) {
  SubdivisionTags sharp;
  sharp.creaseIndices = {5, 6};
  sharp.creaseLengths = {2};
  sharp.creaseSharpnesses = {10};
  SubdivisionTags semiSharp = sharp;
  semiSharp.creaseSharpnesses = {1.5f};

  const auto [smoothAtEdge, smoothNearEdge] = normalAnglesAcrossEdge({}, 0.1f);
  const auto [sharpAtEdge, sharpNearEdge] = normalAnglesAcrossEdge(sharp, 0.1f);
  const auto [semiAtEdge, semiNearEdge] = normalAnglesAcrossEdge(semiSharp, 0.1f);
  EXPECT_LT(smoothAtEdge, 0.01f);
  EXPECT_GT(sharpAtEdge, 45.0f);                   // a true crease: the normal jumps
  EXPECT_LT(semiAtEdge, 0.01f);                    // a semi-sharp crease is smooth at the limit ...
  EXPECT_GT(semiNearEdge, smoothNearEdge + 5.0f);  // ... but bends much faster than no crease
  EXPECT_LT(semiNearEdge, sharpNearEdge - 5.0f);

  // In the tessellation the crease points are kept per face, each with its side's normal.
  const TriangleMesh creased =
      tessellateLimitSurface(cube(), SubdivisionScheme::CatmullClark, sharp, {4});
  float largestJump = 0;
  for (size_t i = 0; i < creased.points.size(); ++i)
    for (size_t j = i + 1; j < creased.points.size(); ++j)
      if (length(creased.points[i] - creased.points[j]) == 0.0f)
        largestJump = std::max(largestJump, angleDegrees(creased.normals[i], creased.normals[j]));
  EXPECT_GT(largestJump, 45.0f);
  expectWatertight(creased);  // duplicated points still close the surface by position
  // The crease's 3 inner points get a second copy, its end vertices one per face (3 each).
  EXPECT_EQ(creased.points.size(), 98u + 3u + 2u * 2u);
}

TEST(Subdivision, CornersPullTheSurfaceToTheCageVertex) {
  const Point corner{1, 1, 1};
  auto distanceToCorner = [&](float sharpness) {
    SubdivisionTags tags;
    tags.cornerIndices = {6};
    tags.cornerSharpnesses = {sharpness};
    return nearestDistance(
        corner, tessellateLimitSurface(cube(), SubdivisionScheme::CatmullClark, tags, {4}).points);
  };
  const double smooth = distanceToCorner(0), semi = distanceToCorner(1.5f),
               sharp = distanceToCorner(10);
  EXPECT_LT(sharp, 1e-6);
  EXPECT_GT(smooth, 0.5);
  EXPECT_LT(semi, smooth - 0.1);
  EXPECT_GT(semi, 0.05);
}

TEST(Subdivision, HoleIndicesRemoveFaces) {
  SubdivisionTags tags;
  tags.holeIndices = {kTopFace};
  const TriangleMesh mesh =
      tessellateLimitSurface(cube(), SubdivisionScheme::CatmullClark, tags, {4});
  EXPECT_EQ(mesh.sourceFace.size(), 5u * 16 * 2);
  for (uint32_t face : mesh.sourceFace) EXPECT_NE(face, uint32_t(kTopFace));
  // The other faces keep the closed cube's limit surface (a hole is not a boundary).
  const TriangleMesh closed =
      tessellateLimitSurface(cube(), SubdivisionScheme::CatmullClark, {}, {4});
  for (const Vec3f& p : mesh.points)
    EXPECT_LT(nearestDistance({p.x, p.y, p.z}, closed.points), 1e-6);
}

TEST(Subdivision, InterpolateBoundaryDecidesBoundaryFacesAndCorners) {
  // A flat 3x3 grid of quads over [0,3]^2.
  MeshData grid;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) grid.points.push_back({float(x), float(y), 0});
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 3; ++x) {
      grid.faceVertexCounts.push_back(4);
      for (int index : {4 * y + x, 4 * y + x + 1, 4 * y + x + 5, 4 * y + x + 4})
        grid.faceVertexIndices.push_back(index);
    }
  SubdivisionTags tags;
  tags.interpolateBoundary = "none";
  const TriangleMesh inner =
      tessellateLimitSurface(grid, SubdivisionScheme::CatmullClark, tags, {2});
  ASSERT_FALSE(inner.sourceFace.empty());
  for (uint32_t face : inner.sourceFace) EXPECT_EQ(face, 4u);  // only the centre face

  tags.interpolateBoundary = "edgeAndCorner";
  const TriangleMesh withCorners =
      tessellateLimitSurface(grid, SubdivisionScheme::CatmullClark, tags, {2});
  EXPECT_EQ(withCorners.sourceFace.size(), 9u * 8);
  EXPECT_LT(nearestDistance({0, 0, 0}, withCorners.points), 1e-6);
  for (const Vec3f& normal : withCorners.normals) EXPECT_NEAR(normal.z, 1.0f, 1e-5f);

  tags.interpolateBoundary = "edgeOnly";
  EXPECT_GT(nearestDistance(
                {0, 0, 0},
                tessellateLimitSurface(grid, SubdivisionScheme::CatmullClark, tags, {2}).points),
            0.1);
}

TEST(Subdivision, LoopOctahedronMatchesLoopLimitMask) {
  // Loop's limit mask: (w v + sum of neighbours) / (w + n), w = 3 / (8 beta),
  // beta = (5/8 - (3/8 + cos(2 pi / n) / 4)^2) / n. Each octahedron vertex has n = 4 neighbours
  // summing to zero, so the limit of (0, 0, 1) is (0, 0, w / (w + 4)).
  const double n = 4, c = 3.0 / 8 + std::cos(2 * M_PI / n) / 4;
  const double beta = (5.0 / 8 - c * c) / n, w = 3.0 / (8 * beta);
  const double expected = w / (w + n);
  EXPECT_NEAR(expected, 0.43636, 1e-5);

  const TriangleMesh mesh = tessellateLimitSurface(octahedron(), SubdivisionScheme::Loop, {}, {6});
  EXPECT_LT(nearestDistance({0, 0, expected}, mesh.points), 1e-5);
  for (size_t i = 0; i < mesh.points.size(); ++i) {
    const Vec3f& p = mesh.points[i];
    EXPECT_LE(std::abs(p.x) + std::abs(p.y) + std::abs(p.z), 1.0f + 1e-6f);  // inside the cage
    EXPECT_GE(std::abs(p.x) + std::abs(p.y) + std::abs(p.z), expected - 1e-4);
    EXPECT_GT(dot(mesh.normals[i], normalize(p)), 0.7f);
  }
  EXPECT_EQ(mesh.triangles.size(), 8u * 36 * 3);  // 6^2 triangles per base triangle
  expectWatertight(mesh);
  expectWindingMatchesNormals(mesh);
}

TEST(Subdivision, LoopTetrahedronIsSymmetricAndClosed) {
  MeshData tetrahedron;
  tetrahedron.points = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  tetrahedron.faceVertexCounts = {3, 3, 3, 3};
  tetrahedron.faceVertexIndices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  const TriangleMesh mesh = tessellateLimitSurface(tetrahedron, SubdivisionScheme::Loop, {}, {4});
  // By symmetry the four corner limit points lie at equal distances from the centre.
  float nearest = INFINITY, farthest = 0;
  for (const Vec3f& p : mesh.points) farthest = std::max(farthest, length(p));
  for (const Vec3f& corner : tetrahedron.points) {
    float best = INFINITY;
    for (const Vec3f& p : mesh.points)
      best = std::min(best, length(p - corner * (farthest / length(corner))));
    nearest = std::min(nearest, best);
    EXPECT_LT(best, 1e-5f);
  }
  EXPECT_LT(farthest, std::sqrt(3.0f));
  expectWatertight(mesh);
  expectWindingMatchesNormals(mesh);
}

TEST(Subdivision, BilinearReproducesPlanarCageFaces) {
  const TriangleMesh mesh = tessellateLimitSurface(cube(), SubdivisionScheme::Bilinear, {}, {3});
  for (size_t i = 0; i < mesh.points.size(); ++i) {
    const Vec3f& p = mesh.points[i];
    EXPECT_NEAR(maxComponent({std::abs(p.x), std::abs(p.y), std::abs(p.z)}), 1.0f, 1e-6f);
    EXPECT_NEAR(maxComponent(mesh.normals[i] * mesh.normals[i]), 1.0f, 1e-6f);  // axis aligned
  }
  for (size_t t = 0; t < mesh.triangles.size(); t += 3) {
    const Vec3f& normal = mesh.normals[mesh.triangles[t]];
    for (int k = 1; k < 3; ++k) EXPECT_EQ(mesh.normals[mesh.triangles[t + size_t(k)]].x, normal.x);
  }
  expectWatertight(mesh);
  expectWindingMatchesNormals(mesh);
}

TEST(Subdivision, PolygonsOtherThanQuadsAreDicedAsSubFaces) {
  const MeshData cage = pentagonalPrism();
  const TriangleMesh mesh = tessellateLimitSurface(cage, SubdivisionScheme::CatmullClark, {}, {3});
  expectWatertight(mesh);
  expectWindingMatchesNormals(mesh);
  // The pentagon's centre: an even rate puts a vertex there; compare with the limit mask of the
  // face point after one independent refinement.
  const std::vector<Point> limit = catmullClarkLimitPoints(catmullClarkStep(toPolygonMesh(cage)));
  const Point& topCentre = limit[10 + 15 + 1];
  EXPECT_LT(nearestDistance(topCentre, mesh.points), 1e-5);
  for (const Vec3f& p : mesh.points) EXPECT_LE(std::hypot(p.x, p.y), 1.0f + 1e-6f);
}

TEST(Subdivision, FaceVaryingColourIsContinuousWhereCageValuesAgree) {
  MeshData cage = cube();
  cage.displayColorInterpolation = Interpolation::FaceVarying;
  for (int index : cage.faceVertexIndices) {
    const Vec3f& p = cage.points[size_t(index)];
    cage.displayColor.push_back((p + Vec3f(1)) * 0.5f);
  }
  // Colour per output point, from every triangle corner that uses it.
  auto discontinuities = [](const TriangleMesh& mesh) {
    std::vector<Vec3f> colourOfPoint(mesh.points.size(), Vec3f(-1));
    std::vector<uint8_t> seam(mesh.points.size(), 0);
    for (size_t corner = 0; corner < mesh.triangles.size(); ++corner) {
      const Vec3f& colour = mesh.displayColor[mesh.cornerFaceVertex[corner]];
      Vec3f& seen = colourOfPoint[mesh.triangles[corner]];
      if (seen.x < 0)
        seen = colour;
      else if (length(seen - colour) > 1e-5f)
        seam[mesh.triangles[corner]] = 1;
    }
    return seam;
  };
  const TriangleMesh smooth =
      tessellateLimitSurface(cage, SubdivisionScheme::CatmullClark, {}, {4});
  ASSERT_EQ(smooth.displayColorInterpolation, Interpolation::FaceVarying);
  for (uint32_t slot : smooth.cornerFaceVertex) ASSERT_LT(slot, smooth.displayColor.size());
  for (uint8_t seam : discontinuities(smooth)) EXPECT_EQ(seam, 0);

  // A different colour on the +z face's corners: a seam along that face's border only.
  for (size_t k = 4; k < 8; ++k) cage.displayColor[k] = Vec3f(0.25f, 0.5f, 0.75f);
  const TriangleMesh seamed =
      tessellateLimitSurface(cage, SubdivisionScheme::CatmullClark, {}, {4});
  const std::vector<uint8_t> seams = discontinuities(seamed);
  int seamPoints = 0;
  for (size_t i = 0; i < seams.size(); ++i)
    if (seams[i]) {
      ++seamPoints;
      EXPECT_GT(seamed.points[i].z, 0.49f);  // the limit of the cube's corners lies at 0.5
    }
  EXPECT_EQ(seamPoints, 4 * 4);  // the 16 points on the +z face's border

  // faceVaryingLinearInterpolation "all": bilinear within each face.
  SubdivisionTags linear;
  linear.faceVaryingLinearInterpolation = "all";
  cage = cube();
  cage.displayColorInterpolation = Interpolation::FaceVarying;
  for (int index : cage.faceVertexIndices) cage.displayColor.push_back(Vec3f(float(index)));
  const TriangleMesh bilinear =
      tessellateLimitSurface(cage, SubdivisionScheme::CatmullClark, linear, {2});
  bool sawCentre = false;
  for (size_t corner = 0; corner < bilinear.triangles.size(); ++corner) {
    const Vec3f& p = bilinear.points[bilinear.triangles[corner]];
    if (bilinear.sourceFace[corner / 3] == uint32_t(kTopFace) && std::abs(p.x) < 1e-6f &&
        std::abs(p.y) < 1e-6f) {
      EXPECT_NEAR(bilinear.displayColor[bilinear.cornerFaceVertex[corner]].x, 5.5f, 1e-5f);
      sawCentre = true;
    }
  }
  EXPECT_TRUE(sawCentre);
}

TEST(Subdivision, VertexVaryingAndUniformPrimvarsFollowTheirInterpolation) {
  MeshData cage = cube();
  cage.displayColorInterpolation = Interpolation::Vertex;
  for (const Vec3f& p : cage.points) cage.displayColor.push_back(p);
  Primvar varying{"height", {}, 1, Interpolation::Varying};
  for (const Vec3f& p : cage.points) varying.values.push_back(p.z);
  const Primvar uniform{"faceId", {0, 1, 2, 3, 4, 5}, 1, Interpolation::Uniform};
  cage.primvars = {varying, uniform};
  const LimitSurfaceTessellator tessellator(cage, SubdivisionScheme::CatmullClark, {});
  const TriangleMesh mesh = tessellator.tessellate(cage.points, {4});
  ASSERT_EQ(mesh.primvars.size(), 2u);
  ASSERT_EQ(mesh.displayColor.size(), mesh.points.size());
  EXPECT_EQ(mesh.primvars[0].name, "height");
  EXPECT_EQ(mesh.primvars[0].interpolation, Interpolation::Vertex);
  const std::vector<float>& heights = mesh.primvars[0].values;
  ASSERT_EQ(heights.size(), mesh.points.size());
  EXPECT_EQ(mesh.primvars[1].values, uniform.values);
  EXPECT_EQ(mesh.primvars[1].interpolation, Interpolation::Uniform);
  for (size_t i = 0; i < mesh.points.size(); ++i) {
    // Vertex data with the cage positions as values is the limit position itself.
    EXPECT_LT(length(mesh.displayColor[i] - mesh.points[i]), 1e-5f);
    // Varying data is interpolated linearly: the +z face's points keep height 1 exactly.
    if (mesh.points[i].z > 0.8f) {
      EXPECT_NEAR(heights[i], 1.0f, 1e-6f);
    }
  }
}

TEST(Subdivision, LeftHandedFlipsWindingAndNormals) {
  MeshData right = cube(), left = cube();
  left.leftHanded = true;
  const TriangleMesh a = tessellateLimitSurface(right, SubdivisionScheme::CatmullClark, {}, {3});
  const TriangleMesh b = tessellateLimitSurface(left, SubdivisionScheme::CatmullClark, {}, {3});
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  for (size_t t = 0; t < a.triangles.size(); t += 3) {
    EXPECT_EQ(a.triangles[t], b.triangles[t]);
    EXPECT_EQ(a.triangles[t + 1], b.triangles[t + 2]);
    EXPECT_EQ(a.triangles[t + 2], b.triangles[t + 1]);
  }
  for (size_t i = 0; i < a.normals.size(); ++i)
    EXPECT_LT(length(a.normals[i] + b.normals[i]), 1e-6f);
  expectWindingMatchesNormals(b);
}

TEST(Subdivision, MotionSamplesShareOneTopology) {
  MeshData cage = cube();
  cage.faceVertexCounts.push_back(3);  // a triangle too, so sub-faces are in play
  cage.points.push_back({0, 0, 3});
  for (int index : {4, 5, 8}) cage.faceVertexIndices.push_back(index);
  const LimitSurfaceTessellator tessellator(cage, SubdivisionScheme::CatmullClark, {});
  std::vector<Vec3f> moved = cage.points;
  for (Vec3f& p : moved) p += Vec3f(0.5f, -2, 1);
  const std::vector<int> rates = {1, 2, 3, 4, 5, 6, 7};
  const TriangleMesh a = tessellator.tessellate(cage.points, rates);
  const TriangleMesh b = tessellator.tessellate(moved, rates);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.sourceFace, b.sourceFace);
  EXPECT_EQ(a.cornerFaceVertex, b.cornerFaceVertex);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.points.size(); ++i)
    EXPECT_LT(length(b.points[i] - a.points[i] - Vec3f(0.5f, -2, 1)), 1e-5f);
  expectWindingMatchesNormals(a);
}

TEST(Subdivision, InvalidInputIsRejectedWithTheProblemNamed) {
  const auto build = [](const MeshData& cage, const SubdivisionTags& tags,
                        SubdivisionScheme scheme = SubdivisionScheme::CatmullClark) {
    return [=] { LimitSurfaceTessellator(cage, scheme, tags); };
  };
  MeshData badIndex = cube();
  badIndex.faceVertexIndices[5] = 8;
  expectInvalid(build(badIndex, {}), "faceVertexIndices[5] = 8 is out of range");
  MeshData badCount = cube();
  badCount.faceVertexCounts[0] = 5;
  expectInvalid(build(badCount, {}), "faceVertexCounts add up to 25");
  expectInvalid(build(cube(), {}, SubdivisionScheme::Loop), "loop scheme needs triangles");
  MeshData notFinite = cube();
  notFinite.points[2].y = NAN;
  expectInvalid(build(notFinite, {}), "points[2]");

  SubdivisionTags tags;
  tags.creaseIndices = {5, 6, 7};
  tags.creaseLengths = {2};
  tags.creaseSharpnesses = {1};
  expectInvalid(build(cube(), tags), "creaseLengths add up to 2 but creaseIndices has 3");
  tags.creaseLengths = {1, 2};
  expectInvalid(build(cube(), tags), "creaseLengths[0] = 1");
  tags.creaseLengths = {3};
  tags.creaseSharpnesses = {1, 2, 3};
  expectInvalid(build(cube(), tags), "creaseSharpnesses has 3 values");
  tags.creaseIndices = {5, 3};
  tags.creaseLengths = {2};
  tags.creaseSharpnesses = {1};
  expectInvalid(build(cube(), tags), "(5, 3) is not an edge");
  tags = {};
  tags.holeIndices = {6};
  expectInvalid(build(cube(), tags), "holeIndices[0] = 6 is out of range");
  tags = {};
  tags.cornerIndices = {1};
  expectInvalid(build(cube(), tags), "cornerSharpnesses has 0 values");
  tags = {};
  tags.interpolateBoundary = "edgeAndCorners";
  expectInvalid(build(cube(), tags), "interpolateBoundary \"edgeAndCorners\"");
  tags = {};
  tags.faceVaryingLinearInterpolation = "cornersPlus3";
  expectInvalid(build(cube(), tags), "faceVaryingLinearInterpolation");
  tags = {};
  tags.triangleSubdivisionRule = "loop";
  expectInvalid(build(cube(), tags), "triangleSubdivisionRule");
  MeshData badColour = cube();
  badColour.displayColor = {{1, 0, 0}, {0, 1, 0}};
  badColour.displayColorInterpolation = Interpolation::Uniform;
  expectInvalid(build(badColour, {}), "displayColor (uniform, width 3) has 6 floats, expected 18");

  const LimitSurfaceTessellator tessellator(cube(), SubdivisionScheme::CatmullClark, {});
  expectInvalid([&] { tessellator.tessellate(cube().points, {1, 2}); }, "rates has 2 entries");
  expectInvalid([&] { tessellator.tessellate(cube().points, {0}); }, "rates[0] = 0");
  expectInvalid([&] { tessellator.tessellate({{0, 0, 0}}, {1}); }, "points has 1 entries");
}

TEST(Subdivision, TagsThatDoNotFitTheCageAreLeftOutOneByOne) {
  // As Hydra's refiner factory: each stale tag is dropped with its reason, the rest is kept.
  SubdivisionTags tags;
  tags.holeIndices = {2, 6, -1};
  tags.cornerIndices = {1, 8, 3};
  tags.cornerSharpnesses = {2, 10, NAN};
  tags.creaseIndices = {4, 5, 0, 5, 2, 9};  // an edge; not an edge; a vertex out of range
  tags.creaseLengths = {2, 2, 2};
  tags.creaseSharpnesses = {2, 3, 4};
  std::vector<std::string> dropped;
  const SubdivisionTags usable = usableSubdivisionTags(cube(), tags, &dropped);
  EXPECT_EQ(usable.holeIndices, std::vector<int>{2});
  EXPECT_EQ(usable.cornerIndices, std::vector<int>{1});
  EXPECT_EQ(usable.cornerSharpnesses, std::vector<float>{2});
  EXPECT_EQ(usable.creaseIndices, (std::vector<int>{4, 5}));
  EXPECT_EQ(usable.creaseLengths, std::vector<int>{2});
  EXPECT_EQ(usable.creaseSharpnesses, std::vector<float>{2});
  const std::vector<std::string> expected = {
      "holeIndices[1] = 6 is out of range for 6 faces",
      "holeIndices[2] = -1 is out of range for 6 faces",
      "cornerIndices[1] = 8 is out of range for 8 points",
      "cornerSharpnesses[2] is not finite",
      "crease 1: (0, 5) is not an edge",
      "crease 2: creaseIndices[5] = 9 is out of range for 8 points"};
  EXPECT_EQ(dropped, expected);
  EXPECT_NO_THROW(LimitSurfaceTessellator(cube(), SubdivisionScheme::CatmullClark, usable));

  // One sharpness per edge: a kept chain keeps its own edges' values.
  tags = {};
  tags.creaseIndices = {0, 5, 4, 5, 6};
  tags.creaseLengths = {2, 3};
  tags.creaseSharpnesses = {1, 2, 3};
  dropped.clear();
  EXPECT_EQ(usableSubdivisionTags(cube(), tags, &dropped).creaseSharpnesses,
            (std::vector<float>{2, 3}));
  // Counts that do not describe the creases: every crease goes, with one reason.
  tags.creaseLengths = {2, 2};
  dropped.clear();
  EXPECT_TRUE(usableSubdivisionTags(cube(), tags, &dropped).creaseIndices.empty());
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_NE(dropped[0].find("every crease"), std::string::npos);
  // Valid tags come back as they are, with nothing said.
  dropped.clear();
  tags = {};
  tags.creaseIndices = {4, 5};
  tags.creaseLengths = {2};
  tags.creaseSharpnesses = {10};
  EXPECT_EQ(usableSubdivisionTags(cube(), tags, &dropped).creaseIndices, tags.creaseIndices);
  EXPECT_TRUE(dropped.empty());
}

}  // namespace
}  // namespace penumbra
