#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "penumbra/warp.h"

using namespace penumbra;

namespace {

constexpr int kGrid = 128;  // kGrid² stratified points of the unit square

/// Calls `visit` with the centre of every cell of a kGrid × kGrid grid over [0, 1)².
void forEachGridPoint(const std::function<void(Vec2f)>& visit) {
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) visit({(i + 0.5f) / kGrid, (j + 0.5f) / kGrid});
}

/// Mean of `f` over a direction warp's samples.
double meanOver(const std::function<Vec3f(Vec2f)>& warp, const std::function<double(Vec3f)>& f) {
  double sum = 0;
  forEachGridPoint([&](Vec2f u) { sum += f(warp(u)); });
  return sum / (kGrid * kGrid);
}

void expectUnitLength(const std::function<Vec3f(Vec2f)>& warp) {
  forEachGridPoint([&](Vec2f u) { EXPECT_NEAR(length(warp(u)), 1.0f, 1e-5f); });
}

}  // namespace

TEST(Warp, ConcentricDiskMappingStaysInTheDiskAndCoversIt) {
  double meanRadius2 = 0;
  const int n = 64;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Vec2f d = concentricSampleDisk({(i + 0.5f) / n, (j + 0.5f) / n});
      const float r2 = d.x * d.x + d.y * d.y;
      EXPECT_LE(r2, 1.0f + 1e-6f);
      meanRadius2 += r2;
    }
  // Uniform over the unit disk: E[r²] = 1/2.
  EXPECT_NEAR(meanRadius2 / (n * n), 0.5, 2e-3);
}

TEST(Warp, PolarDiskMappingStaysInTheDiskAndIsUniform) {
  double meanRadius2 = 0, meanX = 0, meanY = 0;
  forEachGridPoint([&](Vec2f u) {
    const Vec2f d = polarSampleDisk(u);
    const float r2 = d.x * d.x + d.y * d.y;
    EXPECT_LE(r2, 1.0f + 1e-6f);
    meanRadius2 += r2;
    meanX += d.x;
    meanY += d.y;
  });
  const double n = kGrid * kGrid;
  EXPECT_NEAR(meanRadius2 / n, 0.5, 1e-3);
  EXPECT_NEAR(meanX / n, 0.0, 1e-3);
  EXPECT_NEAR(meanY / n, 0.0, 1e-3);
}

TEST(Warp, CosineHemisphereFollowsItsPdf) {
  expectUnitLength(sampleCosineHemisphere);
  forEachGridPoint([](Vec2f u) { EXPECT_GE(sampleCosineHemisphere(u).z, 0.0f); });
  // E[cos θ] = ∫ cos θ · cos θ / π dω = 2/3.
  EXPECT_NEAR(meanOver(sampleCosineHemisphere, [](Vec3f w) { return w.z; }), 2.0 / 3.0, 1e-3);
  // The pdf integrates to 1 over the hemisphere (estimated with uniform directions).
  const double integral =
      meanOver(sampleUniformHemisphere, [](Vec3f w) { return cosineHemispherePdf(w.z); }) /
      kUniformHemispherePdf;
  EXPECT_NEAR(integral, 1.0, 1e-3);
}

TEST(Warp, UniformHemisphereAndSphereCoverTheirDomainEvenly) {
  expectUnitLength(sampleUniformHemisphere);
  expectUnitLength(sampleUniformSphere);
  forEachGridPoint([](Vec2f u) { EXPECT_GE(sampleUniformHemisphere(u).z, 0.0f); });
  // Uniform in solid angle means uniform in z (Archimedes).
  EXPECT_NEAR(meanOver(sampleUniformHemisphere, [](Vec3f w) { return w.z; }), 0.5, 1e-3);
  EXPECT_NEAR(meanOver(sampleUniformSphere, [](Vec3f w) { return w.z; }), 0.0, 1e-3);
  EXPECT_NEAR(meanOver(sampleUniformSphere, [](Vec3f w) { return w.z * w.z; }), 1.0 / 3.0, 1e-3);
  EXPECT_NEAR(meanOver(sampleUniformSphere, [](Vec3f w) { return w.x; }), 0.0, 1e-3);
  EXPECT_FLOAT_EQ(kUniformHemispherePdf * 2 * kPi, 1.0f);
  EXPECT_FLOAT_EQ(kUniformSpherePdf * 4 * kPi, 1.0f);
}

TEST(Warp, UniformConeStaysInsideItsHalfAngle) {
  for (const float oneMinusCosMax : {1e-6f, 0.1f, 1.0f, 2.0f}) {
    const auto warp = [&](Vec2f u) { return sampleUniformCone(u, oneMinusCosMax); };
    expectUnitLength(warp);
    forEachGridPoint(
        [&](Vec2f u) { EXPECT_GE(warp(u).z, 1 - oneMinusCosMax - 1e-6f) << oneMinusCosMax; });
    // Uniform in z over [cos h, 1]; the pdf times the cone's solid angle is 1.
    EXPECT_NEAR(meanOver(warp, [](Vec3f w) { return w.z; }), 1 - 0.5 * oneMinusCosMax, 1e-4);
    EXPECT_FLOAT_EQ(uniformConePdf(oneMinusCosMax) * 2 * kPi * oneMinusCosMax, 1.0f);
  }
}

