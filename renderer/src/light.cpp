#include "penumbra/light.h"

#include <stdexcept>
#include <string>

#include "penumbra/color.h"
#include "penumbra/warp.h"

namespace penumbra {

namespace {

/// 1 - cos(asin(s)) for s = sin, without cancellation for small angular sizes.
float oneMinusCosFromSin2(float sin2) {
  return sin2 / (1 + std::sqrt(std::max(0.0f, 1 - sin2)));
}

float smoothstep(float edge0, float edge1, float x) {
  if (edge1 <= edge0) return x >= edge0 ? 1.0f : 0.0f;
  const float t = std::clamp((x - edge0) / (edge1 - edge0), 0.0f, 1.0f);
  return t * t * (3 - 2 * t);
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
      break;
    case LightType::Cylinder: {
      // The axis keeps its length; the cross-section stays circular (mean of the two scales),
      // square to the axis: under a shear, the local Y and Z lean along it.
      edgeU_ = toWorld.applyToVector({params.length, 0, 0});
      edgeV_ = toWorld.applyToVector({0, params.radius, 0});
      normal_ = toWorld.applyToVector({0, 0, params.radius});
      const Vec3f axis = normalize(edgeU_);
      for (Vec3f* across : {&edgeV_, &normal_})
        if (std::fabs(dot(*across, axis)) > 1e-5f * length(*across))
          *across = *across - axis * dot(*across, axis);
      radius_ = 0.5f * (length(edgeV_) + length(normal_));
      edgeV_ = normalize(edgeV_);
      normal_ = normalize(cross(edgeU_, edgeV_));  // completes the cross-section frame
      area_ = 2 * kPi * radius_ * length(edgeU_);
      break;
    }
    case LightType::Distant: {
      const double halfAngle = std::clamp(0.5 * params.angle * M_PI / 180, 0.0, M_PI);
      cosHalfAngle_ = float(std::cos(halfAngle));
      // 1 - cos(h) = 2 sin²(h/2): exact for the sun's quarter degree, where 1 - cos loses digits.
      oneMinusCosHalfAngle_ = float(2 * std::pow(std::sin(0.5 * halfAngle), 2));
      break;
    }
    case LightType::Dome:
      break;
    case LightType::Mesh: {
      const std::vector<Vec3f>& corners =
          params.meshTriangles ? *params.meshTriangles : std::vector<Vec3f>{};
      std::vector<float> areas;
      for (size_t i = 0; i + 2 < corners.size(); i += 3) {
        areas.push_back(0.5f *
                        length(cross(corners[i + 1] - corners[i], corners[i + 2] - corners[i])));
        area_ += areas.back();
      }
      for (const Vec3f& corner : corners) {
        meshLower_ = componentMin(meshLower_, corner);
        meshUpper_ = componentMax(meshUpper_, corner);
      }
      if (params.meshMotion) {
        const MovingMeshLight& moving = *params.meshMotion;
        if (moving.triangles.triangles.size() != corners.size())
          throw std::invalid_argument("the moving mesh light's triangles are not its own");
        // The light tree's box: where the triangles pass over the shutter, looked at often
        // enough for its importance (it needs no strict bound).
        constexpr int kMoments = 8;
        for (int moment = 1; moment <= kMoments; ++moment) {
          const float time = float(moment) / kMoments;
          const Transform at = moving.objectToWorld.at(time);
          for (uint32_t triangle = 0; 3 * size_t(triangle) < moving.triangles.triangles.size();
               ++triangle)
            for (int k = 0; k < 3; ++k) {
              const Vec3f corner = at.applyToPoint(moving.triangles.cornerAt(triangle, k, time));
              meshLower_ = componentMin(meshLower_, corner);
              meshUpper_ = componentMax(meshUpper_, corner);
            }
        }
      }
      triangleChoice_.emplace(std::move(areas));
      break;
    }
  }
  if (params.type == LightType::Mesh && !(area_ > 0))
    throw std::invalid_argument("the mesh light has no area");
  if (params.type == LightType::Rect || params.type == LightType::Disk) {
    normal_ = toWorld.applyToNormal({0, 0, -1});
    if (!(area_ > 0) || !(length(normal_) > 0))
      throw std::invalid_argument("the light has zero area (check width/height/radius and scale)");
    normal_ = normalize(normal_);
    orthogonalEdges_ = std::fabs(dot(edgeU_, edgeV_)) <= 1e-5f * length(edgeU_) * length(edgeV_);
    if (!orthogonalEdges_) {
      // A shear: the coordinates of centre + a · edgeU + b · edgeV are its offset's products
      // with the dual axes, not its projections on the edges.
      const Vec3f across = cross(edgeU_, edgeV_);
      dualU_ = cross(edgeV_, across) / dot(across, across);
      dualV_ = cross(across, edgeU_) / dot(across, across);
    }
    if (params.type == LightType::Rect && orthogonalEdges_)
      rectangle_ =
          SphericalRectangle::Rectangle(center_ - (edgeU_ + edgeV_) * 0.5f, edgeU_, edgeV_);
  }
  // An authored radius of 0 is a point light (exporters write bulbs so); a sphere scaled to
  // nothing, whatever its radius, is not one (animating the scale to 0 puts lights out).
  pointOnly_ = params.type == LightType::Sphere && params.radius == 0 &&
               std::cbrt(std::fabs(toWorld.linearDeterminant())) > 0;
  if ((params.type == LightType::Sphere || params.type == LightType::Cylinder) && !(area_ > 0) &&
      !pointOnly_)
    throw std::invalid_argument("the light has zero radius or length");
  if (params.normalize) {
    if (params.type == LightType::Distant) {
      // Normalised distant lights give `intensity` as the irradiance on a facing surface: the
      // cone's solid angle projected as UsdLux does it, by |cos|: π sin²(h), where
      // sin²(h) = (1 - cos h)(1 + cos h), and past 90° the back's share too, π (2 - sin²(h)).
      const float sin2 = oneMinusCosHalfAngle_ * (1 + cosHalfAngle_);
      if (!isDelta()) emission = emission / (kPi * (cosHalfAngle_ >= 0 ? sin2 : 2 - sin2));
    } else if (params.type != LightType::Dome && !pointOnly_) {
      emission = emission / area_;
    }
  }
  radiance_ = emission;
  // A point-like sphere's radiant intensity is L · π r², the sphere seen from afar. A radius of
  // 0 takes that of a normalised sphere of any radius, E / 4 (Cycles' Hydra delegate gives the
  // same): the limit of unnormalised spheres is darkness, which no exporter writing a bulb of
  // radius 0 means.
  if (isDelta() && params.type == LightType::Sphere)
    pointProjectedArea_ = pointOnly_ ? 0.25f : kPi * radius_ * radius_;
  if (!isFinite(radiance_) || !isFinite(center_))
    throw std::invalid_argument("the light's parameters or transform are not finite");
  axis_ = normalize(toWorld.applyToVector({0, 0, -1}));
  if (params.type == LightType::Distant) normal_ = axis_;  // the direction the light travels
  if (params.type == LightType::Distant && !isDelta()) {
    coneFrame_.emplace(-normal_);
    conePdf_ = uniformConePdf(oneMinusCosHalfAngle_);
  }
  if (params.type == LightType::Dome) worldToLight_ = toWorld.inverse();
  // UsdLux's cone: the softness is the share of the cone's angle over which emission fades.
  coneCutoff_ = std::clamp(params.coneAngle, 0.0f, 180.0f) * kPi / 180;
  coneSmoothStart_ = coneCutoff_ * (1 - std::clamp(params.coneSoftness, 0.0f, 1.0f));
  coneCosCutoff_ = std::cos(coneCutoff_);
  coneCosSmoothStart_ = std::cos(coneSmoothStart_);
  if (params.ies && !isInfinite()) {
    if (!std::isfinite(params.iesAngleScale))
      throw std::invalid_argument("the IES profile's angle scale is not finite");
    iesWorldToLight_ = toWorld.inverse();
    // Divided by (not times the reciprocal of) the mean: a profile of tiny candelas has a
    // mean whose reciprocal overflows. An all-dark profile stays dark.
    const float mean = params.ies->meanCandela();
    iesDivisor_ = params.iesNormalize && mean > 0 ? mean : 1;
  }
  shaped_ = !isInfinite() && (params.coneAngle < 180 || params.focus > 0 || params.ies);
  // A transform that scales -Z to nothing (a card flattened along Z) leaves no axis to emit along.
  if ((shaped_ || params.type == LightType::Distant) && !isFinite(axis_))
    throw std::invalid_argument(
        "the light's transform collapses its -Z axis, along which it " +
        std::string(params.type == LightType::Distant ? "shines" : "is shaped (ShapingAPI)"));
}

bool Light::isDelta() const {
  return (params_.type == LightType::Sphere && (params_.treatAsPoint || pointOnly_)) ||
         (params_.type == LightType::Distant && !(oneMinusCosHalfAngle_ > 0));
}

Vec3f Light::shaping(const Vec3f& emitted) const {
  if (!shaped_) return Vec3f(1.0f);
  const float cosine = dot(emitted, axis_);
  float cone = 1;
  if (cosine < coneCosCutoff_)
    cone = 0;
  else if (cosine < coneCosSmoothStart_)
    cone = 1 - smoothstep(coneSmoothStart_, coneCutoff_, std::acos(std::min(cosine, 1.0f)));
  Vec3f factor(cone * (params_.ies ? iesFactor(emitted) : 1.0f));
  if (params_.focus > 0) {
    // |cos|: a sphere's or cylinder's emission behind its axis is focused as in front.
    const float focused = std::pow(std::abs(cosine), params_.focus);
    factor *= params_.focusTint + (Vec3f(1.0f) - params_.focusTint) * focused;
  }
  return factor;
}

float Light::iesFactor(const Vec3f& emitted) const {
  // In the light's frame, as hdEmbree evaluates it: the nadir along -Z, horizontal angle 0
  // towards -X and 90° towards -Y.
  const Vec3f local = normalize(iesWorldToLight_.applyToVector(emitted));
  float theta = std::acos(std::clamp(-local.z, -1.0f, 1.0f));
  const float scale = 1 + std::max(params_.iesAngleScale, -1.0f);
  theta = scale > 0 ? std::clamp((theta - kPi) / scale + kPi, 0.0f, kPi) : (theta < kPi ? 0 : kPi);
  return params_.ies->candela(theta, std::atan2(-local.y, -local.x)) / iesDivisor_;
}

Vec2f Light::edgeCoordinates(const Vec3f& point) const {
  const Vec3f offset = point - center_;
  if (orthogonalEdges_)
    return {dot(offset, edgeU_) / dot(edgeU_, edgeU_), dot(offset, edgeV_) / dot(edgeV_, edgeV_)};
  return {dot(offset, dualU_), dot(offset, dualV_)};
}

Vec2f Light::rectUV(const Vec3f& point) const {
  const Vec2f along = edgeCoordinates(point);
  return {along.x + 0.5f, 0.5f - along.y};
}

Vec2f Light::domeUV(const Vec3f& direction, float* sinPolar) const {
  const Vec3f local = normalize(worldToLight_.applyToVector(direction));
  const float latitude = std::asin(std::clamp(local.y, -1.0f, 1.0f));
  const float longitude = std::atan2(local.x, local.z);
  *sinPolar = std::sqrt(local.x * local.x + local.z * local.z);
  return {(kPi - longitude) / (2 * kPi), (kPi / 2 - latitude) / kPi};
}

Vec3f Light::domeDirection(Vec2f uv, float* sinPolar) const {
  const float longitude = kPi * (1 - 2 * uv.x), latitude = kPi * (0.5f - uv.y);
  *sinPolar = std::cos(latitude);
  const Vec3f local = {*sinPolar * std::sin(longitude), std::sin(latitude),
                       *sinPolar * std::cos(longitude)};
  return normalize(params_.lightToWorld.applyToVector(local));
}

std::optional<SphericalRectangle> Light::sphericalRect(const Vec3f& point) const {
  // Textures are sampled by their own distribution; sheared rectangles are parallelograms.
  if (params_.texture || !orthogonalEdges_) return std::nullopt;
  if (!(dot(point - center_, normal_) > 0)) return std::nullopt;  // behind the emitting side
  SphericalRectangle seen(point, rectangle_);
  // Nearly edge-on or far away, the parametrisation loses precision; area sampling is as good.
  if (!(seen.solidAngle() > kMinSphericalSolidAngle)) return std::nullopt;
  return seen;
}

float Light::solidAnglePdfFromArea(const Vec3f& point, const Vec3f& lightPoint,
                                   const Vec3f& lightNormal, float areaDensity) const {
  const Vec3f toLight = lightPoint - point;
  const float distance2 = dot(toLight, toLight);
  const float cosLight = -dot(toLight, lightNormal) / std::sqrt(distance2);
  return cosLight > 0 ? areaDensity * distance2 / cosLight : 0.0f;
}

std::optional<LightSample> Light::sample(const Vec3f& point, Vec2f u, const Vec3f& normal,
                                         float time) const {
  LightSample result;
  Vec3f lightPoint, lightNormal;
  float areaDensity = 1 / area_;
  Vec3f texture(1.0f);
  switch (params_.type) {
    case LightType::Rect:
    case LightType::Disk: {
      Vec2f offset = {u.x - 0.5f, u.y - 0.5f};
      if (params_.type == LightType::Disk) {
        offset = concentricSampleDisk(u);
      } else if (const std::optional<SphericalRectangle> seen = sphericalRect(point)) {
        const Vec3f onLight = seen->sample(u);
        const Vec3f toLight = onLight - point;
        result.distance = length(toLight);
        result.direction = toLight / result.distance;
        result.radiance = radiance_ * shaping(-result.direction);
        result.pdf = float(1 / seen->solidAngle());
        return result;
      } else if (params_.texture) {
        float density = 0;
        const Vec2f uv = params_.texture->distribution().sample(u, &density);
        if (!(density > 0)) return std::nullopt;
        offset = {uv.x - 0.5f, 0.5f - uv.y};
        areaDensity = density / area_;
        texture = params_.texture->lookup(uv);
      }
      lightPoint = center_ + edgeU_ * offset.x + edgeV_ * offset.y;
      lightNormal = normal_;
      break;
    }
    case LightType::Cylinder: {
      // Only the arc of the side that faces the point: the far side would be rejected anyway.
      float middle = 0, halfWidth = 0;
      if (!visibleArc(point, &middle, &halfWidth)) return std::nullopt;
      const float phi = middle + (2 * u.y - 1) * halfWidth;
      lightNormal = edgeV_ * std::cos(phi) + normal_ * std::sin(phi);
      lightPoint = center_ + edgeU_ * (u.x - 0.5f) + lightNormal * radius_;
      areaDensity = 1 / (2 * halfWidth * radius_ * length(edgeU_));
      break;
    }
    case LightType::Mesh: {
      const SurfacePoint drawn = meshPoint(u, time);
      lightPoint = drawn.position;
      lightNormal = drawn.normal;
      if (params_.meshMotion) {
        if (!(drawn.areaOverDensity > 0)) return std::nullopt;  // collapsed at this time
        areaDensity = 1 / drawn.areaOverDensity;
        result.weighingPdf = meshPdf(point, lightPoint, lightNormal);
        if (!(result.weighingPdf > 0)) return std::nullopt;
      }
      break;
    }
    case LightType::Sphere: {
      const Vec3f toCenter = center_ - point;
      const float distance2 = dot(toCenter, toCenter);
      const float distance = std::sqrt(distance2);
      result.direction = toCenter / distance;
      if (isDelta()) {
        result.distance = distance;
        result.radiance =
            radiance_ * shaping(-result.direction) * (pointProjectedArea_ / distance2);
        result.pdf = 1;
        result.isDelta = true;
        return result;
      }
      if (distance <= radius_) return std::nullopt;  // inside: the sphere emits outward only
      // Uniform directions in the cone the sphere subtends (solid-angle sampling).
      const float oneMinusCosMax = oneMinusCosFromSin2(radius_ * radius_ / distance2);
      result.direction =
          normalize(Frame(result.direction).toWorld(sampleUniformCone(u, oneMinusCosMax)));
      const std::optional<float> t = intersectSphere(point, result.direction);
      // Grazing directions may miss by rounding: the tangent distance is then exact enough.
      result.distance = t ? *t : std::sqrt(std::max(0.0f, distance2 - radius_ * radius_));
      result.radiance = radiance_ * shaping(-result.direction);
      result.pdf = uniformConePdf(oneMinusCosMax);
      return result;
    }
    case LightType::Distant:
      result.distance = kInfinity;
      result.radiance = radiance_;
      if (isDelta()) {
        result.direction = -normal_;
        result.pdf = 1;
        result.isDelta = true;
        return result;
      }
      result.direction =
          normalize(coneFrame_->toWorld(sampleUniformCone(u, oneMinusCosHalfAngle_)));
      result.pdf = conePdf_;
      return result;
    case LightType::Dome:
      result.distance = kInfinity;
      if (params_.texture) {
        float density = 0, sinPolar = 0;
        const Vec2f uv = params_.texture->distribution().sample(u, &density);
        result.direction = domeDirection(uv, &sinPolar);
        if (!(density > 0) || !(sinPolar > 0)) return std::nullopt;
        result.radiance = radiance_ * params_.texture->lookup(uv);
        result.pdf = density / (2 * kPi * kPi * sinPolar);
      } else if (isBlack(normal)) {
        result.direction = sampleUniformSphere(u);
        result.radiance = radiance_;
        result.pdf = kUniformSpherePdf;
      } else {
        // A constant sky seen from a surface: cosine-weighted directions make the estimate of
        // its (unoccluded) irradiance exact.
        const Vec3f local = sampleCosineHemisphere(u);
        if (!(local.z > 0)) return std::nullopt;
        result.direction = normalize(Frame(normal).toWorld(local));
        result.radiance = radiance_;
        result.pdf = cosineHemispherePdf(local.z);
      }
      return result;
  }
  result.pdf = solidAnglePdfFromArea(point, lightPoint, lightNormal, areaDensity);
  if (!(result.pdf > 0)) return std::nullopt;
  const Vec3f toLight = lightPoint - point;
  result.distance = length(toLight);
  result.direction = toLight / result.distance;
  result.radiance = radianceLeaving(texture, -result.direction);
  return result;
}

std::optional<Light::Outline> Light::outline() const {
  if (isDelta()) return std::nullopt;
  switch (params_.type) {
    case LightType::Sphere:
      return Outline{LightType::Sphere, center_, Vec3f(0.0f), Vec3f(0.0f), radius_};
    case LightType::Rect:  // its edges are whole sides
      return Outline{LightType::Rect, center_, edgeU_ * 0.5f, edgeV_ * 0.5f, 0};
    case LightType::Disk:  // its edges are semi-axes
      return Outline{LightType::Disk, center_, edgeU_, edgeV_, 0};
    default:
      return std::nullopt;
  }
}

bool Light::emitsFromSurface() const {
  const bool shape = params_.type == LightType::Sphere || params_.type == LightType::Rect ||
                     params_.type == LightType::Disk || params_.type == LightType::Cylinder ||
                     params_.type == LightType::Mesh;
  return shape && !isDelta();
}

Light::SurfacePoint Light::meshPoint(Vec2f u, float time) const {
  float within = 0;
  const size_t triangle = triangleChoice_->sampleIndex(u.x, &within);
  const Vec3f weights = sampleUniformTriangle({within, u.y});
  Vec3f corner[3];
  if (params_.meshMotion) {  // where the traced geometry has the triangle at `time`
    const MovingMeshLight& moving = *params_.meshMotion;
    const Transform toWorld = moving.objectToWorld.at(time);
    for (int k = 0; k < 3; ++k)
      corner[k] = toWorld.applyToPoint(moving.triangles.cornerAt(uint32_t(triangle), k, time));
  } else {
    for (int k = 0; k < 3; ++k) corner[k] = (*params_.meshTriangles)[3 * triangle + size_t(k)];
  }
  const Vec3f across = cross(corner[1] - corner[0], corner[2] - corner[0]);
  // A moving triangle moves as a whole, so a point uniform by area at shutter open is uniform
  // by area now; its density by area now is the triangle's probability over its area now.
  const float areaOverDensity =
      params_.meshMotion ? 0.5f * length(across) / triangleChoice_->probability(triangle) : area_;
  return SurfacePoint{corner[0] * weights.x + corner[1] * weights.y + corner[2] * weights.z,
                      normalize(across), Vec3f(1.0f), areaOverDensity};
}

std::optional<Light::SurfacePoint> Light::sampleSurface(Vec2f u) const {
  const Vec3f untextured(1.0f);
  switch (params_.type) {
    case LightType::Sphere: {
      const Vec3f normal = sampleUniformSphere(u);
      return SurfacePoint{center_ + normal * radius_, normal, untextured, area_};
    }
    case LightType::Rect: {
      if (!params_.texture)
        return SurfacePoint{center_ + edgeU_ * (u.x - 0.5f) + edgeV_ * (u.y - 0.5f), normal_,
                            untextured, area_};
      float density = 0;
      const Vec2f uv = params_.texture->distribution().sample(u, &density);
      if (!(density > 0)) return std::nullopt;
      return SurfacePoint{center_ + edgeU_ * (uv.x - 0.5f) + edgeV_ * (0.5f - uv.y), normal_,
                          params_.texture->lookup(uv), area_ / density};
    }
    case LightType::Mesh:
      return meshPoint(u, 0);
    case LightType::Cylinder: {  // its side (the caps emit nothing): u.x along the axis
      const float phi = 2 * kPi * u.y;
      const Vec3f normal = edgeV_ * std::cos(phi) + normal_ * std::sin(phi);
      return SurfacePoint{center_ + edgeU_ * (u.x - 0.5f) + normal * radius_, normal, untextured,
                          area_};
    }
    default: {  // a disk: its edges are semi-axes
      const Vec2f d = concentricSampleDisk(u);
      return SurfacePoint{center_ + edgeU_ * d.x + edgeV_ * d.y, normal_, untextured, area_};
    }
  }
}

std::optional<float> Light::intersectSphere(const Vec3f& origin, const Vec3f& direction) const {
  const Vec3f toOrigin = origin - center_;
  const float b = dot(toOrigin, direction);
  // Discriminant from the distance of the centre to the line (robust for distant spheres).
  const Vec3f perpendicular = toOrigin - direction * b;
  const float discriminant = radius_ * radius_ - dot(perpendicular, perpendicular);
  if (discriminant < 0) return std::nullopt;
  // Only the near root counts: from inside, the outward-emitting surface faces away.
  const float tNear = -b - std::sqrt(discriminant);
  if (tNear > 0) return tNear;
  return std::nullopt;
}

bool Light::visibleArc(const Vec3f& point, float* middle, float* halfWidth) const {
  const Vec3f axis = normalize(edgeU_);
  const Vec3f toPoint = point - center_;
  const Vec3f across = toPoint - axis * dot(toPoint, axis);
  const float distance = length(across);
  if (!(distance > radius_)) return false;
  *middle = std::atan2(dot(across, normal_), dot(across, edgeV_));
  *halfWidth = std::acos(radius_ / distance);
  return *halfWidth > 0;
}

std::optional<float> Light::intersectCylinder(const Vec3f& origin, const Vec3f& direction,
                                              Vec3f* normal) const {
  const float axisLength = length(edgeU_);
  const Vec3f axis = edgeU_ / axisLength;
  const Vec3f toOrigin = origin - center_;
  const Vec3f o = toOrigin - axis * dot(toOrigin, axis);
  const Vec3f d = direction - axis * dot(direction, axis);
  const float a = dot(d, d), b = dot(o, d), c = dot(o, o) - radius_ * radius_;
  const float discriminant = b * b - a * c;
  if (!(a > 0) || discriminant < 0) return std::nullopt;
  // The side emits outward: only the near root, seen from outside, counts.
  const float t = (-b - std::sqrt(discriminant)) / a;
  if (!(t > 0) || c < 0) return std::nullopt;
  const float along = dot(toOrigin + direction * t, axis);
  if (std::fabs(along) > 0.5f * axisLength) return std::nullopt;
  *normal = normalize(o + d * t);
  return t;
}

std::optional<LightHit> Light::intersect(const Vec3f& origin, const Vec3f& direction,
                                         float tMax) const {
  // Mesh lights are met as geometry (SurfaceHit::lightIndex), not here.
  if (!isAreaLight()) return std::nullopt;
  LightHit hit;
  if (params_.type == LightType::Sphere) {
    const std::optional<float> t = intersectSphere(origin, direction);
    if (!t || *t >= tMax) return std::nullopt;
    const Vec3f toCenter = center_ - origin;
    hit.distance = *t;
    hit.radiance = radiance_ * shaping(-direction);
    hit.pdf = uniformConePdf(oneMinusCosFromSin2(radius_ * radius_ / dot(toCenter, toCenter)));
    return hit;
  }
  if (params_.type == LightType::Cylinder) {
    Vec3f surfaceNormal;
    const std::optional<float> t = intersectCylinder(origin, direction, &surfaceNormal);
    if (!t || *t >= tMax) return std::nullopt;
    float middle = 0, halfWidth = 0;
    if (!visibleArc(origin, &middle, &halfWidth)) return std::nullopt;
    hit.distance = *t;
    hit.radiance = radiance_ * shaping(-direction);
    hit.pdf = solidAnglePdfFromArea(origin, origin + direction * *t, surfaceNormal,
                                    1 / (2 * halfWidth * radius_ * length(edgeU_)));
    return hit;
  }
  const float facing = dot(direction, normal_);
  if (facing >= 0) return std::nullopt;  // one-sided emitters are seen from the -Z side only
  const float t = dot(center_ - origin, normal_) / facing;
  if (!(t > 0) || t >= tMax) return std::nullopt;
  const Vec3f point = origin + direction * t;
  const auto [a, b] = edgeCoordinates(point);
  const bool inside = params_.type == LightType::Rect
                          ? (std::fabs(a) <= 0.5f && std::fabs(b) <= 0.5f)
                          : (a * a + b * b <= 1);
  if (!inside) return std::nullopt;
  float areaDensity = 1 / area_;
  Vec3f texture(1.0f);
  if (params_.type == LightType::Rect && params_.texture) {
    const Vec2f uv = rectUV(point);
    texture = params_.texture->lookup(uv);
    areaDensity = params_.texture->distribution().density(uv) / area_;
  }
  hit.distance = t;
  hit.radiance = radianceLeaving(texture, -direction);
  const std::optional<SphericalRectangle> seen =
      params_.type == LightType::Rect ? sphericalRect(origin) : std::nullopt;
  hit.pdf = seen ? float(1 / seen->solidAngle())
                 : solidAnglePdfFromArea(origin, point, normal_, areaDensity);
  return hit;
}

std::optional<LightHit> Light::escaped(const Vec3f& direction, const Vec3f& normal) const {
  if (!isInfinite() || isDelta()) return std::nullopt;
  LightHit hit;
  hit.distance = kInfinity;
  hit.radiance = radiance_;
  if (params_.type == LightType::Dome) {
    hit.pdf = isBlack(normal) ? kUniformSpherePdf
                              : cosineHemispherePdf(std::max(0.0f, dot(direction, normal)));
    if (params_.texture) {
      float sinPolar = 0;
      const Vec2f uv = domeUV(direction, &sinPolar);
      hit.radiance = radiance_ * params_.texture->lookup(uv);
      hit.pdf = sinPolar > 0
                    ? params_.texture->distribution().density(uv) / (2 * kPi * kPi * sinPolar)
                    : 0;
    }
    return hit;
  }
  if (dot(direction, -normal_) < cosHalfAngle_) return std::nullopt;
  hit.pdf = conePdf_;
  return hit;
}

float Light::meshPdf(const Vec3f& origin, const Vec3f& point, const Vec3f& normal) const {
  return solidAnglePdfFromArea(origin, point, normal, 1 / area_);
}

Vec3f Light::meanRadiance() const {
  return params_.texture ? radiance_ * params_.texture->average() : radiance_;
}

float Light::meanRadianceGrey() const {
  return std::max(0.0f, average(meanRadiance()));
}

LightBounds Light::bounds() const {
  LightBounds bounds;
  const float radianceGrey = meanRadianceGrey();
  const auto include = [&bounds](const Vec3f& p) {
    bounds.lower = componentMin(bounds.lower, p);
    bounds.upper = componentMax(bounds.upper, p);
  };
  bounds.cosThetaO = -1;  // emits every way, unless one-sided below
  switch (params_.type) {
    case LightType::Rect:
    case LightType::Disk:
      // Disks: the parallelogram of their semi-axes holds them.
      for (const float a : {-1.0f, 1.0f})
        for (const float b : {-1.0f, 1.0f})
          include(center_ + edgeU_ * (params_.type == LightType::Rect ? 0.5f * a : a) +
                  edgeV_ * (params_.type == LightType::Rect ? 0.5f * b : b));
      bounds.power = radianceGrey * area_;
      bounds.axis = normal_;
      bounds.cosThetaO = 1;
      break;
    case LightType::Sphere:
      include(center_ - Vec3f(radius_));
      include(center_ + Vec3f(radius_));
      bounds.power =
          pointOnly_ ? radianceGrey * pointProjectedArea_ : radianceGrey * kPi * radius_ * radius_;
      break;
    case LightType::Cylinder:
      for (const float end : {-0.5f, 0.5f}) {
        include(center_ + edgeU_ * end - Vec3f(radius_));
        include(center_ + edgeU_ * end + Vec3f(radius_));
      }
      bounds.power = radianceGrey * 2 * radius_ * length(edgeU_);
      break;
    case LightType::Mesh:
      include(meshLower_);
      include(meshUpper_);
      bounds.power = radianceGrey * area_;
      break;
    case LightType::Distant:
    case LightType::Dome:
      break;  // infinite lights are not in the tree
  }
  // An IES profile scales what the light emits by its mean factor (over the directions it
  // covers), which the tree's choice should know: raw candelas are in the hundreds.
  if (params_.ies && shaped_) bounds.power *= params_.ies->meanCandela() / iesDivisor_;
  return bounds;
}

float Light::irradiance() const {
  const float radianceGrey = meanRadianceGrey();
  if (params_.type == LightType::Dome) return kPi * radianceGrey;
  if (params_.type == LightType::Distant && !isDelta()) {
    // A cone wider than the hemisphere lights a facing surface with its front half alone.
    const float sin2 = oneMinusCosHalfAngle_ * (1 + cosHalfAngle_);
    return radianceGrey * kPi * (cosHalfAngle_ >= 0 ? sin2 : 1);
  }
  return radianceGrey;
}

}  // namespace penumbra
