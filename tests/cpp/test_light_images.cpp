// Lights small in the image, integrated over their image by each camera sample (light_images.h):
// which lights qualify, and that the estimate is the filter-weighted emission a camera ray
// finds (same expectation, computed here by quadrature over the light's image) with far less
// noise, occluders included.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "penumbra/light.h"
#include "penumbra/light_images.h"
#include "penumbra/mesh.h"
#include "penumbra/scene.h"
#include "penumbra/volume.h"
#include "transforms.h"

namespace penumbra {
namespace {

using test::facingBack;
using test::translation;

constexpr int kImageSize = 64;
// The pixels around the light's image (about pixel (32.8, 32.7)): the others see nothing.
constexpr int kWindowLow = 28, kWindowHigh = 38;

/// A pinhole at the origin looking down -Z: 50 / 36 (tenths) lens and film, so a pixel is
/// 0.01125 units across at 1 unit away.
CameraParams pinhole() {
  CameraParams params;
  params.focalLength = 50;
  params.horizontalAperture = params.verticalAperture = 36;
  params.nearClip = 0.1f;
  params.farClip = 1000;
  return params;
}

/// A white sphere light of radiance `radiance` at `centre`.
LightParams sphereLight(const Vec3f& centre, float radius, float radiance = 100) {
  LightParams light;
  light.type = LightType::Sphere;
  light.radius = radius;
  light.intensity = radiance;
  light.lightToWorld = translation(centre.x, centre.y, centre.z);
  return light;
}

std::vector<Light> lightsOf(const std::vector<LightParams>& params) {
  std::vector<Light> lights;
  for (const LightParams& light : params) lights.emplace_back(light);
  return lights;
}

bool integrated(const LightParams& light, const CameraParams& lens = pinhole()) {
  const Camera camera(lens, kImageSize, kImageSize);
  return LightImages(lightsOf({light}), camera, PixelFilter().radius()).integrates(0);
}

// 10 units away: a radius of 0.02 is 0.36 pixels across, 0.1 is 1.8, 2 is 36 pixels.
const Vec3f kLightCentre{0.0931f, -0.0417f, -10};

TEST(LightImages, IntegratesAreaLightsTheCameraSeesSmall) {
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.02f)));
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.1f)));
  EXPECT_FALSE(integrated(sphereLight(kLightCentre, 2)));  // camera rays find it often enough
  // Spheres, disks and rects, whose draws land on them, up to kMaxOutlinedImageSide; cylinders
  // up to kMaxImageSide: 14 pixels across, a sphere and a disk are integrated, a cylinder not.
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.8f)));
  LightParams disk;
  disk.type = LightType::Disk;
  disk.radius = 0.8f;
  disk.intensity = 100;
  disk.lightToWorld = facingBack(kLightCentre.x, kLightCentre.y, kLightCentre.z);
  EXPECT_TRUE(integrated(disk));
  LightParams cylinder;
  cylinder.type = LightType::Cylinder;
  cylinder.length = 1.6f;
  cylinder.radius = 0.1f;
  cylinder.intensity = 100;
  cylinder.lightToWorld = translation(kLightCentre.x, kLightCentre.y, kLightCentre.z);
  EXPECT_FALSE(integrated(cylinder));
  cylinder.length = 0.4f;
  EXPECT_TRUE(integrated(cylinder));
  EXPECT_FALSE(integrated(sphereLight({0, 0, 10}, 0.02f)));     // behind the camera
  EXPECT_FALSE(integrated(sphereLight({0, 0, -0.1f}, 0.02f)));  // across the near plane
  EXPECT_FALSE(integrated(sphereLight({50, 0, -10}, 0.02f)));   // out of the image
  LightParams hidden = sphereLight(kLightCentre, 0.02f);
  hidden.cameraVisible = false;
  EXPECT_FALSE(integrated(hidden));
  LightParams point = sphereLight(kLightCentre, 0.02f);
  point.treatAsPoint = true;
  EXPECT_FALSE(integrated(point));
  LightParams dome;
  dome.type = LightType::Dome;
  EXPECT_FALSE(integrated(dome));
  // A moving camera's image of a light moves (here by 9 pixels): it is integrated while small
  // at every moment; not once part of it crosses the near plane at some moment (still 0.7
  // pixels across then), nor when it streaks over more than kMaxStreakSide (36 pixels).
  CameraParams moving = pinhole();
  moving.cameraToWorld = MotionTransform(std::vector<Transform>{Transform(), translation(1, 0, 0)});
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.02f), moving));
  CameraParams nearing = moving;
  nearing.nearClip = 5;
  nearing.cameraToWorld =
      MotionTransform(std::vector<Transform>{Transform(), translation(0, 0, -5.1)});
  EXPECT_FALSE(integrated(sphereLight(kLightCentre, 0.02f), nearing));
  nearing.cameraToWorld =
      MotionTransform(std::vector<Transform>{Transform(), translation(0, 0, -4.9)});
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.02f), nearing));
  moving.cameraToWorld = MotionTransform(std::vector<Transform>{Transform(), translation(4, 0, 0)});
  EXPECT_FALSE(integrated(sphereLight(kLightCentre, 0.02f), moving));
  // A zoom that makes it larger than kMaxOutlinedImageSide (36 pixels) by the shutter's end.
  CameraParams zooming = pinhole();
  zooming.focalLengthSteps = {50, 1000};
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.1f)));
  EXPECT_FALSE(integrated(sphereLight(kLightCentre, 0.1f), zooming));
  // Its defocus blur counts towards its size: out of focus through a wide aperture it is not.
  CameraParams wide = pinhole();
  wide.fStop = 1;
  wide.focusDistance = 1;
  EXPECT_FALSE(integrated(sphereLight(kLightCentre, 0.02f), wide));
  wide.fStop = 64;
  EXPECT_TRUE(integrated(sphereLight(kLightCentre, 0.02f), wide));
}

