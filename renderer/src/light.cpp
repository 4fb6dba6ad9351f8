#include "penumbra/light.h"

#include <stdexcept>

#include "penumbra/camera.h"
#include "penumbra/color.h"

namespace penumbra {

Vec3f sampleUniformCone(Vec2f u, float oneMinusCosMax) {
  const float cosTheta = 1 - u.x * oneMinusCosMax;
  const float sinTheta = std::sqrt(std::max(0.0f, 1 - cosTheta * cosTheta));
  const float phi = 2 * kPi * u.y;
  return {sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta};
}

float uniformConePdf(float oneMinusCosMax) {
  return 1 / (2 * kPi * oneMinusCosMax);
}

Vec3f sampleCosineHemisphere(Vec2f u) {
  const Vec2f d = concentricSampleDisk(u);
  return {d.x, d.y, std::sqrt(std::max(0.0f, 1 - d.x * d.x - d.y * d.y))};
}

Vec3f sampleUniformSphere(Vec2f u) {
  const float z = 1 - 2 * u.x;
  const float r = std::sqrt(std::max(0.0f, 1 - z * z));
  const float phi = 2 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

namespace {

/// 1 - cos(asin(s)) for s = sin, without cancellation for small angular sizes.
float oneMinusCosFromSin2(float sin2) {
  return sin2 / (1 + std::sqrt(std::max(0.0f, 1 - sin2)));
}

bool isFinite(const Vec3f& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

Light::Light(const LightParams& params) : params_(params) {
  Vec3f emission = params.color * (params.intensity * std::exp2(params.exposure));
  if (params.enableColorTemperature) emission *= blackbodyColor(params.colorTemperature);
  const Transform& toWorld = params.lightToWorld;
  center_ = toWorld.applyToPoint({0, 0, 0});
  switch (params.type) {
    case LightType::Rect:
      edgeU_ = toWorld.applyToVector({params.width, 0, 0});
      edgeV_ = toWorld.applyToVector({0, params.height, 0});
      area_ = length(cross(edgeU_, edgeV_));
      break;
    case LightType::Disk:
      edgeU_ = toWorld.applyToVector({params.radius, 0, 0});
      edgeV_ = toWorld.applyToVector({0, params.radius, 0});
      area_ = kPi * length(cross(edgeU_, edgeV_));
      break;
    case LightType::Sphere:
      // Spheres stay spheres: a non-uniform scale is approximated by its geometric mean.
      radius_ = params.radius * float(std::cbrt(std::fabs(toWorld.linearDeterminant())));
      area_ = 4 * kPi * radius_ * radius_;
      if (params.treatAsPoint && area_ == 0) area_ = 1;  // a point: nothing to normalise by
      break;
    case LightType::Distant: {
      const double halfAngle = std::clamp(0.5 * params.angle * M_PI / 180, 0.0, M_PI);
      cosHalfAngle_ = float(std::cos(halfAngle));
      // 1 - cos(h) = 2 sin²(h/2): exact for the sun's quarter degree, where 1 - cos loses digits.
      oneMinusCosHalfAngle_ = float(2 * std::pow(std::sin(0.5 * halfAngle), 2));
      break;
    }
    case LightType::Dome:
      break;
  }
  if (params.type == LightType::Rect || params.type == LightType::Disk) {
    normal_ = toWorld.applyToNormal({0, 0, -1});
    if (!(area_ > 0) || !(length(normal_) > 0))
      throw std::invalid_argument("the light has zero area (check width/height/radius and scale)");
    normal_ = normalize(normal_);
  }
  if (params.type == LightType::Sphere && !(area_ > 0))
    throw std::invalid_argument("the sphere light has zero radius (use treatAsPoint for a point)");
  if (params.normalize && params.type != LightType::Dome) {
    if (params.type == LightType::Distant) {
      // Normalised distant lights give `intensity` as the irradiance on a facing surface.
      // The cone's projected solid angle is π sin²(h) = π (1 - cos h)(1 + cos h).
      if (!isDelta()) emission = emission / (kPi * oneMinusCosHalfAngle_ * (1 + cosHalfAngle_));
    } else {
      emission = emission / area_;
    }
  }
  radiance_ = emission;
  if (!isFinite(radiance_) || !isFinite(center_))
    throw std::invalid_argument("the light's parameters or transform are not finite");
  if (params.type == LightType::Distant || params.type == LightType::Dome) {
    normal_ = normalize(toWorld.applyToVector({0, 0, -1}));  // direction the light travels
  }
}

bool Light::isDelta() const {
  return (params_.type == LightType::Sphere && params_.treatAsPoint) ||
         (params_.type == LightType::Distant && !(oneMinusCosHalfAngle_ > 0));
}

float Light::solidAnglePdfFromArea(const Vec3f& point, const Vec3f& lightPoint,
                                   const Vec3f& lightNormal) const {
  const Vec3f toLight = lightPoint - point;
  const float distance2 = dot(toLight, toLight);
  const float cosLight = -dot(toLight, lightNormal) / std::sqrt(distance2);
  return cosLight > 0 ? distance2 / (area_ * cosLight) : 0.0f;
}

std::optional<LightSample> Light::sample(const Vec3f& point, Vec2f u) const {
  LightSample result;
  switch (params_.type) {
    case LightType::Rect:
    case LightType::Disk: {
      Vec2f offset = {u.x - 0.5f, u.y - 0.5f};
      if (params_.type == LightType::Disk) offset = concentricSampleDisk(u);
      const Vec3f lightPoint = center_ + edgeU_ * offset.x + edgeV_ * offset.y;
      result.pdf = solidAnglePdfFromArea(point, lightPoint, normal_);
      if (!(result.pdf > 0)) return std::nullopt;
      const Vec3f toLight = lightPoint - point;
      result.distance = length(toLight);
      result.direction = toLight / result.distance;
      result.radiance = radiance_;
      return result;
    }
    case LightType::Sphere: {
      const Vec3f toCenter = center_ - point;
      const float distance2 = dot(toCenter, toCenter);
      const float distance = std::sqrt(distance2);
      if (params_.treatAsPoint) {
        // Radiant intensity of the sphere seen from afar: L · π r².
        result.direction = toCenter / distance;
        result.distance = distance;
        result.radiance = radiance_ * (kPi * radius_ * radius_ / distance2);
        result.pdf = 1;
        result.isDelta = true;
        return result;
      }
      if (distance <= radius_) return std::nullopt;  // inside: the sphere emits outward only
      // Uniform directions in the cone the sphere subtends (solid-angle sampling).
      const float sin2Max = radius_ * radius_ / distance2;
      const float oneMinusCosMax = oneMinusCosFromSin2(sin2Max);
      const Frame frame(toCenter / distance);
      result.direction = normalize(frame.toWorld(sampleUniformCone(u, oneMinusCosMax)));
      const std::optional<float> t = intersectSphere(point, result.direction);
      // Grazing directions may miss by rounding: the tangent distance is then exact enough.
      result.distance = t ? *t : std::sqrt(std::max(0.0f, distance2 - radius_ * radius_));
      result.radiance = radiance_;
      result.pdf = uniformConePdf(oneMinusCosMax);
      return result;
    }
    case LightType::Distant: {
      result.distance = kInfinity;
      if (isDelta()) {
        result.direction = -normal_;
        result.radiance = radiance_;
        result.pdf = 1;
        result.isDelta = true;
        return result;
      }
      result.direction =
          normalize(Frame(-normal_).toWorld(sampleUniformCone(u, oneMinusCosHalfAngle_)));
      result.radiance = radiance_;
      result.pdf = uniformConePdf(oneMinusCosHalfAngle_);
      return result;
    }
    case LightType::Dome:
      result.direction = sampleUniformSphere(u);
      result.distance = kInfinity;
      result.radiance = radiance_;
      result.pdf = 1 / (4 * kPi);
      return result;
  }
  return std::nullopt;
}

std::optional<float> Light::intersectSphere(const Vec3f& origin, const Vec3f& direction) const {
  const Vec3f toOrigin = origin - center_;
  const float b = dot(toOrigin, direction);
  // Discriminant in the numerically robust form (pbrt-v4 §6.8.1 idea: |o - b d|).
  const Vec3f perpendicular = toOrigin - direction * b;
  const float discriminant = radius_ * radius_ - dot(perpendicular, perpendicular);
  if (discriminant < 0) return std::nullopt;
  // Only the near root counts: from inside, the outward-emitting surface faces away.
  const float tNear = -b - std::sqrt(discriminant);
  if (tNear > 0) return tNear;
  return std::nullopt;
}

std::optional<LightHit> Light::intersect(const Vec3f& origin, const Vec3f& direction,
                                         float tMax) const {
  if (isInfinite() || isDelta()) return std::nullopt;
  LightHit hit;
  if (params_.type == LightType::Sphere) {
    const std::optional<float> t = intersectSphere(origin, direction);
    if (!t || *t >= tMax) return std::nullopt;
    const Vec3f toCenter = center_ - origin;
    const float sin2Max = radius_ * radius_ / dot(toCenter, toCenter);
    hit.distance = *t;
    hit.radiance = radiance_;
    hit.pdf = uniformConePdf(oneMinusCosFromSin2(sin2Max));
    return hit;
  }
  const float facing = dot(direction, normal_);
  if (facing >= 0) return std::nullopt;  // one-sided emitters are seen from the -Z side only
  const float t = dot(center_ - origin, normal_) / facing;
  if (!(t > 0) || t >= tMax) return std::nullopt;
  const Vec3f offset = origin + direction * t - center_;
  const float a = dot(offset, edgeU_) / dot(edgeU_, edgeU_);
  const float b = dot(offset, edgeV_) / dot(edgeV_, edgeV_);
  const bool inside = params_.type == LightType::Rect
                          ? (std::fabs(a) <= 0.5f && std::fabs(b) <= 0.5f)
                          : (a * a + b * b <= 1);
  if (!inside) return std::nullopt;
  hit.distance = t;
  hit.radiance = radiance_;
  hit.pdf = solidAnglePdfFromArea(origin, origin + direction * t, normal_);
  return hit;
}

std::optional<LightHit> Light::escaped(const Vec3f& /*origin*/, const Vec3f& direction) const {
  if (!isInfinite() || isDelta()) return std::nullopt;
  LightHit hit;
  hit.distance = kInfinity;
  hit.radiance = radiance_;
  if (params_.type == LightType::Dome) {
    hit.pdf = 1 / (4 * kPi);
    return hit;
  }
  if (dot(direction, -normal_) < cosHalfAngle_) return std::nullopt;
  hit.pdf = uniformConePdf(oneMinusCosHalfAngle_);
  return hit;
}

}  // namespace penumbra
