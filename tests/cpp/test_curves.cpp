// Curves (UsdGeomBasisCurves) as a kind of geometry: tubes and ribbons hit where the analytic
// curves of each basis and wrap are, their widths, normals and primvars interpolated as the
// schema says, their motion, and their validation.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "penumbra/curves.h"
#include "penumbra/scene.h"
#include "penumbra/surface_hit.h"
#include "transforms.h"
#include "white_furnace.h"

using namespace penumbra;
using penumbra::test::translation;

namespace {

Ray rayFrom(const Vec3f& origin, const Vec3f& direction, float time = 0) {
  Ray ray;
  ray.origin = origin;
  ray.direction = normalize(direction);
  ray.time = time;
  return ray;
}

/// Straight down (-y) from height 5 at (x, z).
Ray downAt(float x, float z, float time = 0) {
  return rayFrom({x, 5, z}, {0, -1, 0}, time);
}

/// Along -z from z = 10 at (x, y): curves drawn in the xy-plane are seen face on.
Ray intoScreenAt(float x, float y) {
  return rayFrom({x, y, 10}, {0, 0, -1});
}

/// A scene holding `curves` placed by `objectToWorld`.
struct CurvesScene {
  Device device;
  Scene scene{device};
  Geometry::MeshId id;

  explicit CurvesScene(CurvesData curves, const MotionTransform& objectToWorld = Transform()) {
    id = scene.geometry().addMesh();
    scene.geometry().setCurvesGeometry(id, std::move(curves));
    scene.geometry().setMeshInstance(id, objectToWorld, MaterialTable::kNoMaterial, true);
    scene.commit();
  }

  bool hits(const Ray& ray) const { return bool(scene.geometry().intersect(ray, RayKind::Camera)); }
  std::optional<SurfaceHit> surface(const Ray& ray) const {
    return intersectSurface(scene, ray, RayKind::Camera);
  }
};

/// One curve of constant width through `positions`.
CurvesData oneCurve(CurveType type, CurveBasis basis, CurveWrap wrap, std::vector<Vec3f> positions,
                    float width) {
  CurvesData curves;
  curves.type = type;
  curves.basis = basis;
  curves.wrap = wrap;
  curves.curveVertexCounts = {int(positions.size())};
  curves.positions = std::move(positions);
  curves.widths = {width};
  curves.widthsInterpolation = Interpolation::Constant;
  return curves;
}

/// A cubic Bézier from (-2, 0, z) to (2, 0, z) with evenly spaced control points: u = (x + 2)/4.
std::vector<Vec3f> straightBezier(float z = 0) {
  return {{-2, 0, z}, {-2.0f / 3, 0, z}, {2.0f / 3, 0, z}, {2, 0, z}};
}

/// A straight curve of constant width from (-2, 0, 0) to (2, 0, 0): linear, or one cubic Bézier
/// segment (straightBezier()).
CurvesData straightCurve(CurveType type, float width) {
  return oneCurve(
      type, CurveBasis::Bezier, CurveWrap::Nonperiodic,
      type == CurveType::Linear ? std::vector<Vec3f>{{-2, 0, 0}, {2, 0, 0}} : straightBezier(),
      width);
}

/// Expects a round tube of radius `radius` whose centre line, drawn in the xy-plane, passes
/// through `centre` along `tangent`: seen along -z it is hit at distance 10 - radius straight on,
/// within 0.95 radius of the centre line across it, and missed at 1.05 radius.
void expectTubeThrough(const CurvesScene& s, const Vec3f& centre, const Vec3f& tangent,
                       float radius) {
  SCOPED_TRACE("centre (" + std::to_string(centre.x) + ", " + std::to_string(centre.y) + ")");
  const std::optional<GeometryHit> hit =
      s.scene.geometry().intersect(intoScreenAt(centre.x, centre.y), RayKind::Camera);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 10 - radius, 2e-3f * radius + 1e-5f);
  const Vec3f across = normalize(Vec3f(-tangent.y, tangent.x, 0));
  for (const float side : {-1.0f, 1.0f}) {
    const Vec3f inside = centre + across * (side * 0.95f * radius);
    const Vec3f outside = centre + across * (side * 1.05f * radius);
    EXPECT_TRUE(s.hits(intoScreenAt(inside.x, inside.y))) << "side " << side;
    EXPECT_FALSE(s.hits(intoScreenAt(outside.x, outside.y))) << "side " << side;
  }
}

/// The message validateCurves throws for `curves` (empty: none).
std::string problemOf(const CurvesData& curves) {
  try {
    validateCurves(curves);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return {};
}

/// Primvar `name` at the hit of `ray` on `s`'s curves, `width` floats expected.
std::vector<float> primvarThere(const CurvesScene& s, const Ray& ray, const PrimvarName& name,
                                int width) {
  const std::optional<SurfaceHit> hit = s.surface(ray);
  if (!hit) {
    ADD_FAILURE() << "no hit";
    return {};
  }
  const SurfacePoint point = hit->shape->pointAt(hit->primitive, hit->u, hit->v, 0);
  float value[4];
  int found = 0;
  if (!primvarAt(point, name, value, &found)) {
    ADD_FAILURE() << "no primvar " << name.str();
    return {};
  }
  EXPECT_EQ(found, width);
  return std::vector<float>(value, value + found);
}

}  // namespace