TEST(LightImages, PixelsListTheLightsTheirFilterReaches) {
  const Camera camera(pinhole(), kImageSize, kImageSize);
  const LightImages images(lightsOf({sphereLight({100, 0, -10}, 0.02f),  // out of the image
                                     sphereLight(kLightCentre, 0.02f)}),
                           camera, PixelFilter().radius());
  EXPECT_FALSE(images.integrates(0));
  EXPECT_TRUE(images.integrates(1));
  // The light's image is about pixel (32.8, 32.7); the filter reaches 1.5 pixels.
  const auto [begin, end] = images.near(32, 32);
  ASSERT_EQ(end - begin, 1);
  const LightImages::Integrated& light = images.integrated()[*begin];
  EXPECT_EQ(light.lightIndex, 1u);
  EXPECT_TRUE(light.reaches({32.5f, 32.5f}));
  EXPECT_FALSE(light.reaches({29.5f, 32.5f}));
  const auto [farBegin, farEnd] = images.near(2, 60);
  EXPECT_EQ(farBegin, farEnd);
}

/// a then b, in the row-vector convention (p · a · b).
Transform then(const Transform& a, const Transform& b) {
  Transform product;
  for (int row = 0; row < 4; ++row)
    for (int column = 0; column < 4; ++column) {
      double sum = 0;
      for (int k = 0; k < 4; ++k) sum += a.at(row, k) * b.at(k, column);
      product.m[size_t(row * 4 + column)] = sum;
    }
  return product;
}

