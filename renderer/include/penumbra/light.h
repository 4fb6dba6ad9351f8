// UsdLux lights (DESIGN.md §3): radiance = color · intensity · 2^exposure · blackbody
// [/ world-space area if normalize]. Rect and disk lights lie in their local XY plane and emit
// along -Z; sphere lights emit outward; a distant light's light travels along -Z; the dome
// surrounds the scene.
//
// Shadow rays are distributed over each light's area or solid angle (soft shadows); every
// sampling routine returns its density in solid angle so that the integrator can combine it with
// BSDF sampling by multiple importance sampling.
#pragma once

#include <optional>

#include "penumbra/math.h"

namespace penumbra {

enum class LightType { Rect, Disk, Sphere, Distant, Dome };

struct LightParams {
  LightType type = LightType::Sphere;
  Transform lightToWorld;
  Vec3f color{1.0f};
  float intensity = 1;
  float exposure = 0;
  bool normalize = false;
  bool enableColorTemperature = false;
  float colorTemperature = 6500;  // kelvin
  float width = 1, height = 1;    // rect, scene units before the transform
  float radius = 0.5f;            // disk and sphere
  float angle = 0.53f;            // distant: angular diameter in degrees
  bool treatAsPoint = false;      // sphere: emit from the centre as a point
};

/// A light sample as seen from a shading point.
struct LightSample {
  Vec3f direction;     // unit, from the shading point towards the light
  float distance = 0;  // to the sampled point; infinity for distant and dome lights
  Vec3f radiance;      // arriving along -direction (for delta lights: irradiance / pdf scale)
  float pdf = 0;       // solid-angle density; for delta lights 1 with isDelta set
  bool isDelta = false;
};

/// Where a ray meets a light's emitting surface.
struct LightHit {
  float distance = 0;
  Vec3f radiance;
  float pdf = 0;  // the solid-angle density sample() would have had for this direction
};

class Light {
 public:
  /// Throws std::invalid_argument for degenerate shapes (zero area, non-finite values).
  explicit Light(const LightParams& params);

  LightType type() const { return params_.type; }
  /// True for distant and dome lights: reached by rays that escape the scene.
  bool isInfinite() const {
    return params_.type == LightType::Distant || params_.type == LightType::Dome;
  }
  /// True for lights no ray can hit (point-like sphere, zero-angle distant light).
  bool isDelta() const;

  std::optional<LightSample> sample(const Vec3f& point, Vec2f u) const;
  /// First intersection of a ray with a finite light's emitting surface closer than tMax.
  std::optional<LightHit> intersect(const Vec3f& origin, const Vec3f& direction, float tMax) const;
  /// Radiance and pdf for a ray that escaped the scene in `direction` (infinite lights).
  std::optional<LightHit> escaped(const Vec3f& origin, const Vec3f& direction) const;

  /// The emitted radiance (constant over the light), after all UsdLux factors.
  const Vec3f& radiance() const { return radiance_; }
  float area() const { return area_; }

 private:
  float solidAnglePdfFromArea(const Vec3f& point, const Vec3f& lightPoint,
                              const Vec3f& lightNormal) const;
  std::optional<float> intersectSphere(const Vec3f& origin, const Vec3f& direction) const;

  LightParams params_;
  Vec3f radiance_;
  // Rect: corner + edges; disk: centre + semi-axes; sphere: centre + radius.
  Vec3f center_, edgeU_, edgeV_, normal_;
  float radius_ = 0;
  float area_ = 0;
  float cosHalfAngle_ = 1;          // distant light cone
  float oneMinusCosHalfAngle_ = 0;  // kept separately for precision at small angles
};

/// Directions uniformly distributed in a cone around +Z whose half angle h has
/// 1 - cos h = oneMinusCosMax (passed that way to keep precision for tiny cones).
Vec3f sampleUniformCone(Vec2f u, float oneMinusCosMax);
float uniformConePdf(float oneMinusCosMax);
/// Cosine-weighted hemisphere around +Z.
Vec3f sampleCosineHemisphere(Vec2f u);
Vec3f sampleUniformSphere(Vec2f u);

}  // namespace penumbra