TEST(Curves, RoundLinearTubeIsHitAtItsRadiusAndSeamlessAtJoints) {
  // Two segments along x, joined at x = 0; width 1: radius 0.5.
  CurvesScene s(oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Nonperiodic,
                         {{-2, 0, 0}, {0, 0, 0}, {2, 0.0f, 0}}, 1),
                translation(0, 1, 0));
  for (const float x : {-1.0f, 0.0f, 0.001f, 1.5f}) {
    const std::optional<SurfaceHit> hit = s.surface(downAt(x, 0));
    ASSERT_TRUE(hit) << x;
    EXPECT_NEAR(hit->distance, 5 - 1 - 0.5f, 1e-5f) << x;
    EXPECT_NEAR(hit->normal.y, 1, 1e-5f) << x;
    EXPECT_EQ(hit->shadingNormal.y, hit->normal.y);
    EXPECT_TRUE(hit->closed);
    EXPECT_NEAR(hit->fibreDirection.x, 1, 1e-6f);
    if (x != 0) {
      EXPECT_EQ(hit->primitive, x < 0 ? 0u : 1u) << x;
    }
    EXPECT_EQ(hit->shape->elementOf(hit->primitive), 0);
  }
  // Off the axis by z: the tube's surface at height sqrt(r² - z²), the normal facing the ray.
  const float z = 0.3f;
  const std::optional<SurfaceHit> off = s.surface(downAt(-1, z));
  ASSERT_TRUE(off);
  EXPECT_NEAR(off->distance, 4 - std::sqrt(0.25f - z * z), 1e-5f);
  EXPECT_NEAR(off->normal.z, z / 0.5f, 1e-4f);
  EXPECT_NEAR(off->normal.y, std::sqrt(0.25f - z * z) / 0.5f, 1e-4f);
  // The width is right: just inside the radius hits, just outside misses, at the joint too.
  for (const float x : {-1.0f, 0.0f, 1.0f}) {
    EXPECT_TRUE(s.hits(downAt(x, 0.49f))) << x;
    EXPECT_FALSE(s.hits(downAt(x, 0.51f))) << x;
    EXPECT_FALSE(s.hits(downAt(x, -0.51f))) << x;
  }
  // From the side and from below, the normal faces the ray.
  const std::optional<SurfaceHit> side = s.surface(rayFrom({-1, 1, 5}, {0, 0, -1}));
  ASSERT_TRUE(side);
  EXPECT_NEAR(side->distance, 4.5f, 1e-5f);
  EXPECT_NEAR(side->normal.z, 1, 1e-5f);
  const std::optional<SurfaceHit> below = s.surface(rayFrom({1, -3, 0}, {0, 1, 0}));
  ASSERT_TRUE(below);
  EXPECT_NEAR(below->distance, 3.5f, 1e-5f);
  EXPECT_NEAR(below->normal.y, -1, 1e-5f);
  // The ends are round: a sphere of the radius around the first vertex. (A ray parallel to the
  // axis is Embree's degenerate case; this one rises 1 in 20.)
  const Vec3f towards = normalize(Vec3f(1, 0.05f, 0));
  const Vec3f start = {-5, 0.85f, 0};
  const Vec3f fromCentre = start - Vec3f(-2, 1, 0);
  const float b = dot(fromCentre, towards);
  EXPECT_NEAR(s.scene.geometry().hitDistance(rayFrom(start, towards), RayKind::Camera),
              -b - std::sqrt(b * b - dot(fromCentre, fromCentre) + 0.25f), 1e-4f);
}

TEST(Curves, RayFromInsideATubeMeetsItsWallFacingOut) {
  for (const CurveType type : {CurveType::Linear, CurveType::Cubic}) {
    SCOPED_TRACE(type == CurveType::Linear ? "linear" : "cubic");
    CurvesScene s(straightCurve(type, 1));
    for (const Vec3f& direction : {Vec3f(0, 1, 0), Vec3f(0, -0.6f, 0.8f)}) {
      const std::optional<SurfaceHit> hit =
          intersectSurface(s.scene, rayFrom({0.5f, 0, 0}, direction), RayKind::Secondary);
      ASSERT_TRUE(hit);
      EXPECT_NEAR(hit->distance, 0.5f, 1e-4f);
      EXPECT_NEAR(dot(hit->normal, direction), 1, 1e-4f);  // outwards, as the ray goes
      EXPECT_TRUE(hit->closed);
    }
  }
}

// A hit's point lies on the tube to within the rounding of its own coordinates, however far
// the ray came from (rebuilt from the centre line and the radius at the hit's u, not as origin
// + distance · direction, which from 10^4 units was off by up to 10^-3, and shadow rays started
// inside the fibre). On a tapered tube the surface is the spheres' envelope, 1/cos of the
// cone's angle above the radius at the point's own x.
TEST(Curves, HitPointsLieOnTheTubeHoweverFarTheRayCameFrom) {
  for (const CurveType type : {CurveType::Linear, CurveType::Cubic}) {
    for (const bool tapered : {false, true}) {
      SCOPED_TRACE(std::string(type == CurveType::Linear ? "linear" : "cubic") +
                   (tapered ? ", tapered" : ""));
      CurvesData curves = straightCurve(type, 0.1f);
      // Varying widths 0.1 → 0.3: radius 0.1 + 0.025 x along the axis.
      const float slope = tapered ? 0.025f : 0;
      auto radiusAt = [&](float x) { return tapered ? 0.1f + slope * x : 0.05f; };
      if (tapered) {
        curves.widths = {0.1f, 0.3f};
        curves.widthsInterpolation = Interpolation::Varying;
      }
      CurvesScene s(std::move(curves));
      const float secant = 1 / std::sqrt(1 - slope * slope);
      for (int i = 0; i < 9; ++i)
        for (const float across : {-0.7f, 0.0f, 0.4f}) {
          const float x = float(i) / 4 - 1;
          const Vec3f target{x, 0, across * radiusAt(x)};
          const Vec3f origin = target + Vec3f{3000.0f * x + 500, 9000, 2000.0f * across - 1300};
          const std::optional<SurfaceHit> hit = s.surface(rayFrom(origin, target - origin));
          ASSERT_TRUE(hit) << x << ", " << across;
          const Vec3f& p = hit->position;
          const float fromSurface = std::sqrt(p.y * p.y + p.z * p.z) - radiusAt(p.x) * secant;
          EXPECT_LT(std::abs(fromSurface), 0.05f * s.scene.rayEpsilon(p)) << x << ", " << across;
        }
    }
  }
}

TEST(Curves, HitPointsLieOnTheRibbonHoweverFarTheRayCameFrom) {
  // Straight ribbons along x, 1 wide, facing a tilted normal: they lie in the plane through the
  // x axis across that normal. Embree gives the hit's distance along the ray, not its point;
  // from 10^4 units away that put hits either side of the ribbon by more than the spawn offset
  // (shadow acne). They are moved onto the plane the ribbon's centre line lies in at u.
  const Vec3f normal = normalize(Vec3f{0, 1, 0.3f});
  const Vec3f across = cross(Vec3f{1, 0, 0}, normal);
  for (const CurveType type : {CurveType::Linear, CurveType::Cubic}) {
    SCOPED_TRACE(type == CurveType::Linear ? "linear" : "cubic");
    CurvesData curves = straightCurve(type, 1);
    curves.normals = {normal};
    curves.normalsInterpolation = Interpolation::Constant;
    CurvesScene s(std::move(curves));
    for (int i = 0; i < 9; ++i)
      for (const float offset : {-0.4f, 0.0f, 0.3f}) {
        const float x = float(i) / 4 - 1;
        const Vec3f target = Vec3f{x, 0, 0} + across * offset;
        const Vec3f origin = target + Vec3f{3000.0f * x + 500, 9000, 2000.0f * offset - 1300};
        const std::optional<SurfaceHit> hit = s.surface(rayFrom(origin, target - origin));
        ASSERT_TRUE(hit) << x << ", " << offset;
        const Vec3f& p = hit->position;
        EXPECT_LT(std::abs(dot(p, normal)), 0.05f * s.scene.rayEpsilon(p)) << x << ", " << offset;
        // Where it was met, to the precision of a distance of 10^4 along the ray (10^-3).
        EXPECT_NEAR(dot(p, across), offset, 1e-2f) << x << ", " << offset;
      }
  }
}

