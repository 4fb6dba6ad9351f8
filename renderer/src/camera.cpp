#include "penumbra/camera.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "penumbra/warp.h"

namespace penumbra {

Camera::Camera(const CameraParams& params, int imageWidth, int imageHeight)
    : params_(params), width_(imageWidth), height_(imageHeight) {
  if (imageWidth <= 0 || imageHeight <= 0)
    throw std::invalid_argument("image size must be positive, got " + std::to_string(imageWidth) +
                                "x" + std::to_string(imageHeight));
  if (!(params.horizontalAperture > 0) || !(params.verticalAperture > 0))
    throw std::invalid_argument("camera apertures must be positive");
  if (!(params.pixelAspectRatio > 0) || !std::isfinite(params.pixelAspectRatio))
    throw std::invalid_argument("pixel aspect ratio must be positive");
  if (params.projection == Projection::Perspective && !(params.focalLength > 0))
    throw std::invalid_argument("camera focalLength must be positive");
  const float imageAspect = params.pixelAspectRatio * float(imageWidth) / float(imageHeight);
  const float apertureAspect = params.horizontalAperture / params.verticalAperture;
  filmWidth_ = params.horizontalAperture;
  filmHeight_ = params.verticalAperture;
  if (imageAspect > apertureAspect)
    filmWidth_ = filmHeight_ * imageAspect;
  else
    filmHeight_ = filmWidth_ / imageAspect;
  thinLens_ =
      params.projection == Projection::Perspective && params.fStop > 0 && params.focusDistance > 0;
  for (const float focalLength : params.focalLengthSteps)
    if (!(focalLength > 0))
      throw std::invalid_argument("camera focalLength samples must be positive");
  if (!params_.cameraToWorld.isAnimated()) staticViewAxis_ = viewAxisAt(0);
  // The side of a square of a pixel's film area (pixels are square unless pixelAspectRatio),
  // in tenths of a unit.
  const float pixelFilm = std::sqrt(filmWidth_ / float(width_) * filmHeight_ / float(height_));
  pixelCone_ = params_.projection == Projection::Orthographic
                   ? RayCone{0.1f * pixelFilm, 0.0f}
                   : RayCone{0.0f, pixelFilm / focalLengthAt(0)};
}

namespace {
/// A lens parameter at a normalised time: uniformly spaced samples, or the scalar when none.
float sampledAt(const std::vector<float>& steps, float scalar, float time) {
  if (steps.empty()) return scalar;
  if (steps.size() == 1) return steps.front();
  const StepPosition where = locateStep(steps.size(), time);
  return (1 - where.fraction) * steps[where.step] + where.fraction * steps[where.step + 1];
}
}  // namespace

float Camera::focalLengthAt(float time) const {
  return sampledAt(params_.focalLengthSteps, params_.focalLength, time);
}

float Camera::focusDistanceAt(float time) const {
  return sampledAt(params_.focusDistanceSteps, params_.focusDistance, time);
}

// f = 0.1 · focalLength scene units; R = f / (2 N).
float Camera::lensRadiusAt(float time) const {
  return thinLens_ ? 0.1f * focalLengthAt(time) / (2 * params_.fStop) : 0.0f;
}

Ray Camera::generateRay(float imageX, float imageY, Vec2f lensSample, float time) const {
  // Position on the film window, in tenths of a scene unit, relative to the optical axis.
  const float filmX = params_.horizontalApertureOffset + (imageX / width_ - 0.5f) * filmWidth_;
  const float filmY = params_.verticalApertureOffset + (0.5f - imageY / height_) * filmHeight_;
  Vec3f origin, direction;
  if (params_.projection == Projection::Orthographic) {
    origin = {0.1f * filmX, 0.1f * filmY, 0};
    direction = {0, 0, -1};
  } else {
    const float focalLength = focalLengthAt(time);
    direction = {filmX / focalLength, filmY / focalLength, -1};
    if (thinLens_) {
      // Rays through the lens converge where the pinhole ray meets the plane of focus.
      const Vec3f focusPoint = direction * focusDistanceAt(time);
      const Vec2f lens = concentricSampleDisk(lensSample);
      const float radius = lensRadiusAt(time);
      origin = {radius * lens.x, radius * lens.y, 0};
      direction = focusPoint - origin;
    }
  }
  direction = normalize(direction);
  Ray ray;
  // Clipping distances are measured along the view axis, where -direction.z is the cosine.
  ray.tNear = params_.nearClip / -direction.z;
  ray.tFar = params_.farClip / -direction.z;
  ray.time = time;
  const Transform cameraToWorld = params_.cameraToWorld.at(time);
  const Vec3f worldOrigin = cameraToWorld.applyToPoint(origin);
  const Vec3f worldDirection = cameraToWorld.applyToVector(direction);
  const float scale = length(worldDirection);
  ray.origin = worldOrigin;
  ray.direction = worldDirection / scale;
  ray.tNear *= scale;
  ray.tFar *= scale;
  return ray;
}

bool Camera::isStatic() const {
  return !params_.cameraToWorld.isAnimated() && params_.focalLengthSteps.size() <= 1 &&
         params_.focusDistanceSteps.size() <= 1;
}

Camera::Moment Camera::momentAt(float time) const {
  return {params_.cameraToWorld.at(time).inverse(), focalLengthAt(time), focusDistanceAt(time),
          lensRadiusAt(time)};
}

std::optional<PointImage> Camera::pointImage(const Vec3f& point, const Moment& moment) const {
  const Vec3f q = moment.worldToCamera.applyToPoint(point);
  const float viewDepth = -q.z;  // in camera units, as generateRay's clipping distances
  // In front of the lens too, whatever the near clip: a projection is only an image there.
  if (!(viewDepth > std::max(params_.nearClip, 0.0f)) || !(viewDepth < params_.farClip))
    return std::nullopt;
  // generateRay backwards: from the film window (tenths of a unit) to pixels.
  const auto toImage = [&](float filmX, float filmY) {
    return Vec2f{((filmX - params_.horizontalApertureOffset) / filmWidth_ + 0.5f) * width_,
                 (0.5f - (filmY - params_.verticalApertureOffset) / filmHeight_) * height_};
  };
  if (params_.projection == Projection::Orthographic)
    return PointImage{toImage(10 * q.x, 10 * q.y), {0, 0}};
  const float focalLength = moment.focalLength;
  PointImage image{toImage(q.x * focalLength / viewDepth, q.y * focalLength / viewDepth), {0, 0}};
  if (thinLens_) {
    // The ray from lens point l through q meets the plane of focus (depth D) at
    // q·D/depth + l·(1 − D/depth), which the film sees at focalLength / D times that.
    const float focus = moment.focusDistance;
    const float filmPerLensUnit = moment.lensRadius * (1 - focus / viewDepth) * focalLength / focus;
    image.perLensUnit = {filmPerLensUnit / filmWidth_ * width_,
                         -filmPerLensUnit / filmHeight_ * height_};
  }
  return image;
}

std::optional<Camera::RayFamily> Camera::rayFamily(Vec2f lensSample, float time) const {
  if (params_.projection != Projection::Perspective) return std::nullopt;
  // generateRay's camera-space direction before normalising: the film position over the focal
  // length and -1, through a lens scaled by the focus distance, less the lens point.
  const double focalLength = focalLengthAt(time);
  const double scale = thinLens_ ? double(focusDistanceAt(time)) : 1.0;
  double lensX = 0, lensY = 0;
  if (thinLens_) {
    const Vec2f lens = concentricSampleDisk(lensSample);
    const double radius = lensRadiusAt(time);
    lensX = radius * lens.x;
    lensY = radius * lens.y;
  }
  const Transform toWorld = params_.cameraToWorld.at(time);
  const auto toWorldVector = [&](double x, double y, double z) {
    return Vec3d{x * toWorld.at(0, 0) + y * toWorld.at(1, 0) + z * toWorld.at(2, 0),
                 x * toWorld.at(0, 1) + y * toWorld.at(1, 1) + z * toWorld.at(2, 1),
                 x * toWorld.at(0, 2) + y * toWorld.at(1, 2) + z * toWorld.at(2, 2)};
  };
  RayFamily family;
  family.origin = toWorldVector(lensX, lensY, 0);
  for (int axis = 0; axis < 3; ++axis) family.origin[size_t(axis)] += toWorld.at(3, axis);
  family.direction = toWorldVector(
      scale * (params_.horizontalApertureOffset - 0.5 * filmWidth_) / focalLength - lensX,
      scale * (params_.verticalApertureOffset + 0.5 * filmHeight_) / focalLength - lensY, -scale);
  family.perImageX = toWorldVector(scale * filmWidth_ / (double(width_) * focalLength), 0, 0);
  family.perImageY = toWorldVector(0, -scale * filmHeight_ / (double(height_) * focalLength), 0);
  return family;
}

Vec3f Camera::viewAxisAt(float time) const {
  return normalize(params_.cameraToWorld.at(time).applyToVector({0, 0, -1}));
}

float Camera::viewDepth(const Ray& ray, float t) const {
  const Vec3f viewAxis = staticViewAxis_ ? *staticViewAxis_ : viewAxisAt(ray.time);
  return t * dot(ray.direction, viewAxis);
}

Vec3f Camera::centre(float time) const {
  return params_.cameraToWorld.at(time).applyToPoint(Vec3f(0.0f));
}

Vec3f Camera::toCameraSpace(const Vec3f& direction, float time) const {
  // Projections on the camera's unit axes: the inverse rotation, whatever the transform's scale.
  const Transform cameraToWorld = params_.cameraToWorld.at(time);
  return {dot(direction, normalize(cameraToWorld.applyToVector({1, 0, 0}))),
          dot(direction, normalize(cameraToWorld.applyToVector({0, 1, 0}))),
          dot(direction, normalize(cameraToWorld.applyToVector({0, 0, 1})))};
}

}  // namespace penumbra
