// Sampling warps: maps from uniform random numbers u ∈ [0, 1)² to points of a domain (disk,
// hemisphere, sphere, cone, triangle, spherical rectangle), with their densities. Inline: they
// sit on every camera ray, light sample and BSDF sample.
//
// Distinct maps to the same domain are kept apart on purpose: each caller's images depend on its
// exact map (which u goes where) and floating-point expression, so they are not interchangeable.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "penumbra/math.h"

namespace penumbra {

/// Shirley–Chiu concentric mapping of the unit square to the unit disk (no clumping); keeps
/// strata compact, which suits lenses and cosine-weighted directions.
inline Vec2f concentricSampleDisk(Vec2f u) {
  const float x = 2 * u.x - 1, y = 2 * u.y - 1;
  if (x == 0 && y == 0) return {0, 0};
  float radius, angle;
  if (std::fabs(x) > std::fabs(y)) {
    radius = x;
    angle = (kPi / 4) * (y / x);
  } else {
    radius = y;
    angle = kPi / 2 - (kPi / 4) * (x / y);
  }
  return {radius * std::cos(angle), radius * std::sin(angle)};
}

/// The polar mapping of the unit square to the unit disk: radius √u.x, angle 2π u.y. Uniform like
/// concentricSampleDisk but a different map; GGX visible-normal sampling (Heitz 2018) uses it.
inline Vec2f polarSampleDisk(Vec2f u) {
  const float radius = std::sqrt(u.x);
  const float phi = 2 * kPi * u.y;
  return {radius * std::cos(phi), radius * std::sin(phi)};
}

/// Cosine-weighted hemisphere around +Z (Malley's method over concentricSampleDisk); density
/// cosineHemispherePdf(z).
inline Vec3f sampleCosineHemisphere(Vec2f u) {
  const Vec2f d = concentricSampleDisk(u);
  return {d.x, d.y, std::sqrt(std::max(0.0f, 1 - d.x * d.x - d.y * d.y))};
}
inline float cosineHemispherePdf(float cosTheta) {
  return cosTheta * kInvPi;
}

/// Uniform over the hemisphere z > 0, z = u.x (density kUniformHemispherePdf): for lobes that
/// scatter most towards grazing directions, which cosine-weighted sampling would starve.
inline Vec3f sampleUniformHemisphere(Vec2f u) {
  const float z = u.x;
  const float radius = std::sqrt(std::max(0.0f, 1 - z * z));
  const float phi = 2 * kPi * u.y;
  return {radius * std::cos(phi), radius * std::sin(phi), z};
}
constexpr float kUniformHemispherePdf = 1 / (2 * kPi);

/// Uniform over the unit sphere, z = 1 − 2 u.x (density kUniformSpherePdf).
inline Vec3f sampleUniformSphere(Vec2f u) {
  const float z = 1 - 2 * u.x;
  const float r = std::sqrt(std::max(0.0f, 1 - z * z));
  const float phi = 2 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
constexpr float kUniformSpherePdf = 1 / (4 * kPi);

/// Directions uniformly distributed in a cone around +Z whose half angle h has
/// 1 − cos h = oneMinusCosMax (passed that way to keep precision for tiny cones); cos θ =
/// 1 − u.x · oneMinusCosMax, so oneMinusCosMax = 1 is the upper hemisphere with z = 1 − u.x.
inline Vec3f sampleUniformCone(Vec2f u, float oneMinusCosMax) {
  const float cosTheta = 1 - u.x * oneMinusCosMax;
  const float sinTheta = std::sqrt(std::max(0.0f, 1 - cosTheta * cosTheta));
  const float phi = 2 * kPi * u.y;
  return {sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta};
}
inline float uniformConePdf(float oneMinusCosMax) {
  return 1 / (2 * kPi * oneMinusCosMax);
}

/// Barycentric weights (of corners 0, 1, 2) of a point uniform on a triangle, by the square-root
/// map; the density is 1 / area.
inline Vec3f sampleUniformTriangle(Vec2f u) {
  const float root = std::sqrt(u.x);
  return {1 - root, root * (1 - u.y), root * u.y};
}

/// A rectangle seen from a point, for sampling directions uniformly within the solid angle it
/// subtends (Ureña, Fajardo & King 2013, "An Area-Preserving Parametrization for Spherical
/// Rectangles"). Computed in double: the angles cancel badly for small rectangles.
class SphericalRectangle {
 public:
  /// What does not depend on where the rectangle is seen from: `corner`, the two orthogonal
  /// edges from it as unit vectors and lengths, and their normal. Made once per rectangle.
  struct Rectangle {
    Vec3f corner, x, y, z;
    double lengthX = 0, lengthY = 0;

    Rectangle() = default;
    Rectangle(const Vec3f& from, const Vec3f& edgeX, const Vec3f& edgeY)
        : corner(from), lengthX(length(edgeX)), lengthY(length(edgeY)) {
      x = edgeX / float(lengthX);
      y = edgeY / float(lengthY);
      z = cross(x, y);
    }
  };

  /// The rectangle seen from `point`.
  SphericalRectangle(const Vec3f& point, const Rectangle& rectangle)
      : origin_(point), x_(rectangle.x), y_(rectangle.y), z_(rectangle.z) {
    const Vec3f toCorner = rectangle.corner - point;
    x0_ = dot(toCorner, x_);
    y0_ = dot(toCorner, y_);
    z0_ = dot(toCorner, z_);
    if (z0_ > 0) {  // work on the side of the plane facing the point
      z0_ = -z0_;
      z_ = -z_;
    }
    x1_ = x0_ + rectangle.lengthX;
    y1_ = y0_ + rectangle.lengthY;
    // Normals of the planes through the point and each edge, then the interior angles.
    const auto planeNormal = [](double ax, double ay, double bx, double by, double z) {
      // cross((ax, ay, z), (bx, by, z)), normalised
      const double nx = ay * z - z * by, ny = z * bx - ax * z, nz = ax * by - ay * bx;
      const double norm = std::sqrt(nx * nx + ny * ny + nz * nz);
      return std::array<double, 3>{nx / norm, ny / norm, nz / norm};
    };
    const auto n0 = planeNormal(x0_, y0_, x1_, y0_, z0_);
    const auto n1 = planeNormal(x1_, y0_, x1_, y1_, z0_);
    const auto n2 = planeNormal(x1_, y1_, x0_, y1_, z0_);
    const auto n3 = planeNormal(x0_, y1_, x0_, y0_, z0_);
    const auto angle = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
      return std::acos(std::clamp(-(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]), -1.0, 1.0));
    };
    const double g0 = angle(n0, n1), g1 = angle(n1, n2), g2 = angle(n2, n3), g3 = angle(n3, n0);
    b0_ = n0[2];
    b1_ = n2[2];
    k_ = 2 * M_PI - g2 - g3;
    solidAngle_ = g0 + g1 - k_;
  }