TEST(Curves, ATwistedRibbonsCentreLineLiesInItsTangentPlane) {
  // What moving a ribbon's hit onto its tangent plane rests on: Embree's ribbon runs between
  // two edge curves either side of the centre line, so the centre line at u lies in the plane
  // across Ng at every v, however the ribbon bends and twists. Near the ribbon, where the ray's
  // point is exact to a few 10^-7, the move is as small.
  const std::vector<Vec3f> bent = {{-2, 0, 0}, {-0.7f, 0.6f, 0.3f}, {0.7f, -0.4f, 0.2f}, {2, 0, 0}};
  CurvesData twisted =
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, bent, 1);
  twisted.normals = {{0, 1, 0}, {0, 1, 0.3f}, {0, 1, 1}, {0, 0.6f, 1}};
  twisted.normalsInterpolation = Interpolation::Vertex;
  twisted.widths = {0.6f, 1.2f};
  twisted.widthsInterpolation = Interpolation::Varying;
  CurvesScene s(std::move(twisted));
  int hits = 0;
  for (int i = 0; i < 15; ++i)
    for (const float z : {-0.3f, 0.0f, 0.25f}) {
      const Ray ray = rayFrom({float(i) / 4 - 1.75f, 4, z + 2}, {0.05f, -1, -0.5f});
      const std::optional<SurfaceHit> hit = s.surface(ray);
      if (!hit) continue;
      ++hits;
      const Vec3f rayPoint = ray.origin + ray.direction * hit->distance;
      EXPECT_LT(length(hit->position - rayPoint), 2e-6f) << i << ", " << z;
    }
  EXPECT_GT(hits, 30);
}

TEST(Curves, NoCurvesRenderNothing) {
  CurvesScene s{CurvesData{}};
  EXPECT_FALSE(s.hits(downAt(0, 0)));
}

TEST(Curves, CubicBezierPassesThroughItsEndsAndItsMidpoint) {
  const Vec3f p[4] = {{-1, 0, 0}, {-0.5f, 1, 0}, {0.5f, 1.5f, 0}, {1, 0.5f, 0}};
  const float radius = 0.05f;
  CurvesScene s(oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic,
                         {p[0], p[1], p[2], p[3]}, 2 * radius));
  // At t = ½: (P0 + 3 P1 + 3 P2 + P3)/8, along P3 + P2 - P1 - P0.
  const Vec3f middle = (p[0] + p[1] * 3 + p[2] * 3 + p[3]) / 8;
  const Vec3f middleTangent = p[3] + p[2] - p[1] - p[0];
  expectTubeThrough(s, middle, middleTangent, radius);
  // Near its ends (a hundredth of the way in), along P1 - P0 and P3 - P2.
  expectTubeThrough(s, p[0] * 0.97f + p[1] * 0.03f, p[1] - p[0], radius);
  expectTubeThrough(s, p[3] * 0.97f + p[2] * 0.03f, p[3] - p[2], radius);
  // The fibre direction at a hit is the curve's unit tangent at its u.
  const std::optional<SurfaceHit> hit = s.surface(intoScreenAt(middle.x, middle.y));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->u, 0.5f, 1e-3f);
  const Vec3f along = normalize(middleTangent);
  EXPECT_NEAR(dot(hit->fibreDirection, along), 1, 1e-5f);
  EXPECT_NEAR(hit->normal.z, 1, 1e-3f);  // facing the ray
  EXPECT_TRUE(hit->closed);
  const std::optional<SurfaceHit> early = s.surface(intoScreenAt(-0.8f, 0.35f));
  ASSERT_TRUE(early);
  const float u = early->u, w = 1 - u;
  const Vec3f tangent =
      (p[1] - p[0]) * (w * w) + (p[2] - p[1]) * (2 * u * w) + (p[3] - p[2]) * (u * u);
  EXPECT_NEAR(dot(early->fibreDirection, normalize(tangent)), 1, 1e-5f);
}

TEST(Curves, CatmullRomPassesThroughItsInteriorVertices) {
  const std::vector<Vec3f> p = {{-2.5f, 0, 0},   {-1.5f, 1, 0},   {-0.5f, 0.5f, 0},
                                {0.5f, 1.5f, 0}, {1.5f, 0.5f, 0}, {2.5f, 1, 0}};
  const float radius = 0.04f;
  CurvesScene s(
      oneCurve(CurveType::Cubic, CurveBasis::CatmullRom, CurveWrap::Nonperiodic, p, 2 * radius));
  // Three segments from P1 to P4, through P2 and P3, with tangents (P[i+1] - P[i-1])/2.
  for (int i = 2; i <= 3; ++i) expectTubeThrough(s, p[i], p[i + 1] - p[i - 1], radius);
  // The middle segment at t = ½: (-P1 + 9 P2 + 9 P3 - P4)/16, along P1 - 11 P2 + 11 P3 - P4.
  expectTubeThrough(s, (p[2] * 9 + p[3] * 9 - p[1] - p[4]) / 16,
                    p[1] - p[2] * 11 + p[3] * 11 - p[4], radius);
  // A hundredth of a segment from its ends, it is within 1e-4 of P1 + (P2 - P0)/200 (and the
  // same at P4).
  expectTubeThrough(s, p[1] + (p[2] - p[0]) * 0.005f, p[2] - p[0], radius);
  expectTubeThrough(s, p[4] - (p[5] - p[3]) * 0.005f, p[5] - p[3], radius);
  // It does not reach the end vertices.
  EXPECT_FALSE(s.hits(intoScreenAt(p[0].x, p[0].y)));
  EXPECT_FALSE(s.hits(intoScreenAt(p[5].x, p[5].y)));
}

TEST(Curves, BSplineDoesNotPassThroughItsControlPoints) {
  const std::vector<Vec3f> p = {{-1, 0, 0}, {-0.5f, 1, 0}, {0.5f, 1, 0}, {1, 0, 0}};
  const float radius = 0.04f;
  CurvesScene s(
      oneCurve(CurveType::Cubic, CurveBasis::BSpline, CurveWrap::Nonperiodic, p, 2 * radius));
  EXPECT_FALSE(s.hits(intoScreenAt(p[1].x, p[1].y)));
  EXPECT_FALSE(s.hits(intoScreenAt(p[0].x, p[0].y)));
  // Its segment starts at (P0 + 4 P1 + P2)/6 along (P2 - P0)/2 and ends at (P1 + 4 P2 + P3)/6.
  // (A fiftieth of the way in: second-order error 2e-4.)
  expectTubeThrough(s, (p[0] + p[1] * 4 + p[2]) / 6 + (p[2] - p[0]) * 0.01f, p[2] - p[0], radius);
  expectTubeThrough(s, (p[0] + p[1] * 23 + p[2] * 23 + p[3]) / 48, {1, 0, 0}, radius);  // t = ½
}

