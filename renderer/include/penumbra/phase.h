// The Henyey–Greenstein phase function (1941) of participating media: the distribution of the
// direction a scattered ray takes, from one parameter g, the mean cosine of the scattering angle
// (g > 0 forward, g < 0 backward, 0 isotropic). Directions here are directions of travel: the
// incoming ray's and the scattered ray's.
#pragma once

#include <cmath>

#include "penumbra/math.h"

namespace penumbra {

class HenyeyGreenstein {
 public:
  explicit HenyeyGreenstein(float g) : g_(g) {}

  /// Density (per steradian) of scattering a ray travelling along `incoming` into `outgoing`
  /// (both unit). Integrates to 1 over the sphere; as a phase function is its own sampling
  /// density, the value is also sample()'s pdf.
  float evaluate(const Vec3f& incoming, const Vec3f& outgoing) const {
    return density(dot(incoming, outgoing));
  }
  /// Density as a function of the cosine of the scattering angle.
  float density(float cosTheta) const {
    const float denominator = 1 + g_ * g_ - 2 * g_ * cosTheta;
    return (1 - g_ * g_) / (4 * kPi * denominator * std::sqrt(std::max(denominator, 1e-12f)));
  }
  /// A scattered direction for a ray travelling along `incoming`, by inverting the distribution
  /// of the cosine; its density is evaluate(incoming, result).
  Vec3f sample(const Vec3f& incoming, Vec2f u) const {
    float cosTheta;
    if (std::abs(g_) < 1e-3f) {
      cosTheta = 1 - 2 * u.x;
    } else {
      const float ratio = (1 - g_ * g_) / (1 - g_ + 2 * g_ * u.x);
      cosTheta = (1 + g_ * g_ - ratio * ratio) / (2 * g_);
    }
    cosTheta = std::clamp(cosTheta, -1.0f, 1.0f);
    const float sinTheta = std::sqrt(std::max(0.0f, 1 - cosTheta * cosTheta));
    const float phi = 2 * kPi * u.y;
    const Frame frame(incoming);
    return normalize(frame.toWorld({sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta}));
  }

 private:
  float g_;
};

}  // namespace penumbra
