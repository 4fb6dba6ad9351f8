// Pinhole and thin-lens cameras with UsdGeomCamera's parameters (docs/design.md §3): focal length
// and apertures in tenths of a scene unit, distances in scene units, looking down -Z with +Y up.
#pragma once

#include <optional>
#include <vector>

#include "penumbra/motion.h"

namespace penumbra {

struct Ray {
  Vec3f origin;
  Vec3f direction;  // unit length
  float tNear = 0;
  float tFar = kInfinity;
  float time = 0;  // normalised shutter time in [0, 1]
};

/// A ray's footprint as a cone: radius `width` at the origin, growing by `spread` per unit of
/// distance. Texture lookups are filtered over it; the zero cone point-samples them.
struct RayCone {
  float width = 0;
  float spread = 0;
  float radiusAt(float distance) const { return width + spread * distance; }
};

enum class Projection { Perspective, Orthographic };

/// Where a point appears in the image at one moment of the shutter: through the lens point
/// d of the unit disk (the lens sample's concentricSampleDisk), at `position + perLensUnit ∘ d`
/// (pixels, x right, y down; the position is affine in the lens point).
struct PointImage {
  Vec2f position;
  Vec2f perLensUnit;  // {0, 0} for a pinhole
};

struct CameraParams {
  MotionTransform cameraToWorld;
  Projection projection = Projection::Perspective;
  float focalLength = 50;  // tenths of a scene unit
  float horizontalAperture = 20.955f;
  float verticalAperture = 15.2908f;
  float horizontalApertureOffset = 0;
  float verticalApertureOffset = 0;
  float pixelAspectRatio = 1;  // width / height of one pixel on the film
  float fStop = 0;             // 0: pinhole
  float focusDistance = 0;     // scene units
  float nearClip = 1;          // scene units, along the view axis
  float farClip = 1e6f;
  float shutterOpen = 0;  // time codes relative to the frame
  float shutterClose = 0;
  // UsdGeomCamera's linear exposure scale (2^exposure · time · ISO / 100 · responsivity /
  // fStop², its exposure:* inputs): multiplies the radiance an image of the film shows, not
  // what a sample is (render passes apply it when they resolve colour).
  float exposureScale = 1;
  // Animated lens over the shutter: uniformly spaced samples; empty means the scalars above.
  std::vector<float> focalLengthSteps;
  std::vector<float> focusDistanceSteps;
};

/// A camera bound to an image resolution. The aperture is fitted to the image aspect
/// (pixelAspectRatio · width / height) by expanding it (UsdRenderSettings' default conform
/// policy, "expandAperture").
class Camera {
 public:
  /// Throws std::invalid_argument for non-positive sizes or apertures.
  Camera(const CameraParams& params, int imageWidth, int imageHeight);

  /// Ray through continuous image position (x right, y down, in pixels; (0,0) is the top-left
  /// corner of the image), a uniform lens sample and a normalised shutter time in [0, 1].
  Ray generateRay(float imageX, float imageY, Vec2f lensSample, float time = 0) const;
  /// The footprint of one pixel as a ray cone (scene units): for perspective cameras the angle
  /// a pixel subtends at the image centre, for orthographic ones a pixel's width. The lens
  /// aperture is not included (defocus blurs by sampling the lens, not by filtering).
  RayCone pixelCone() const { return pixelCone_; }
  /// Distance along the view axis of the point at parameter t of a ray this camera generated.
  float viewDepth(const Ray& ray, float t) const;
  /// The camera's centre (the pinhole, or the lens's centre) at normalised shutter time `time`.
  Vec3f centre(float time) const;
  /// A world-space direction in camera space (+X right, +Y up, looking down -Z) at `time`.
  Vec3f toCameraSpace(const Vec3f& direction, float time) const;

  /// True if neither the camera's transform nor its lens changes over the shutter.
  bool isStatic() const;
  /// The camera at one moment of the shutter, as pointImage() needs it (made once for many
  /// points).
  struct Moment {
    Transform worldToCamera;
    float focalLength = 0, focusDistance = 0, lensRadius = 0;
  };
  Moment momentAt(float time) const;
  /// Where `point` (world space) appears in the image (PointImage) at `moment`; none when it is
  /// not between the clipping planes (or not in front of the lens). Camera rays at that moment
  /// through that image position and lens point pass through `point`.
  std::optional<PointImage> pointImage(const Vec3f& point, const Moment& moment) const;
  /// The camera rays through lens point `lensSample` (a uniform sample, as generateRay's) at
  /// normalised shutter time `time`, as one family over image positions: the ray through (x, y)
  /// leaves `origin` along `direction + x · perImageX + y · perImageY` (world space, not of unit
  /// length), as generateRay makes it up to rounding. None for orthographic cameras, whose rays
  /// share a direction rather than an origin.
  struct RayFamily {
    Vec3d origin, direction, perImageX, perImageY;
  };
  std::optional<RayFamily> rayFamily(Vec2f lensSample, float time) const;
  int imageWidth() const { return width_; }
  int imageHeight() const { return height_; }

  /// Lens radius in scene units (0 for a pinhole) at the start of the shutter.
  float lensRadius() const { return lensRadiusAt(0); }
  /// Fitted film window size in tenths of a scene unit.
  float filmWidth() const { return filmWidth_; }
  float filmHeight() const { return filmHeight_; }
  const CameraParams& params() const { return params_; }

 private:
  float focalLengthAt(float time) const;
  float focusDistanceAt(float time) const;
  float lensRadiusAt(float time) const;
  /// The unit view axis (the camera's -Z in world space).
  Vec3f viewAxisAt(float time) const;

  CameraParams params_;
  int width_, height_;
  float filmWidth_, filmHeight_;
  bool thinLens_;
  // viewAxisAt of a camera that does not move, made once: viewDepth asks at every camera sample.
  std::optional<Vec3f> staticViewAxis_;
  RayCone pixelCone_;  // made once: every camera sample starts its ray cone from it
};

}  // namespace penumbra