TEST(Curves, PinnedCurvesReachTheirEndVertices) {
  const std::vector<Vec3f> p = {{-1, 0, 0}, {0, 1, 0}, {1, 0.25f, 0}};
  const float radius = 0.04f;
  for (const CurveBasis basis : {CurveBasis::BSpline, CurveBasis::CatmullRom}) {
    SCOPED_TRACE(basis == CurveBasis::BSpline ? "bspline" : "catmullRom");
    CurvesScene s(oneCurve(CurveType::Cubic, basis, CurveWrap::Pinned, p, 2 * radius));
    // The phantom vertices 2 P0 - P1 and 2 P2 - P1 make each end start along P1 - P0 (P2 - P1):
    // a hundredth of the way in, the curve is there (B-spline: no curvature at its ends).
    expectTubeThrough(s, p[0] + (p[1] - p[0]) * 0.01f, p[1] - p[0], radius);
    expectTubeThrough(s, p[2] - (p[2] - p[1]) * 0.01f, p[2] - p[1], radius);
    // The first segment's middle, P[-1] = 2 P0 - P1 substituted in the basis at t = ½.
    if (basis == CurveBasis::BSpline) {
      expectTubeThrough(s, (p[0] * 25 + p[1] * 22 + p[2]) / 48, p[1] * 6 + p[2] - p[0] * 7, radius);
    } else {
      expectTubeThrough(s, (p[0] * 7 + p[1] * 10 - p[2]) / 16, p[1] * 10 - p[2] - p[0] * 9, radius);
      expectTubeThrough(s, p[1], p[2] - p[0], radius);
    }
  }
  // Two vertices suffice: a pinned B-spline through collinear vertices is their straight line.
  CurvesScene line(oneCurve(CurveType::Cubic, CurveBasis::BSpline, CurveWrap::Pinned,
                            {{-1, 0, 0}, {1, 0, 0}}, 2 * radius));
  for (const float x : {-0.98f, 0.0f, 0.98f}) expectTubeThrough(line, {x, 0, 0}, {1, 0, 0}, radius);
  EXPECT_FALSE(line.hits(intoScreenAt(-1.1f, 0)));
}

TEST(Curves, PeriodicCurvesClose) {
  const std::vector<Vec3f> square = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  const float radius = 0.05f;
  // Linear: the closing segment from the last vertex back to the first.
  CurvesScene open(
      oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Nonperiodic, square, 2 * radius));
  CurvesScene closed(
      oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Periodic, square, 2 * radius));
  EXPECT_FALSE(open.hits(intoScreenAt(0, 1)));
  expectTubeThrough(closed, {0, 1, 0}, {0, 1, 0}, radius);
  expectTubeThrough(closed, {1, 0, 0}, {1, 0, 0}, radius);
  expectTubeThrough(closed, {0, 0.2f, 0}, {0, 1, 0}, radius);  // near the corner it closes
  // B-spline: four segments, the last one through (P3 + 4 P0 + P1)/6 along (P1 - P3)/2.
  CurvesScene spline(
      oneCurve(CurveType::Cubic, CurveBasis::BSpline, CurveWrap::Periodic, square, 2 * radius));
  expectTubeThrough(spline, (square[3] + square[0] * 4 + square[1]) / 6, square[1] - square[3],
                    radius);
  expectTubeThrough(spline, (square[1] + square[2] * 4 + square[3]) / 6, square[3] - square[1],
                    radius);
  // Bézier: six vertices, two segments, the second ending at the first vertex.
  const std::vector<Vec3f> loop = {{-1, 0, 0}, {-1, 1, 0}, {1, 1, 0},
                                   {1, 0, 0},  {1, -1, 0}, {-1, -1, 0}};
  CurvesScene bezier(
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Periodic, loop, 2 * radius));
  expectTubeThrough(bezier, {0, 0.75f, 0}, {1, 0, 0}, radius);
  expectTubeThrough(bezier, {0, -0.75f, 0}, {-1, 0, 0}, radius);
  expectTubeThrough(bezier, {-1, 0.01f, 0}, {0, 1, 0}, radius);
}

TEST(Curves, PeriodicCurvesWrapTheirVaryingData) {
  const std::vector<Vec3f> square = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  // Linear: the closing segment's width goes from the last varying value to the first.
  CurvesData linear =
      oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Periodic, square, 1);
  linear.widths = {0.1f, 0.2f, 0.2f, 0.3f};
  linear.widthsInterpolation = Interpolation::Varying;
  CurvesScene l(linear);
  expectTubeThrough(l, {0, 1, 0}, {0, 1, 0}, 0.1f);  // radius (0.15 + 0.05)/2
  // Vertex data likewise. (Of constant width: on a cone, Embree's u is where the surface normal
  // meets the axis, not level with the hit.)
  linear.widths = {0.2f};
  linear.widthsInterpolation = Interpolation::Constant;
  linear.primvars = {{"vertex", {1, 2, 3, 5}, 1, Interpolation::Vertex}};
  CurvesScene constant(linear);
  EXPECT_NEAR(primvarThere(constant, intoScreenAt(0, 1), "vertex", 1).at(0), 3, 1e-4f);
  // B-spline: four segments, four varying values; the last segment, from P3 + 4 P0 + P1 over
  // 6 to P0 + 4 P1 + P2 over 6, has them from the fourth to the first: 2.5 at its middle,
  // (1, 1/12) where it is symmetric.
  CurvesData spline =
      oneCurve(CurveType::Cubic, CurveBasis::BSpline, CurveWrap::Periodic, square, 0.1f);
  spline.primvars = {{"varying", {1, 2, 3, 4}, 1, Interpolation::Varying},
                     {"vertex", {0, 6, 12, 6}, 1, Interpolation::Vertex}};
  CurvesScene s(spline);
  const std::optional<SurfaceHit> hit = s.surface(intoScreenAt(1, 1.0f / 12));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->u, 0.5f, 1e-3f);
  EXPECT_NEAR(primvarThere(s, intoScreenAt(1, 1.0f / 12), "varying", 1).at(0), 2.5f, 1e-3f);
  // Vertex data by the basis, wrapped likewise: (6 + 23·0 + 23·6 + 12)/48 = 3.25.
  EXPECT_NEAR(primvarThere(s, intoScreenAt(1, 1.0f / 12), "vertex", 1).at(0), 3.25f, 1e-3f);
}

