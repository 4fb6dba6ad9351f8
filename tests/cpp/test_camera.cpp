#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/warp.h"

using namespace penumbra;

namespace {

// The camera of tests/assets/cornell.usda: 35 mm lens on a 36 x 20.25 mm film, metres.
CameraParams cornellCamera() {
  CameraParams params;
  params.focalLength = 0.35f;
  params.horizontalAperture = 0.36f;
  params.verticalAperture = 0.2025f;
  const double matrix[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 4.45679, 1};
  params.cameraToWorld = Transform::fromRowMajor(matrix);
  params.nearClip = 0.05f;
  params.farClip = 1000;
  return params;
}

void expectNear(const Vec3f& a, const Vec3f& b, float tolerance) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

}  // namespace

TEST(Camera, PinholeRaysMatchHandComputedDirections) {
  const Camera camera(cornellCamera(), 640, 360);
  // Image centre: straight down -Z from the camera position.
  const Ray centre = camera.generateRay(320, 180, {0.5f, 0.5f});
  expectNear(centre.origin, {0, 1, 4.45679f}, 1e-5f);
  expectNear(centre.direction, {0, 0, -1}, 1e-6f);
  // Top-left corner: film point (-0.18, +0.10125) in tenths, focal length 0.35.
  const Ray corner = camera.generateRay(0, 0, {0.5f, 0.5f});
  expectNear(corner.direction, normalize(Vec3f(-0.18f / 0.35f, 0.10125f / 0.35f, -1)), 1e-6f);
  // Bottom-right corner mirrors it.
  const Ray opposite = camera.generateRay(640, 360, {0.5f, 0.5f});
  expectNear(opposite.direction, normalize(Vec3f(0.18f / 0.35f, -0.10125f / 0.35f, -1)), 1e-6f);
}

TEST(Camera, ClippingRangeIsMeasuredAlongTheViewAxis) {
  const Camera camera(cornellCamera(), 640, 360);
  const Ray corner = camera.generateRay(0, 0, {0.5f, 0.5f});
  EXPECT_NEAR(corner.tNear * -corner.direction.z, 0.05f, 1e-6f);
  EXPECT_NEAR(camera.viewDepth(corner, corner.tFar), 1000, 1e-2f);
}

TEST(Camera, ApertureExpandsToTheImageAspect) {
  // A square image from a 16:9 aperture keeps the width and grows the height.
  const Camera camera(cornellCamera(), 100, 100);
  EXPECT_FLOAT_EQ(camera.filmWidth(), 0.36f);
  EXPECT_FLOAT_EQ(camera.filmHeight(), 0.36f);
  const Ray top = camera.generateRay(50, 0, {0.5f, 0.5f});
  expectNear(top.direction, normalize(Vec3f(0, 0.18f / 0.35f, -1)), 1e-6f);
}

TEST(Camera, ApertureOffsetsShiftTheFilm) {
  CameraParams params = cornellCamera();
  params.horizontalApertureOffset = 0.035f;
  const Camera camera(params, 640, 360);
  const Ray centre = camera.generateRay(320, 180, {0.5f, 0.5f});
  expectNear(centre.direction, normalize(Vec3f(0.1f, 0, -1)), 1e-6f);
}

TEST(Camera, ThinLensRaysConvergeOnThePlaneOfFocus) {
  CameraParams params = cornellCamera();
  params.fStop = 2;
  params.focusDistance = 3;
  const Camera camera(params, 640, 360);
  // f = 0.035 m, R = f / (2 N).
  EXPECT_NEAR(camera.lensRadius(), 0.035f / 4, 1e-7f);
  const Ray pinhole = camera.generateRay(100, 50, {0.5f, 0.5f});
  const Vec3f focus = pinhole.origin + pinhole.direction * (3 / -pinhole.direction.z);
  float spread = 0;
  for (const Vec2f lens : {Vec2f{0.1f, 0.2f}, Vec2f{0.9f, 0.5f}, Vec2f{0.3f, 0.95f}}) {
    const Ray ray = camera.generateRay(100, 50, lens);
    const Vec3f hit = ray.origin + ray.direction * (3 / -ray.direction.z);
    expectNear(hit, focus, 1e-5f);
    spread = std::max(spread, length(ray.origin - pinhole.origin));
  }
  EXPECT_GT(spread, 0.5f * camera.lensRadius());
  EXPECT_LE(spread, camera.lensRadius() * 1.0001f);
}

TEST(Camera, FStopZeroIsAPinhole) {
  CameraParams params = cornellCamera();
  params.focusDistance = 3;
  EXPECT_EQ(Camera(params, 64, 36).lensRadius(), 0);
}

TEST(Camera, RejectsBadParameters) {
  CameraParams params = cornellCamera();
  EXPECT_THROW(Camera(params, 0, 10), std::invalid_argument);
  params.horizontalAperture = 0;
  EXPECT_THROW(Camera(params, 10, 10), std::invalid_argument);
}