TEST(LightImages, ALightsOutlineImageHoldsEveryRayThatMeetsItAndLittleElse) {
  // A camera turned 30° about Y, scaled by 2 and moved, through a lens; lights placed in its
  // space 10 units ahead (a little right of and above the image's centre), facing it: a sphere,
  // a rect sheared and tilted, a disk stretched into an ellipse and tilted. Rays through one lens
  // point meet each light where its OutlineImage says, in every row and strip of columns.
  const double turn = 30 * kPi / 180;
  const double rowMajor[16] = {2 * std::cos(turn), 0, -2 * std::sin(turn), 0, 0, 2, 0, 0,
                               2 * std::sin(turn), 0, 2 * std::cos(turn),  0, 1, 2, 3, 1};
  const Transform cameraToWorld = Transform::fromRowMajor(rowMajor);
  CameraParams params = pinhole();
  params.cameraToWorld = MotionTransform(std::vector<Transform>{cameraToWorld});
  params.fStop = 4;
  params.focusDistance = 12;
  const Camera camera(params, kImageSize, kImageSize);
  const Vec2f lensSample{0.83f, 0.27f};
  const std::optional<Camera::RayFamily> family = camera.rayFamily(lensSample, 0);
  ASSERT_TRUE(family.has_value());
  const Transform placed = then(facingBack(0.48, 0.25, -10, 20), cameraToWorld);
  const double tilt = 35 * kPi / 180;
  const double shearAndTilt[16] = {
      1, 0, 0, 0, 0.3, std::cos(tilt), std::sin(tilt), 0, 0, -std::sin(tilt), std::cos(tilt),
      0, 0, 0, 0, 1};
  const double stretchAndTilt[16] = {
      1.6 * std::cos(tilt), 0, 1.6 * std::sin(tilt), 0, 0, 0.7, 0, 0,
      -std::sin(tilt),      0, std::cos(tilt),       0, 0, 0,   0, 1};
  LightParams sphere = sphereLight({0, 0, 0}, 0.16f);
  sphere.lightToWorld = placed;
  LightParams rect;
  rect.type = LightType::Rect;
  rect.width = 0.5f;
  rect.height = 0.3f;
  rect.intensity = 100;
  rect.lightToWorld = then(Transform::fromRowMajor(shearAndTilt), placed);
  LightParams disk;
  disk.type = LightType::Disk;
  disk.radius = 0.2f;
  disk.intensity = 100;
  disk.lightToWorld = then(Transform::fromRowMajor(stretchAndTilt), placed);
  for (const LightParams& lightParams : {sphere, rect, disk}) {
    SCOPED_TRACE(int(lightParams.type));
    const Light light(lightParams);
    const std::optional<Light::Outline> outline = light.outline();
    ASSERT_TRUE(outline.has_value());
    const double margin = 0.01;
    // Positions relative to pixel (30.5, 30.5), as a sample of that pixel sees them.
    const Vec2f origin{30.5f, 30.5f};
    const OutlineImage image(*family, *outline, origin, margin);
    // Which positions of a fine grid see the light, by generateRay and Light::intersect.
    constexpr double kRowStep = 1.0 / 16, kColumnStep = 1.0 / 64;
    std::vector<std::pair<double, double>> met;  // (x, y) relative to the origin
    for (double y = -10; y < 10; y += kRowStep)
      for (double x = -10; x < 22; x += kColumnStep) {
        const Ray ray = camera.generateRay(origin.x + float(x), origin.y + float(y), lensSample);
        if (light.intersect(ray.origin, ray.direction, ray.tFar)) met.emplace_back(x, y);
      }
    ASSERT_GT(met.size(), 2000u);  // 2 to 4 pixels across
    const auto meets = [&](double x, double y) {
      const Ray ray = camera.generateRay(origin.x + float(x), origin.y + float(y), lensSample);
      return light.intersect(ray.origin, ray.direction, ray.tFar).has_value();
    };
    // Each row's span holds the row's positions that meet it, and (where it crosses a quarter
    // of a pixel or more of it) a twentieth of a pixel inside its ends they meet it, in the row
    // or within the margin above or below: the light's thousandth of growth moves a chord's
    // ends further where the outline runs nearly along the row, at its tips.
    for (double y = -10; y < 10; y += kRowStep) {
      const std::optional<OutlineImage::Span> span = image.row(y);
      int inRow = 0;
      for (const auto& [x, metY] : met) {
        if (metY != y) continue;
        ++inRow;
        ASSERT_TRUE(span.has_value()) << "row " << y;
        EXPECT_GE(x, span->first) << "row " << y;
        EXPECT_LE(x, span->second) << "row " << y;
      }
      if (inRow < 16) continue;
      // The span is the union of the rows within the margin above and below, widened by it.
      const auto meetsNear = [&](double x) {
        return meets(x, y - margin) || meets(x, y) || meets(x, y + margin);
      };
      EXPECT_TRUE(meetsNear(span->first + margin + 0.05)) << "row " << y;
      EXPECT_TRUE(meetsNear(span->second - margin - 0.05)) << "row " << y;
    }
    // Rounding may let rays meet the light up to the margin beyond it across rows too: the
    // rows just above and below its image have spans, those beyond the margin none.
    const std::optional<OutlineImage::Span> allRows = image.rowsWithin(-1000, 1000);
    ASSERT_TRUE(allRows.has_value());
    EXPECT_TRUE(image.row(allRows->first + 0.001).has_value());
    EXPECT_TRUE(image.row(allRows->second - 0.001).has_value());
    EXPECT_FALSE(image.row(allRows->first - 0.001).has_value());
    EXPECT_FALSE(image.row(allRows->second + 0.001).has_value());
    // The rows that reach a strip of columns hold those of its positions that meet the light,
    // and end within a tenth of a pixel of the highest and lowest of them.
    for (double x0 = -2; x0 < 14; x0 += 0.75)
      for (const double width : {0.3, 1.1, 3.0, 40.0}) {
        const double x1 = x0 + width;
        double lowest = kInfinity, highest = -kInfinity;
        for (const auto& [x, y] : met)
          if (x >= x0 && x <= x1) {
            lowest = std::min(lowest, y);
            highest = std::max(highest, y);
          }
        const std::optional<OutlineImage::Span> rows = image.rowsWithin(x0, x1);
        if (lowest > highest) continue;
        ASSERT_TRUE(rows.has_value()) << "strip " << x0 << " " << x1;
        EXPECT_LE(rows->first, lowest) << "strip " << x0 << " " << x1;
        EXPECT_GE(rows->second, highest) << "strip " << x0 << " " << x1;
        EXPECT_GT(rows->first, lowest - 0.1 - kRowStep) << "strip " << x0 << " " << x1;
        EXPECT_LT(rows->second, highest + 0.1 + kRowStep) << "strip " << x0 << " " << x1;
      }
    // A strip beside the image reaches none of its rows.
    EXPECT_FALSE(image.rowsWithin(-9, -8).has_value());
  }
  // No family for an orthographic camera, whose rays do not share an origin.
  CameraParams orthographic = pinhole();
  orthographic.projection = Projection::Orthographic;
  EXPECT_FALSE(Camera(orthographic, kImageSize, kImageSize).rayFamily(lensSample, 0).has_value());
}