TEST(Curves, RibbonsFaceTheirNormalsWithTheirFullWidth) {
  // A linear ribbon along x, 1 wide, facing +y; and a cubic one along x at z = 3.
  CurvesData curves = oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Nonperiodic,
                               {{-2, 0, 0}, {2, 0, 0}}, 1);
  curves.normals = {{0, 2, 0}};  // need not be unit
  curves.normalsInterpolation = Interpolation::Constant;
  CurvesScene s(curves);
  for (const float x : {-1.5f, 0.0f, 1.0f}) {
    const std::optional<SurfaceHit> hit = s.surface(downAt(x, 0.45f));
    ASSERT_TRUE(hit) << x;
    EXPECT_NEAR(hit->distance, 5, 1e-4f);
    EXPECT_NEAR(hit->normal.y, 1, 1e-4f);
    EXPECT_FALSE(hit->closed);  // a thin sheet
    EXPECT_NEAR(hit->fibreDirection.x, 1, 1e-5f);
    EXPECT_TRUE(s.hits(downAt(x, -0.45f)));
    EXPECT_FALSE(s.hits(downAt(x, 0.55f)));
    EXPECT_FALSE(s.hits(downAt(x, -0.55f)));
  }
  // Seen from below, it is the same ribbon, its normal still the authored side's.
  const std::optional<SurfaceHit> below = s.surface(rayFrom({0.5f, -3, 0.2f}, {0, 1, 0}));
  ASSERT_TRUE(below);
  EXPECT_NEAR(below->distance, 3, 1e-4f);
  EXPECT_NEAR(below->normal.y, 1, 1e-4f);
  // Running the other way, it still faces its normal.
  std::swap(curves.positions[0], curves.positions[1]);
  CurvesScene reversed(curves);
  const std::optional<SurfaceHit> back = reversed.surface(rayFrom({0.5f, -3, 0.2f}, {0, 1, 0}));
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->normal.y, 1, 1e-4f);
  EXPECT_NEAR(back->fibreDirection.x, -1, 1e-5f);
  // Edge on, a ribbon is not there.
  EXPECT_FALSE(s.hits(rayFrom({0, 0.01f, 5}, {0, 0, -1})));
  EXPECT_FALSE(s.hits(rayFrom({0, -0.01f, 5}, {0, 0, -1})));

  // A cubic ribbon whose normals turn from +y to +z (vertex, by the basis): face on at each end
  // to the normal there.
  CurvesData twisted =
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1);
  twisted.normals = {{0, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}};
  twisted.normalsInterpolation = Interpolation::Vertex;
  CurvesScene t(twisted);
  const std::optional<SurfaceHit> start = t.surface(downAt(-1.9f, 0.3f));
  ASSERT_TRUE(start);
  EXPECT_NEAR(start->distance, 5, 1e-2f);
  EXPECT_GT(start->normal.y, 0.99f);
  const std::optional<SurfaceHit> end = t.surface(rayFrom({1.9f, 0.3f, 5}, {0, 0, -1}));
  ASSERT_TRUE(end);
  EXPECT_NEAR(end->distance, 5, 1e-2f);
  EXPECT_GT(end->normal.z, 0.99f);
  EXPECT_FALSE(t.hits(downAt(-1.9f, 0.55f)));
  EXPECT_FALSE(t.hits(rayFrom({1.9f, 0.55f, 5}, {0, 0, -1})));
}

TEST(Curves, RibbonsFacingAlongTheirCurveAreRejectedNamingTheSegment) {
  // Embree turns a ribbon across normal × direction; a normal along the curve leaves it no
  // width direction, and the segment would vanish without a word.
  const auto problemOfShape = [](CurvesData curves) -> std::string {
    const Device device;
    Scene scene(device);
    const Geometry::MeshId id = scene.geometry().addMesh();
    try {
      scene.geometry().setCurvesGeometry(id, std::move(curves));
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return {};
  };
  CurvesData straight = oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Nonperiodic,
                                 {{-2, 0, 0}, {2, 0, 0}}, 1);
  straight.normals = {{-3, 0, 0}};
  straight.normalsInterpolation = Interpolation::Constant;
  EXPECT_NE(problemOfShape(straight).find("normals: a ribbon faces along its curve at the start "
                                          "of segment 0 of curve 0"),
            std::string::npos);
  straight.normals = {{1, 1e-3f, 0}};  // nearly along it: a width direction all the same
  EXPECT_EQ(problemOfShape(straight), "");
  // A cubic ribbon whose normals turn to lie along it by its end.
  CurvesData turning =
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1);
  turning.normals = {{0, 1, 0}, {0, 1, 0}, {1, 0, 0}, {1, 0, 0}};
  turning.normalsInterpolation = Interpolation::Vertex;
  EXPECT_NE(problemOfShape(turning).find("at the end of segment 0 of curve 0"), std::string::npos);
  // Facing up at the shutter's open, standing up along its normal at its close.
  straight.normals = {{0, 1, 0}};
  straight.positionMotion = {{{0, -2, 0}, {0, 2, 0}}};
  EXPECT_NE(problemOfShape(straight).find("segment 0 of curve 0"), std::string::npos);
  straight.positionMotion = {{{-2, 1, 0}, {2, 1, 0}}};
  EXPECT_EQ(problemOfShape(straight), "");
}

TEST(Curves, RibbonWidthsAndNormalsFollowTheirInterpolation) {
  // Two straight cubic ribbons (z = 0 and z = 3), widths varying from 1 to 2 along each, the
  // first facing +y, the second +z (uniform normals).
  CurvesData curves =
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1);
  const std::vector<Vec3f> second = straightBezier(3);
  curves.positions.insert(curves.positions.end(), second.begin(), second.end());
  curves.curveVertexCounts = {4, 4};
  curves.widths = {1, 2, 1, 2};
  curves.widthsInterpolation = Interpolation::Varying;
  curves.normals = {{0, 1, 0}, {0, 0, 1}};
  curves.normalsInterpolation = Interpolation::Uniform;
  CurvesScene s(curves);
  // Half-width 0.5 + 0.5 u with u = (x + 2)/4: 0.625 at x = -1, 0.875 at x = 1.
  for (const float x : {-1.0f, 1.0f}) {
    const float halfWidth = 0.5f + 0.5f * (x + 2) / 4;
    EXPECT_TRUE(s.hits(downAt(x, 0.99f * halfWidth))) << x;
    EXPECT_FALSE(s.hits(downAt(x, 1.01f * halfWidth))) << x;
    EXPECT_TRUE(s.hits(rayFrom({x, -0.99f * halfWidth, 10}, {0, 0, -1}))) << x;
    EXPECT_FALSE(s.hits(rayFrom({x, -1.01f * halfWidth, 10}, {0, 0, -1}))) << x;
  }
  const std::optional<SurfaceHit> flat = s.surface(downAt(0, 0.2f));
  ASSERT_TRUE(flat);
  EXPECT_NEAR(flat->distance, 5, 1e-4f);
  EXPECT_NEAR(flat->normal.y, 1, 1e-4f);
  const std::optional<SurfaceHit> upright = s.surface(rayFrom({0, 0.2f, 10}, {0, 0, -1}));
  ASSERT_TRUE(upright);
  EXPECT_NEAR(upright->distance, 7, 1e-4f);
  EXPECT_NEAR(upright->normal.z, 1, 1e-4f);
  EXPECT_EQ(upright->shape->elementOf(upright->primitive), 1);
}