TEST(Warp, UniformTriangleWeightsAreBarycentricAndUniform) {
  Vec3f mean(0.0f);
  forEachGridPoint([&](Vec2f u) {
    const Vec3f b = sampleUniformTriangle(u);
    EXPECT_GE(b.x, 0.0f);
    EXPECT_GE(b.y, 0.0f);
    EXPECT_GE(b.z, 0.0f);
    EXPECT_NEAR(b.x + b.y + b.z, 1.0f, 1e-6f);
    mean += b;
  });
  // The centroid of a uniform density on a triangle has weights 1/3 each.
  mean = mean / float(kGrid * kGrid);
  EXPECT_NEAR(mean.x, 1.0f / 3, 1e-3f);
  EXPECT_NEAR(mean.y, 1.0f / 3, 1e-3f);
  EXPECT_NEAR(mean.z, 1.0f / 3, 1e-3f);
}

TEST(Warp, SphericalRectangleSamplesTheRectangleEvenlyInSolidAngle) {
  // A 2 × 2 square at distance 1 below the point, centred on the axis: solid angle
  // 4 asin(ab / √((a² + d²)(b² + d²))) = 4 asin(1/2) = 2π/3 for half sides a = b = d = 1.
  const Vec3f point(0, 0, 1);
  const SphericalRectangle seen(
      point, SphericalRectangle::Rectangle(Vec3f(-1, -1, 0), Vec3f(2, 0, 0), Vec3f(0, 2, 0)));
  EXPECT_NEAR(seen.solidAngle(), 2 * M_PI / 3, 1e-9);
  int quadrants[2][2] = {{0, 0}, {0, 0}};
  forEachGridPoint([&](Vec2f u) {
    const Vec3f p = seen.sample(u);
    EXPECT_NEAR(p.z, 0.0f, 1e-5f);
    EXPECT_LE(std::fabs(p.x), 1.0f + 1e-5f);
    EXPECT_LE(std::fabs(p.y), 1.0f + 1e-5f);
    ++quadrants[p.x > 0][p.y > 0];
  });
  // By symmetry each quadrant subtends a quarter of the solid angle.
  for (const auto& row : quadrants)
    for (const int count : row) EXPECT_NEAR(double(count) / (kGrid * kGrid), 0.25, 2e-3);
}

TEST(Warp, SphericalRectangleSolidAngleMatchesTheCornerFormulaFromEveryViewpoint) {
  // Seen from height h, the rectangle [x0, x1] × [y0, y1] subtends F(x1, y1) − F(x0, y1) −
  // F(x1, y0) + F(x0, y0), F(x, y) = atan(xy / (h √(x² + y² + h²))): an independent formula.
  const auto cornerFormula = [](double x0, double x1, double y0, double y1, double h) {
    const auto f = [h](double x, double y) {
      return std::atan(x * y / (h * std::sqrt(x * x + y * y + h * h)));
    };
    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0);
  };
  const SphericalRectangle::Rectangle rectangle(Vec3f(-1, -0.5f, 0), Vec3f(2, 0, 0),
                                                Vec3f(0, 1, 0));
  // Over the middle and a corner, close to the plane (towards 2π), beside it at grazing
  // heights, far off to the side and far above (a tiny solid angle), and from below.
  const Vec3f points[] = {{0, 0, 1},      {0.2f, 0.1f, 1e-3f}, {0.9f, 0.4f, 0.01f},
                          {3, 0, 0.01f},  {-2, 5, 0.2f},       {40, -30, 1},
                          {0.3f, 0, 300}, {0, 0, -2},          {1.5f, 0.7f, -0.05f}};
  for (const Vec3f& point : points) {
    const SphericalRectangle seen(point, rectangle);
    const double h = std::fabs(double(point.z));
    // The solid angle of the part [x0, x1] × [y0, y1] of the rectangle.
    const auto part = [&](double x0, double x1, double y0, double y1) {
      return cornerFormula(x0 - double(point.x), x1 - double(point.x), y0 - double(point.y),
                           y1 - double(point.y), h);
    };
    const double expected = part(-1, 1, -0.5, 0.5);
    // To the rounding of the point's offsets in float.
    EXPECT_NEAR(seen.solidAngle() / expected, 1, 1e-6)
        << point.x << ' ' << point.y << ' ' << point.z << ": " << expected;
    if (!(expected > 1e-4)) continue;  // lights sample such rectangles by area
    // Samples land in each quarter, split off centre, in proportion to its solid angle.
    constexpr double kSplitX = 0.3, kSplitY = -0.1;
    double counts[2][2] = {{0, 0}, {0, 0}};
    forEachGridPoint([&](Vec2f u) {
      const Vec3f p = seen.sample(u);
      ++counts[p.x > kSplitX][p.y > kSplitY];
    });
    const double xs[] = {-1, kSplitX, 1}, ys[] = {-0.5, kSplitY, 0.5};
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) {
        EXPECT_NEAR(counts[i][j] / (kGrid * kGrid),
                    part(xs[i], xs[i + 1], ys[j], ys[j + 1]) / expected, 3e-3)
            << point.x << ' ' << point.y << ' ' << point.z << " quarter " << i << j;
      }
  }
  // In the plane there is nothing to sample.
  EXPECT_EQ(SphericalRectangle(Vec3f(3, 0, 0), rectangle).solidAngle(), 0.0);
}
