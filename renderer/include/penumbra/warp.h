// Sampling warps: maps from uniform random numbers u ∈ [0, 1)² to points of a domain (disk,
// hemisphere, sphere, cone, triangle, spherical rectangle), with their densities. Inline: they
// sit on every camera ray, light sample and BSDF sample.
//
// Distinct maps to the same domain are kept apart on purpose: each caller's images depend on its
// exact map (which u goes where) and floating-point expression, so they are not interchangeable.
#pragma once

#include <algorithm>
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
/// Rectangles"). Computed in double: inverting the parametrisation loses precision for small
/// rectangles.
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
    if (!(z0_ < 0)) return;  // in the plane: no solid angle
    const double z2 = z0_ * z0_;
    // Corners 00, 10, 11 and 01 as seen from the point: lengths and dot products.
    const auto distance = [z2](double x, double y) { return std::sqrt(x * x + y * y + z2); };
    const auto dotOf = [z2](double ax, double ay, double bx, double by) {
      return ax * bx + ay * by + z2;
    };
    const double d00 = distance(x0_, y0_), d10 = distance(x1_, y0_), d11 = distance(x1_, y1_),
                 d01 = distance(x0_, y1_);
    // The two triangles (00, 10, 11) and (00, 11, 01), each as den + i·num with
    // tan(Ω/2) = num / den = |a · (b × c)| / (abc + (a·b)c + (a·c)b + (b·c)a) (Van Oosterom &
    // Strackee 1983). Their half solid angles add as these multiply, and the sum is in [0, π):
    // one atan2, and no difference of nearly equal angles to lose a small rectangle's precision.
    const double triple = -z0_ * rectangle.lengthX * rectangle.lengthY;
    const double diagonal = dotOf(x0_, y0_, x1_, y1_);
    const double first = d00 * d10 * d11 + dotOf(x0_, y0_, x1_, y0_) * d11 + diagonal * d10 +
                         dotOf(x1_, y0_, x1_, y1_) * d00;
    const double second = d00 * d11 * d01 + diagonal * d01 + dotOf(x0_, y0_, x0_, y1_) * d11 +
                          dotOf(x1_, y1_, x0_, y1_) * d00;
    solidAngle_ =
        2 * std::atan2(std::max(0.0, triple * (first + second)), first * second - triple * triple);
    // The sampling's offset angle k = 2π − g2 − g3, by the interior angles g at corners 01 and
    // 00 between the planes through the point and the edges. Those planes' normals are
    // (0, z0, −y0), (−z0, 0, x1), (0, −z0, y1) and (z0, 0, −x0) over their lengths: corner c's
    // angle is that of the complex number ±x·y + i·|z0|·d_c (its cosine and sine times a positive
    // length), and g2 + g3 that of their product.
    const double cos01 = x0_ * y1_, sin01 = -z0_ * d01, cos00 = -x0_ * y0_, sin00 = -z0_ * d00;
    const double cosSum = cos01 * cos00 - sin01 * sin00, sinSum = cos01 * sin00 + sin01 * cos00;
    const double length = std::sqrt(cosSum * cosSum + sinSum * sinSum);
    cosK_ = cosSum / length;
    sinK_ = -sinSum / length;
    b0_ = -y0_ / std::sqrt(z2 + y0_ * y0_);  // the z of the first and third planes' normals
    b1_ = y1_ / std::sqrt(z2 + y1_ * y1_);
    oneMinusB0Squared_ = z2 / (z2 + y0_ * y0_);
  }

  /// Steradians; 0 or tiny when the point is (nearly) in the rectangle's plane.
  double solidAngle() const { return solidAngle_; }

  /// The point of the rectangle in direction u ∈ [0, 1)² of the parametrisation.
  Vec3f sample(Vec2f u) const {
    // The angle k + u.x Ω, by its cosine and sine.
    const double cosU = std::cos(u.x * solidAngle_), sinU = std::sin(u.x * solidAngle_);
    const double cosAu = cosU * cosK_ - sinU * sinK_, sinAu = sinU * cosK_ + cosU * sinK_;
    const double fu = (cosAu * b0_ - b1_) / sinAu;
    // x = −cu z0 / √(1 − cu²) with cu = sign(fu) / √(fu² + b0²), in one square root: the
    // chain of dependent roots and divisions is what a sample waits for.
    const double xu = std::clamp(
        std::copysign(z0_, fu) / std::sqrt(std::max(1e-30, fu * fu - oneMinusB0Squared_)), x0_,
        x1_);
    const double d2 = xu * xu + z0_ * z0_, d = std::sqrt(d2);
    const double h0 = y0_ / std::sqrt(d2 + y0_ * y0_), h1 = y1_ / std::sqrt(d2 + y1_ * y1_);
    const double hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
    const double yv = hv2 < 1 - 1e-12 ? std::clamp(hv * d / std::sqrt(1 - hv2), y0_, y1_) : y1_;
    return origin_ + x_ * float(xu) + y_ * float(yv) + z_ * float(z0_);
  }

 private:
  Vec3f origin_, x_, y_, z_;
  double x0_, y0_, z0_, x1_, y1_;
  double b0_ = 0, b1_ = 0, oneMinusB0Squared_ = 0, cosK_ = 1, sinK_ = 0, solidAngle_ = 0;
};

}  // namespace penumbra