TEST(Curves, VaryingAndVertexWidthsGiveTheirRadius) {
  // Height of the surface above the centre line seen straight down at x (u = (x + 2)/4).
  auto heightAt = [](const CurvesScene& s, float x) {
    return 5 - s.scene.geometry().hitDistance(downAt(x, 0), RayKind::Camera);
  };
  // Varying (linear per segment) widths 0.4 → 0.6: radius 0.2 + 0.1 u. The tube's slope makes
  // its surface 1/cos of the cone's angle (1.0003) above that radius.
  CurvesData linear = oneCurve(CurveType::Linear, CurveBasis::Bezier, CurveWrap::Nonperiodic,
                               {{-2, 0, 0}, {2, 0, 0}}, 1);
  linear.widths = {0.4f, 0.6f};
  linear.widthsInterpolation = Interpolation::Varying;
  CurvesScene l(linear);
  for (const float x : {-1.0f, 0.0f, 1.0f})
    EXPECT_NEAR(heightAt(l, x), 0.2f + 0.1f * (x + 2) / 4, 2e-4f) << x;

  CurvesData cubic = linear;
  cubic.type = CurveType::Cubic;
  cubic.positions = straightBezier();
  cubic.curveVertexCounts = {4};
  CurvesScene c(cubic);
  for (const float x : {-1.0f, 0.0f, 1.0f})
    EXPECT_NEAR(heightAt(c, x), 0.2f + 0.1f * (x + 2) / 4, 2e-4f) << x;

  // Vertex widths by the Bézier basis: 0.4, 0.6, 0.6, 0.4 give (0.4 + 1.8 + 1.8 + 0.4)/8 = 0.55
  // at u = ½, where the radius is at its widest (flat).
  cubic.widths = {0.4f, 0.6f, 0.6f, 0.4f};
  cubic.widthsInterpolation = Interpolation::Vertex;
  CurvesScene v(cubic);
  EXPECT_NEAR(heightAt(v, 0), 0.275f, 2e-4f);
  // Uniform: one width per curve.
  cubic.curveVertexCounts = {4, 4};
  const std::vector<Vec3f> second = straightBezier(3);
  cubic.positions.insert(cubic.positions.end(), second.begin(), second.end());
  cubic.widths = {0.5f, 0.3f};
  cubic.widthsInterpolation = Interpolation::Uniform;
  CurvesScene u(cubic);
  EXPECT_NEAR(5 - u.scene.geometry().hitDistance(downAt(0.5f, 0), RayKind::Camera), 0.25f, 1e-4f);
  EXPECT_NEAR(5 - u.scene.geometry().hitDistance(downAt(0.5f, 3), RayKind::Camera), 0.15f, 1e-4f);
}

TEST(Curves, DisplayColorAndPrimvarsOfEachInterpolationReachShading) {
  // Two straight Bézier curves (at z = 0 and z = 3), u = (x + 2)/4 along each.
  CurvesData curves = oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic,
                               straightBezier(), 0.5f);
  const std::vector<Vec3f> second = straightBezier(3);
  curves.positions.insert(curves.positions.end(), second.begin(), second.end());
  curves.curveVertexCounts = {4, 4};
  curves.displayColor = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1},
                         {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  curves.displayColorInterpolation = Interpolation::Vertex;
  curves.primvars = {{"constant", {0.5f, 0.25f}, 2, Interpolation::Constant},
                     {"uniform", {10, 20}, 1, Interpolation::Uniform},
                     {"varying", {0, 4, 100, 200}, 1, Interpolation::Varying},
                     {"faceVarying", {0, 4, 100, 200}, 1, Interpolation::FaceVarying},
                     {"vertex", {0, 0, 0, 8, 1, 2, 3, 4}, 1, Interpolation::Vertex}};
  CurvesScene s(curves);
  // displayColor by the basis at u = ¼: weights 27/64, 27/64, 9/64, 1/64.
  const std::optional<SurfaceHit> hit = s.surface(downAt(-1, 0));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->u, 0.25f, 1e-4f);
  EXPECT_NEAR(hit->material().diffuseColor.x, 28.0f / 64, 1e-4f);
  EXPECT_NEAR(hit->material().diffuseColor.y, 28.0f / 64, 1e-4f);
  EXPECT_NEAR(hit->material().diffuseColor.z, 10.0f / 64, 1e-4f);

  const std::vector<float> constant = primvarThere(s, downAt(-1, 3), "constant", 2);
  ASSERT_EQ(constant.size(), 2u);
  EXPECT_EQ(constant[0], 0.5f);
  EXPECT_EQ(constant[1], 0.25f);
  EXPECT_EQ(primvarThere(s, downAt(-1, 0), "uniform", 1).at(0), 10);
  EXPECT_EQ(primvarThere(s, downAt(-1, 3), "uniform", 1).at(0), 20);
  // Varying: linear between the segment's ends, u = ¼ and ¾.
  EXPECT_NEAR(primvarThere(s, downAt(-1, 0), "varying", 1).at(0), 1, 1e-4f);
  EXPECT_NEAR(primvarThere(s, downAt(1, 3), "varying", 1).at(0), 175, 1e-2f);
  EXPECT_NEAR(primvarThere(s, downAt(1, 3), "faceVarying", 1).at(0), 175, 1e-2f);
  // Vertex: by the basis: 8 u³ on the first curve; 1 + 3u on the second (evenly spaced values).
  EXPECT_NEAR(primvarThere(s, downAt(0, 0), "vertex", 1).at(0), 1, 1e-4f);
  EXPECT_NEAR(primvarThere(s, downAt(1, 3), "vertex", 1).at(0), 3.25f, 1e-4f);
  EXPECT_EQ(s.scene.geometry().primvarWidth("constant"), 2);
  EXPECT_EQ(hit->shape->primvarWidth(displayColorName()), 3);
  const std::optional<SurfaceHit> other = s.surface(downAt(1, 3));
  ASSERT_TRUE(other);
  EXPECT_EQ(other->shape->elementOf(other->primitive), 1);
  // Texture coordinates are point-sampled: every corner carries the value at the point.
  Vec2f st[3];
  const SurfacePoint point = other->shape->pointAt(other->primitive, other->u, other->v, 0);
  ASSERT_TRUE(other->shape->cornerCoordinates(point, "constant", st));
  for (const Vec2f& corner : st) EXPECT_EQ(corner.y, 0.25f);
  EXPECT_FALSE(other->shape->cornerCoordinates(point, "uniform", st));  // width 1

  // Editing only displayColor keeps the BVH.
  curves.displayColor = {{0.25f, 0.5f, 0.75f}};
  curves.displayColorInterpolation = Interpolation::Constant;
  const uint64_t builds = s.scene.geometry().meshBvhBuilds();
  s.scene.geometry().setCurvesGeometry(s.id, curves);
  s.scene.commit();
  EXPECT_EQ(s.scene.geometry().meshBvhBuilds(), builds);
  const std::optional<SurfaceHit> recoloured = s.surface(downAt(1, 3));
  ASSERT_TRUE(recoloured);
  EXPECT_EQ(recoloured->material().diffuseColor.z, 0.75f);
}