TEST(LightImages, ATinyLightFarFromTheOriginLosesNoRayToRounding) {
  // A 4K camera 100 units from the origin, turned, and a sphere light 0.02 pixels across 40
  // units ahead: the rays that rounding lets meet it at its image's top and bottom rows, where
  // the rows' quadratics barely have roots, lie in the spans drawn.
  const double yaw = 30 * kPi / 180, pitch = 20 * kPi / 180;
  const double rowMajor[16] = {std::cos(yaw),
                               std::sin(yaw) * std::sin(pitch),
                               -std::sin(yaw) * std::cos(pitch),
                               0,
                               0,
                               std::cos(pitch),
                               std::sin(pitch),
                               0,
                               std::sin(yaw),
                               -std::cos(yaw) * std::sin(pitch),
                               std::cos(yaw) * std::cos(pitch),
                               0,
                               100,
                               50,
                               -33,
                               1};
  const Transform cameraToWorld = Transform::fromRowMajor(rowMajor);
  CameraParams params;
  params.cameraToWorld = MotionTransform(std::vector<Transform>{cameraToWorld});
  const Camera camera(params, 3840, 2160);
  const Vec3f centre = cameraToWorld.applyToPoint({0.931f, -0.417f, -40});
  const std::vector<Light> lights = lightsOf({sphereLight(centre, 5e-5f)});
  const LightImages images(lights, camera, PixelFilter().radius());
  ASSERT_FALSE(images.integrated().empty());
  const LightImages::Integrated& integrated = images.integrated()[0];
  const Vec2f lensSample{0.5f, 0.5f};
  const std::optional<Camera::RayFamily> family = camera.rayFamily(lensSample, 0);
  ASSERT_TRUE(family.has_value());
  const std::optional<PointImage> image = camera.pointImage(centre, camera.momentAt(0));
  ASSERT_TRUE(image.has_value());
  const Vec2f origin{std::floor(image->position.x) + 0.5f, std::floor(image->position.y) + 0.5f};
  const OutlineImage outline(*family, *lights[0].outline(), origin, integrated.margin);
  const std::optional<OutlineImage::Span> rows = outline.rowsWithin(-10, 10);
  ASSERT_TRUE(rows.has_value());
  // Rows within a tenth of the image's height of its top and bottom (the rows' span without
  // the margin), each scanned across.
  const double top = rows->first + integrated.margin, bottom = rows->second - integrated.margin;
  const double height = bottom - top;
  ASSERT_GT(height, 0);
  int hits = 0, lost = 0;
  for (int step = 0; step <= 400; ++step) {
    const double within = 0.1 * height * step / 400;
    for (const double y : {top + within, bottom - within}) {
      const std::optional<OutlineImage::Span> span = outline.row(y);
      for (int column = 0; column <= 400; ++column) {
        const double x = -0.2 + 0.4 * column / 400;
        const Ray ray = camera.generateRay(origin.x + float(x), origin.y + float(y), lensSample);
        if (!lights[0].intersect(ray.origin, ray.direction, ray.tFar)) continue;
        ++hits;
        if (!span || x < span->first || x > span->second) ++lost;
      }
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_EQ(lost, 0) << "of " << hits;
}

struct PixelStatistics {
  std::vector<double> mean, variance;  // per pixel of the window, of one sample's luminance
  double sum = 0;                      // of the means
  double varianceSum = 0;              // of the variances
};

/// Each pixel's mean and variance over `samples` camera samples, with or without the light
/// images, over the window around the light.
PixelStatistics render(const Scene& scene, const Camera& camera, const LightImages* images,
                       uint32_t samples) {
  IntegratorSettings settings;
  settings.lightImages = images;
  const PixelFilter filter;
  PixelStatistics statistics;
  for (int y = kWindowLow; y < kWindowHigh; ++y)
    for (int x = kWindowLow; x < kWindowHigh; ++x) {
      double sum = 0, sum2 = 0;
      for (uint32_t i = 0; i < samples; ++i) {
        const double value =
            renderCameraSample(scene, camera, filter, x, y, i, settings).radiance.y;
        sum += value;
        sum2 += value * value;
      }
      const double mean = sum / samples;
      statistics.mean.push_back(mean);
      statistics.variance.push_back(std::max(0.0, sum2 / samples - mean * mean));
      statistics.sum += mean;
      statistics.varianceSum += statistics.variance.back();
    }
  return statistics;
}

/// What a camera sample of each pixel of the window sees of `light` on average: the filter's
/// share over each cell of a fine grid of image positions, where the camera ray through the
/// cell's centre meets the light before any surface.
std::vector<double> expectedImage(const Scene& scene, const Camera& camera, const Light& light) {
  const PixelFilter filter;
  std::vector<double> image;
  const double cell = 1.0 / 64;
  for (int y = kWindowLow; y < kWindowHigh; ++y)
    for (int x = kWindowLow; x < kWindowHigh; ++x) {
      const Vec2f centre{float(x) + 0.5f, float(y) + 0.5f};
      const float reach = filter.radius();
      double value = 0;
      for (double dy = -reach; dy < reach; dy += cell)
        for (double dx = -reach; dx < reach; dx += cell) {
          const Ray ray = camera.generateRay(centre.x + float(dx + cell / 2),
                                             centre.y + float(dy + cell / 2), {0.5f, 0.5f});
          const std::optional<LightHit> hit = light.intersect(ray.origin, ray.direction, ray.tFar);
          if (!hit || scene.geometry().hitDistance(ray, RayKind::Camera) < hit->distance) continue;
          value += filter
                       .sampleOffsetWithin({float(dx), float(dy)},
                                           {float(dx + cell), float(dy + cell)}, {0.5f, 0.5f})
                       .share *
                   hit->radiance.y;
        }
      image.push_back(value);
    }
  return image;
}

double total(const std::vector<double>& values) {
  double sum = 0;
  for (const double value : values) sum += value;
  return sum;
}

struct Outcome {
  double sum;            // of the pixels' means, with the light images
  double varianceRatio;  // the pixels' summed variance without them over that with them
};

/// Renders `light`, small in the image and centred on kLightCentre's line of sight (behind a
/// card that hides its left half if `occluded`), with and without the light images, `samples`
/// per pixel, and checks both against the quadrature; the image sums within `sumTolerance`
/// (relative).
Outcome checkAgainstQuadrature(const LightParams& light, bool occluded, uint32_t samples = 512,
                               double sumTolerance = 0.005) {
  const Device device;
  Scene scene(device);
  scene.lights().setLights(lightsOf({light}));
  if (occluded) {
    // An opaque card at z = -5 whose edge is on the line of sight to the light's centre.
    MeshData card;
    const float edge = kLightCentre.x / 2;
    card.points = {{-1, -1, -5}, {edge, -1, -5}, {edge, 1, -5}, {-1, 1, -5}};
    card.faceVertexCounts = {4};
    card.faceVertexIndices = {0, 1, 2, 3};
    const Geometry::MeshId id = scene.geometry().addMesh();
    scene.geometry().setMeshGeometry(id, triangulate(card));
    scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
  }
  scene.commit();
  const Camera camera(pinhole(), kImageSize, kImageSize);
  const LightImages images(scene.lights().all(), camera, PixelFilter().radius());
  EXPECT_TRUE(images.integrates(0));

  const std::vector<double> expected = expectedImage(scene, camera, scene.lights().all()[0]);
  const PixelStatistics integrating = render(scene, camera, &images, samples);
  const PixelStatistics cameraRays = render(scene, camera, nullptr, samples);
  double brightest = 0;
  for (const double value : expected) brightest = std::max(brightest, value);
  for (size_t pixel = 0; pixel < expected.size(); ++pixel) {
    // Five standard deviations of each mean, plus the quadrature's own error.
    const double tolerance =
        5 * std::sqrt(integrating.variance[pixel] / samples) + 0.01 * brightest;
    EXPECT_NEAR(integrating.mean[pixel], expected[pixel], tolerance) << "pixel " << pixel;
  }
  // The light's emission, counted once (camera rays do not add it again), and what camera
  // rays alone find, within their noise.
  EXPECT_NEAR(integrating.sum, total(expected), sumTolerance * total(expected));
  EXPECT_NEAR(cameraRays.sum, total(expected), 5 * std::sqrt(cameraRays.varianceSum / samples));
  return {integrating.sum, cameraRays.varianceSum / integrating.varianceSum};
}

TEST(LightImages, ASubpixelLightIsItsFilterWeightedEmissionWithLittleNoise) {
  const Outcome outcome = checkAgainstQuadrature(sphereLight(kLightCentre, 0.02f), false);
  // Radiance 100 over the light's 0.0993 square pixels (the filter's weights sum to 1 within
  // 3 % wherever the light is on the pixel grid).
  const double analytic = 100 * kPi * std::pow(0.02 * 5 / 10 * 64 / 3.6, 2);
  EXPECT_NEAR(outcome.sum, analytic, 0.03 * analytic);
  // 116 (70 drawn in the box around the image, whose corners the disc leaves dark).
  EXPECT_GT(outcome.varianceRatio, 100);
}

TEST(LightImages, ALightTwoPixelsAcrossIsItsFilterWeightedEmission) {
  // Drawn in the box around its image, a draw missed the light's disc in the box's corners:
  // 6.1 times less variance than camera rays; in the disc's span of the draw's row, 17.1.
  EXPECT_GT(checkAgainstQuadrature(sphereLight(kLightCentre, 0.1f), false).varianceRatio, 10);
}

TEST(LightImages, ASphereLightFivePixelsAcrossIsSeenByEveryDraw) {
  // Its pixels' draws land in its image's span of their row, so that only how much of the
  // filter that span holds varies, not whether the draw sees the light.
  const Outcome outcome = checkAgainstQuadrature(sphereLight(kLightCentre, 0.28f), false);
  // 7.3 times less variance than camera rays (2.1 drawn in the box around the image, 6.0 in
  // the image's span of a row drawn anywhere in the box).
  EXPECT_GT(outcome.varianceRatio, 6.5);
}

TEST(LightImages, SurfacesInFrontHideWhatCameraRaysWouldNotSee) {
  const Outcome whole = checkAgainstQuadrature(sphereLight(kLightCentre, 0.1f), false);
  const Outcome halfHidden = checkAgainstQuadrature(sphereLight(kLightCentre, 0.1f), true);
  EXPECT_NEAR(halfHidden.sum / whole.sum, 0.5, 0.02);
  EXPECT_GT(halfHidden.varianceRatio, 1.5);
}

TEST(LightImages, RectDiskAndCylinderLightsAreTheirFilterWeightedEmission) {
  // About 1.3 × 0.9 pixels, 0.9 pixels across, and 1.8 × 0.36 pixels (along X) at 10 units.
  LightParams rect;
  rect.type = LightType::Rect;
  rect.width = 0.15f;
  rect.height = 0.1f;
  LightParams disk;
  disk.type = LightType::Disk;
  disk.radius = 0.05f;
  LightParams cylinder;
  cylinder.type = LightType::Cylinder;
  cylinder.length = 0.2f;
  cylinder.radius = 0.02f;
  for (LightParams* light : {&rect, &disk, &cylinder}) {
    // Rect and disk lights emit along their local -Z: turned to face the camera, and about the
    // line of sight so that no edge lies along the quadrature's grid (whose error would then add
    // up along it).
    light->lightToWorld = facingBack(kLightCentre.x, kLightCentre.y, kLightCentre.z, 20);
    light->intensity = 100;
    SCOPED_TRACE(int(light->type));
    // Turned, the cylinder's image fills less of the box the filter offsets are drawn in than
    // a sphere's does, so more draws miss: 2,048 samples, and the sums within 1.5 % (measured
    // within 0.7 %; five standard deviations of independent samples would be 6–10 %, but the
    // sampler's stratification does better).
    const Outcome whole = checkAgainstQuadrature(*light, false, 2048, 0.015);
    // The rect's and disk's draws land on them, in a row that crosses their image and in its
    // span of that row: 9.6 and 35.4 times less variance than camera rays (4.6 and 5.0 drawn
    // in the box, as the cylinder's are: 3.2).
    const double leastRatio = light->type == LightType::Cylinder ? 1.5
                              : light->type == LightType::Rect   ? 8
                                                                 : 25;
    EXPECT_GT(whole.varianceRatio, leastRatio);
    // The card's edge is on the line of sight to the light's centre, about which each is
    // symmetric.
    EXPECT_NEAR(checkAgainstQuadrature(*light, true, 2048, 0.015).sum / whole.sum, 0.5, 0.02);
  }
}

TEST(LightImages, ThroughALensTheBlurredLightKeepsItsEmission) {
  // Out of focus (f/8, focused at 7 units), the 0.36-pixel light blurs over about 2.4 pixels.
  const Device device;
  Scene scene(device);
  scene.lights().setLights(lightsOf({sphereLight(kLightCentre, 0.02f)}));
  scene.commit();
  CameraParams lens = pinhole();
  lens.fStop = 8;
  lens.focusDistance = 7;
  const Camera camera(lens, kImageSize, kImageSize);
  const LightImages images(scene.lights().all(), camera, PixelFilter().radius());
  ASSERT_TRUE(images.integrates(0));
  const uint32_t samples = 512;
  const PixelStatistics integrating = render(scene, camera, &images, samples);
  const PixelStatistics cameraRays = render(scene, camera, nullptr, samples);
  EXPECT_NEAR(integrating.sum, cameraRays.sum, 5 * std::sqrt(cameraRays.varianceSum / samples));
  const double inFocus = 100 * kPi * std::pow(0.02 * 5 / 10 * 64 / 3.6, 2);
  EXPECT_NEAR(integrating.sum, inFocus, 0.03 * inFocus);
  EXPECT_GT(cameraRays.varianceSum / integrating.varianceSum, 1.5);
}

TEST(LightImages, AMovingCameraSeesTheLightsStreakWithLessNoise) {
  // The camera moves 0.3 units along X over the shutter: the 0.36-pixel light's image sweeps
  // 2.7 pixels. Camera rays find it as often as the streak covers their filter; each sample
  // integrates it at the sample's own moment.
  const Device device;
  Scene scene(device);
  scene.lights().setLights(lightsOf({sphereLight(kLightCentre, 0.02f)}));
  scene.commit();
  CameraParams moving = pinhole();
  moving.cameraToWorld =
      MotionTransform(std::vector<Transform>{Transform(), translation(0.3, 0, 0)});
  const Camera camera(moving, kImageSize, kImageSize);
  const LightImages images(scene.lights().all(), camera, PixelFilter().radius());
  ASSERT_TRUE(images.integrates(0));
  // Pixels on the streak integrate it at any moment; one far from it does not.
  EXPECT_TRUE(images.integratesAt(0, 31, 32, {0, 0}, 0.5f));
  EXPECT_FALSE(images.integratesAt(0, 40, 32, {0, 0}, 0.5f));
  const uint32_t samples = 1024;
  const PixelStatistics integrating = render(scene, camera, &images, samples);
  const PixelStatistics cameraRays = render(scene, camera, nullptr, samples);
  for (size_t pixel = 0; pixel < integrating.mean.size(); ++pixel) {
    // Where camera rays find the light rarely, their own variance says little (none found it
    // in some pixels): a camera sample adds at most the radiance, 100, so its variance is at
    // most 100 × its mean.
    const double cameraRayVariance =
        std::max(cameraRays.variance[pixel], 100 * integrating.mean[pixel]);
    const double tolerance =
        5 * std::sqrt((integrating.variance[pixel] + cameraRayVariance) / samples);
    EXPECT_NEAR(integrating.mean[pixel], cameraRays.mean[pixel], tolerance) << "pixel " << pixel;
  }
  // Radiance 100 over the light's image, as for a static camera (the streak spreads it).
  const double still = 100 * kPi * std::pow(0.02 * 5 / 10 * 64 / 3.6, 2);
  EXPECT_NEAR(integrating.sum, still, 0.03 * still);
  EXPECT_NEAR(cameraRays.sum, still, 5 * std::sqrt(cameraRays.varianceSum / samples));
  EXPECT_GT(cameraRays.varianceSum / integrating.varianceSum, 10);
}

TEST(LightImages, AnAbsorbingMediumInFrontDimsTheLightByBeerLambert) {
  // A slab of σa = 0.5 between z = -4 and z = -6 (2 units thick) in front of the light.
  const uint32_t samples = 1024;
  const auto statistics = [&](bool withSlab) {
    const Device device;
    Scene scene(device);
    scene.lights().setLights(lightsOf({sphereLight(kLightCentre, 0.02f)}));
    if (withSlab) {
      VolumeData data;
      data.material.scattering = Vec3f(0.0f);
      data.material.absorption = Vec3f(0.5f);
      data.material.principledAbsorption = Vec3f(0.0f);
      data.material.blackbodyIntensity = 0;
      data.objectBounds = {{-5, -5, -6}, {5, 5, -4}};
      const VolumeSet::VolumeId id = scene.volumes().add();
      scene.volumes().setData(id, std::move(data));
      scene.volumes().setPlacement(id, Transform(), true);
    }
    scene.commit();
    const Camera camera(pinhole(), kImageSize, kImageSize);
    const LightImages images(scene.lights().all(), camera, PixelFilter().radius());
    EXPECT_TRUE(images.integrates(0));
    return render(scene, camera, &images, samples);
  };
  const PixelStatistics clear = statistics(false), dimmed = statistics(true);
  // The transmittance estimate is what is noisy: five standard deviations of the dimmed sum.
  const double tolerance = 5 * std::sqrt(dimmed.varianceSum / samples) / clear.sum;
  EXPECT_LT(tolerance, 0.1);
  EXPECT_NEAR(dimmed.sum / clear.sum, std::exp(-0.5 * 2), tolerance);
}

}  // namespace
}  // namespace penumbra