  /// Steradians; not finite or tiny when the point is (nearly) in the rectangle's plane.
  double solidAngle() const { return solidAngle_; }

  /// The point of the rectangle in direction u ∈ [0, 1)² of the parametrisation.
  Vec3f sample(Vec2f u) const {
    const double au = u.x * solidAngle_ + k_;
    const double fu = (std::cos(au) * b0_ - b1_) / std::sin(au);
    double cu = std::copysign(1.0, fu) / std::sqrt(fu * fu + b0_ * b0_);
    cu = std::clamp(cu, -1.0, 1.0);
    const double xu = std::clamp(-(cu * z0_) / std::sqrt(std::max(1e-30, 1 - cu * cu)), x0_, x1_);
    const double d = std::sqrt(xu * xu + z0_ * z0_);
    const double h0 = y0_ / std::sqrt(d * d + y0_ * y0_), h1 = y1_ / std::sqrt(d * d + y1_ * y1_);
    const double hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
    const double yv = hv2 < 1 - 1e-12 ? std::clamp(hv * d / std::sqrt(1 - hv2), y0_, y1_) : y1_;
    return origin_ + x_ * float(xu) + y_ * float(yv) + z_ * float(z0_);
  }

 private:
  Vec3f origin_, x_, y_, z_;
  double x0_, y0_, z0_, x1_, y1_;
  double b0_, b1_, k_, solidAngle_;
};

}  // namespace penumbra