TEST(Curves, VertexAndVaryingDataFollowBSplineSegments) {
  // A B-spline of 5 vertices: 2 segments, 3 varying values.
  CurvesData curves = oneCurve(CurveType::Cubic, CurveBasis::BSpline, CurveWrap::Nonperiodic,
                               {{-3, 0, 0}, {-1, 0, 0}, {0, 0, 0}, {1, 0, 0}, {3, 0, 0}}, 0.5f);
  curves.primvars = {{"vertex", {0, 6, 12, 6, 0}, 1, Interpolation::Vertex},
                     {"varying", {1, 2, 4}, 1, Interpolation::Varying}};
  CurvesScene s(curves);
  // The joint is at (P1 + 4 P2 + P3)/6 = x 0: vertex (6 + 48 + 6)/6 = 10, varying 2.
  EXPECT_NEAR(primvarThere(s, downAt(0.0f, 0), "vertex", 1).at(0), 10, 1e-3f);
  EXPECT_NEAR(primvarThere(s, downAt(0.0f, 0), "varying", 1).at(0), 2, 1e-3f);
  // The first segment starts at (P0 + 4 P1 + P2)/6: x -7/6.
  EXPECT_NEAR(primvarThere(s, downAt(-7.0f / 6 + 1e-3f, 0), "varying", 1).at(0), 1, 1e-2f);
}

TEST(Curves, MovingCurvesAreWhereTheShutterTimeSays) {
  for (const CurveType type : {CurveType::Linear, CurveType::Cubic}) {
    SCOPED_TRACE(type == CurveType::Linear ? "linear" : "cubic");
    CurvesData curves = straightCurve(type, 1);
    std::vector<Vec3f> later = curves.positions;
    for (Vec3f& p : later) p.z += 4;
    curves.positionMotion = {later};
    CurvesScene s(curves);
    EXPECT_TRUE(s.hits(downAt(0, 0, 0)));
    EXPECT_FALSE(s.hits(downAt(0, 0, 1)));
    const std::optional<SurfaceHit> middle = s.surface(downAt(1, 2, 0.5f));
    ASSERT_TRUE(middle);
    EXPECT_NEAR(middle->distance, 4.5f, 1e-4f);
    EXPECT_NEAR(middle->normal.y, 1, 1e-4f);
    EXPECT_FALSE(s.hits(downAt(1, 2.6f, 0.5f)));
    const std::optional<SurfaceHit> late = s.surface(downAt(-1, 4.3f, 1));
    ASSERT_TRUE(late);
    EXPECT_NEAR(late->distance, 5 - std::sqrt(0.25f - 0.09f), 1e-4f);
  }
}

TEST(Curves, NormalsAndFibreDirectionFollowThePlacement) {
  // Rotated a quarter turn about z (x onto y), the tube along x runs along y.
  const double rotateXToY[16] = {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  CurvesScene s(
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1),
      Transform::fromRowMajor(rotateXToY));
  const std::optional<SurfaceHit> hit = s.surface(rayFrom({5, 1, 0}, {-1, 0, 0}));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 4.5f, 1e-4f);
  EXPECT_NEAR(hit->normal.x, 1, 1e-4f);
  EXPECT_NEAR(hit->fibreDirection.y, 1, 1e-5f);
}

TEST(Curves, AnisotropicLobesStretchAlongTheFibre) {
  // A tube along x, rotated onto y: an anisotropic material's tangent is the fibre direction
  // (a fibre's primitive spans no surface to take a tangent from).
  const double rotateXToY[16] = {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  CurvesScene s(
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1),
      Transform::fromRowMajor(rotateXToY));
  Material brushed;
  brushed.constants.anisotropy = 0.8f;
  s.scene.setMaterial(0, brushed);
  s.scene.geometry().setMeshInstance(s.id, Transform::fromRowMajor(rotateXToY), 0, true);
  s.scene.commit();
  const std::optional<SurfaceHit> hit = s.surface(rayFrom({5, 1, 0}, {-1, 0, 0}));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->tangent.y, 1, 1e-5f);
  EXPECT_NEAR(length(hit->tangent), 1, 1e-5f);
}

TEST(Curves, WhiteTubesUnderAWhiteDomeAreWhite) {
  // White furnace: white Lambertian tubes under a uniform dome of radiance 1 look like it.
  CurvesData curves;
  curves.type = CurveType::Cubic;
  curves.basis = CurveBasis::CatmullRom;
  curves.curveVertexCounts = {5, 2};
  curves.positions = {{-2, -1, 0}, {-1.5f, -0.5f, 0}, {0, 0.3f, -0.5f}, {1.5f, -0.2f, 0},
                      {2, 1, 0},   {-1, 1.2f, 0.5f},  {1, 1.3f, 0}};
  curves.wrap = CurveWrap::Pinned;
  curves.widths = {0.5f, 0.7f};
  curves.widthsInterpolation = Interpolation::Uniform;
  curves.displayColor = {Vec3f(1.0f)};
  CurvesScene s(curves);
  const test::FurnaceImage image = test::renderUnderWhiteDome(s.scene);
  EXPECT_GT(image.coverage, 1.0 / 8);  // the tubes fill much of the image
  EXPECT_NEAR(image.meanRadiance, 1.0, 0.01);
}