TEST(Camera, PixelAspectRatioStretchesPixelsOnTheFilm) {
  // 100 x 100 pixels twice as wide as high cover a 2:1 aperture without expanding it.
  CameraParams params = cornellCamera();
  params.horizontalAperture = 0.4f;
  params.verticalAperture = 0.2f;
  params.pixelAspectRatio = 2;
  const Camera camera(params, 100, 100);
  EXPECT_FLOAT_EQ(camera.filmWidth(), 0.4f);
  EXPECT_FLOAT_EQ(camera.filmHeight(), 0.2f);
  const Ray corner = camera.generateRay(100, 0, {0.5f, 0.5f});
  expectNear(corner.direction, normalize(Vec3f(0.2f / 0.35f, 0.1f / 0.35f, -1)), 1e-6f);
  params.pixelAspectRatio = 0;
  EXPECT_THROW(Camera(params, 100, 100), std::invalid_argument);
}

TEST(Camera, PointImageIsWhereCameraRaysThroughThePointCameFrom) {
  // A turned, offset camera with a non-square pixel aspect: pinhole, thin lens, orthographic,
  // and a thin lens that moves, zooms and refocuses over the shutter.
  CameraParams params = cornellCamera();
  const double turned[16] = {0.8, 0, -0.6, 0, 0, 1, 0, 0, 0.6, 0, 0.8, 0, 1, 2, 3, 1};
  params.cameraToWorld = Transform::fromRowMajor(turned);
  params.horizontalApertureOffset = 0.02f;
  params.verticalApertureOffset = -0.01f;
  params.pixelAspectRatio = 1.25f;
  CameraParams thinLens = params;
  thinLens.fStop = 1.4f;
  thinLens.focusDistance = 3;
  CameraParams orthographic = params;
  orthographic.projection = Projection::Orthographic;
  // 3.6 units wide, so that a pixel is well above the rounding of points 40 units away.
  orthographic.horizontalAperture *= 100;
  orthographic.verticalAperture *= 100;
  CameraParams moving = thinLens;
  const double later[16] = {0.6, 0, -0.8, 0, 0, 1, 0, 0, 0.8, 0, 0.6, 0, 1.5, 2, 2.5, 1};
  moving.cameraToWorld = MotionTransform(
      std::vector<Transform>{Transform::fromRowMajor(turned), Transform::fromRowMajor(later)});
  moving.focalLengthSteps = {0.35f, 0.5f, 0.4f};
  moving.focusDistanceSteps = {3, 2};
  for (const CameraParams& lens : {params, thinLens, orthographic, moving}) {
    const Camera camera(lens, 320, 200);
    for (const float time : {0.0f, 0.37f, 0.9f})
      for (const Vec2f position : {Vec2f{10.5f, 20.25f}, Vec2f{160, 100}, Vec2f{300.75f, 190.5f}})
        for (const Vec2f lensSample : {Vec2f{0.5f, 0.5f}, Vec2f{0.1f, 0.8f}, Vec2f{0.95f, 0.3f}})
          for (const float distance : {1.5f, 3.0f, 40.0f}) {
            const Ray ray = camera.generateRay(position.x, position.y, lensSample, time);
            const std::optional<PointImage> image =
                camera.pointImage(ray.origin + ray.direction * distance, camera.momentAt(time));
            ASSERT_TRUE(image);
            const Vec2f lensPoint = concentricSampleDisk(lensSample);
            EXPECT_NEAR(image->position.x + image->perLensUnit.x * lensPoint.x, position.x, 2e-3f);
            EXPECT_NEAR(image->position.y + image->perLensUnit.y * lensPoint.y, position.y, 2e-3f);
            if (lens.fStop == 0) {
              EXPECT_EQ(image->perLensUnit.x, 0);
              EXPECT_EQ(image->perLensUnit.y, 0);
            }
          }
    // Nothing in front of the near clipping plane or behind the camera has an image.
    const Vec3f centre = camera.centre(0);
    const Ray axis = camera.generateRay(160, 100, {0.5f, 0.5f});
    EXPECT_FALSE(camera.pointImage(centre + axis.direction * 0.01f, camera.momentAt(0)));
    EXPECT_FALSE(camera.pointImage(centre - axis.direction * 2.0f, camera.momentAt(0)));
  }
}

TEST(Camera, IsStaticUnlessItsTransformOrLensChangesOverTheShutter) {
  EXPECT_TRUE(Camera(cornellCamera(), 64, 64).isStatic());
  CameraParams zooming = cornellCamera();
  zooming.focalLengthSteps = {0.35f, 0.5f};
  EXPECT_FALSE(Camera(zooming, 64, 64).isStatic());
  CameraParams moving = cornellCamera();
  const double later[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 1, 4.45679, 1};
  moving.cameraToWorld = MotionTransform(
      std::vector<Transform>{cornellCamera().cameraToWorld.at(0), Transform::fromRowMajor(later)});
  EXPECT_FALSE(Camera(moving, 64, 64).isStatic());
}