TEST(Curves, InvalidCurvesAreRejectedNamingTheArray) {
  CurvesData curves =
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1);
  EXPECT_EQ(problemOf(curves), "");

  CurvesData c = curves;
  c.curveVertexCounts = {5};
  EXPECT_NE(problemOf(c).find("curveVertexCounts[0] = 5; expected 4, 7, 10"), std::string::npos)
      << problemOf(c);
  c.curveVertexCounts = {3};
  EXPECT_NE(problemOf(c).find("curveVertexCounts[0] = 3"), std::string::npos);
  c.curveVertexCounts = {-1};
  EXPECT_NE(problemOf(c).find("curveVertexCounts[0] = -1"), std::string::npos);
  c.curveVertexCounts = {4, 4};
  EXPECT_NE(problemOf(c).find("curveVertexCounts sum to 8 vertices, but positions has 4"),
            std::string::npos);
  c = curves;
  c.basis = CurveBasis::BSpline;
  c.curveVertexCounts = {4};
  EXPECT_EQ(problemOf(c), "");
  c.wrap = CurveWrap::Periodic;  // B-spline periodic: 3 or more
  EXPECT_EQ(problemOf(c), "");
  c.positions.resize(2);
  c.curveVertexCounts = {2};
  EXPECT_NE(problemOf(c).find("3 or more vertices for a periodic curve"), std::string::npos);
  c.wrap = CurveWrap::Pinned;  // pinned: 2 or more
  EXPECT_EQ(problemOf(c), "");
  c.basis = CurveBasis::Bezier;  // pinned Bézier curves are nonperiodic ones
  EXPECT_NE(problemOf(c).find("nonperiodic Bezier"), std::string::npos);
  c = curves;
  c.wrap = CurveWrap::Periodic;  // Bézier periodic: a multiple of 3
  EXPECT_NE(problemOf(c).find("multiple of 3"), std::string::npos);
  c.type = CurveType::Linear;
  EXPECT_EQ(problemOf(c), "");
  c.positions.resize(2);
  c.curveVertexCounts = {2};
  EXPECT_NE(problemOf(c).find("3 or more vertices for a periodic linear curve"), std::string::npos);
  c.wrap = CurveWrap::Nonperiodic;
  EXPECT_EQ(problemOf(c), "");
  c.positions.resize(1);
  c.curveVertexCounts = {1};
  EXPECT_NE(problemOf(c).find("2 or more vertices for a linear curve"), std::string::npos);

  c = curves;
  c.positions[2].x = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(problemOf(c).find("positions[2] is not finite"), std::string::npos);
  c = curves;
  c.positionMotion = {{{0, 0, 0}}};
  EXPECT_NE(problemOf(c).find("positions at motion step 1"), std::string::npos);

  c = curves;
  c.widths = {};
  EXPECT_NE(problemOf(c).find("widths (constant) has 0 values, expected 1"), std::string::npos);
  c.widths = {1, 1, 1};
  c.widthsInterpolation = Interpolation::Vertex;
  EXPECT_NE(problemOf(c).find("widths (vertex) has 3 values, expected 4"), std::string::npos);
  c.widthsInterpolation = Interpolation::Varying;  // a segment's two ends
  EXPECT_NE(problemOf(c).find("widths (varying) has 3 values, expected 2"), std::string::npos);
  c.widths = {1, 0};  // a strand tapering to its tip
  EXPECT_EQ(problemOf(c), "");
  c.widths = {1, -0.5f};
  EXPECT_NE(problemOf(c).find("widths[1] = -0.5"), std::string::npos);
  c.widths = {-1, 1};
  EXPECT_NE(problemOf(c).find("widths[0]"), std::string::npos);
  c.widths = {1, std::numeric_limits<float>::infinity()};
  EXPECT_NE(problemOf(c).find("widths[1]"), std::string::npos);
  c.widths = {1, std::numeric_limits<float>::quiet_NaN()};
  EXPECT_NE(problemOf(c).find("widths[1]"), std::string::npos);
  c.widths = {1};
  c.widthsInterpolation = Interpolation::Uniform;
  EXPECT_EQ(problemOf(c), "");

  c = curves;
  c.normals = {{0, 1, 0}, {0, 1, 0}};
  c.normalsInterpolation = Interpolation::Varying;
  EXPECT_EQ(problemOf(c), "");
  c.normalsInterpolation = Interpolation::Vertex;
  EXPECT_NE(problemOf(c).find("normals (vertex) has 2 values, expected 4"), std::string::npos);
  c.normalsInterpolation = Interpolation::Varying;
  c.normals[1] = {0, 0, 0};
  EXPECT_NE(problemOf(c).find("normals[1] has zero length"), std::string::npos);
  c.normals[1] = {0, std::numeric_limits<float>::infinity(), 0};
  EXPECT_NE(problemOf(c).find("normals[1] is not finite"), std::string::npos);

  c = curves;
  c.displayColor = {{1, 0, 0}, {0, 1, 0}};
  c.displayColorInterpolation = Interpolation::Uniform;
  EXPECT_NE(problemOf(c).find("displayColor (uniform) has 2 values, expected 1"),
            std::string::npos);
  c = curves;
  c.primvars = {{"heat", {1, 2, 3}, 1, Interpolation::Varying}};
  EXPECT_NE(problemOf(c).find("primvar heat of width 1 (varying) has 3 values, expected 2"),
            std::string::npos);
  c.primvars = {{"st", {1, 2, 3}, 2, Interpolation::Constant}};
  EXPECT_NE(problemOf(c).find("primvar st has 3 floats, not a multiple of its width 2"),
            std::string::npos);
  c.primvars = {{"wide", {1, 2, 3, 4, 5}, 5, Interpolation::Constant}};
  EXPECT_NE(problemOf(c).find("primvar wide has width 5"), std::string::npos);

  // The geometry refuses them the same way.
  const Device device;
  Scene scene(device);
  const Geometry::MeshId id = scene.geometry().addMesh();
  c = curves;
  c.widths = {-1};
  EXPECT_THROW(scene.geometry().setCurvesGeometry(id, c), std::invalid_argument);
}

TEST(Curves, MismatchedColoursAndPrimvarsAreDroppedNotTheCurves) {
  const CurvesData curves =
      oneCurve(CurveType::Cubic, CurveBasis::Bezier, CurveWrap::Nonperiodic, straightBezier(), 1);
  CurvesData c = curves;
  c.displayColor = {{1, 0, 0}, {0, 1, 0}};
  c.displayColorInterpolation = Interpolation::Uniform;
  c.primvars = {{"heat", {1, 2, 3}, 1, Interpolation::Varying},
                {"tip", {1, 2}, 1, Interpolation::Varying}};
  const std::vector<std::string> dropped = dropMismatchedCurveData(c);
  ASSERT_EQ(dropped.size(), 2u);
  EXPECT_EQ(dropped[0],
            "displayColor (uniform) has 2 values, expected 1; the fallback colour is used");
  EXPECT_EQ(dropped[1],
            "primvar heat of width 1 (varying) has 3 values, expected 2; materials reading it use "
            "their fallback");
  EXPECT_TRUE(c.displayColor.empty());
  ASSERT_EQ(c.primvars.size(), 1u);
  EXPECT_EQ(c.primvars[0].name.str(), "tip");
  EXPECT_EQ(problemOf(c), "");
  // Curves refused whole keep their data: validateCurves says why.
  c = curves;
  c.curveVertexCounts = {5};
  c.primvars = {{"heat", {1, 2, 3}, 1, Interpolation::Varying}};
  EXPECT_TRUE(dropMismatchedCurveData(c).empty());
  EXPECT_EQ(c.primvars.size(), 1u);
}
