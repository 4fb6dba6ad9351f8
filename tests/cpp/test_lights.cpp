#include <gtest/gtest.h>

#include <limits>

#include "penumbra/color.h"
#include "penumbra/integrator.h"
#include "penumbra/light.h"
#include "penumbra/sampler.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::facingDown;
using penumbra::test::translation;

namespace {

Vec2f sample2D(uint32_t index) {
  return SampleStream(1, 0, 0, index).next2D();
}

/// ∫ pdf(ω) dω over the sphere, where the light reports pdf for directions that reach it.
double integratePdf(const Light& light, const Vec3f& point) {
  const int n = 1 << 20;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3f direction = sampleUniformSphere(sample2D(uint32_t(i)));
    const auto hit = light.isInfinite() ? light.escaped(direction)
                                        : light.intersect(point, direction, kInfinity);
    if (hit) sum += hit->pdf;
  }
  return sum * 4 * kPi / n;
}

/// Irradiance at `point` on a surface with `normal`, estimated with the light's own sampling.
double estimateIrradiance(const Light& light, const Vec3f& point, const Vec3f& normal) {
  const int n = 1 << 16;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const auto sample = light.sample(point, sample2D(uint32_t(i)));
    if (!sample) continue;
    const float cosine = std::max(0.0f, dot(sample->direction, normal));
    sum += luminance(sample->radiance) * cosine / sample->pdf;
  }
  return sum / n;
}

/// Form factor from a point to a parallel rectangle of sides a, b at height h with one corner
/// right above the point (the classic differential-area-to-rectangle result).
double cornerFormFactor(double a, double b, double h) {
  const double x = a / h, y = b / h;
  const double sx = std::sqrt(1 + x * x), sy = std::sqrt(1 + y * y);
  return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2 * M_PI);
}

std::vector<Vec3f> checker(int width, int height) {
  std::vector<Vec3f> texels;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) texels.push_back((x + y) % 2 ? Vec3f(4, 3, 2) : Vec3f(0.1f));
  return texels;
}

/// A 16x8 lat-long map: dim everywhere, one bright texel in the row just above the horizon at
/// the centre column (longitude 0: +Z in the light's frame).
std::shared_ptr<const LightTexture> skyTexture() {
  std::vector<Vec3f> texels(16 * 8, Vec3f(0.05f, 0.1f, 0.2f));
  texels[3 * 16 + 8] = Vec3f(200, 180, 150);
  return std::make_shared<const LightTexture>(16, 8, std::move(texels), true);
}

/// Irradiance estimated independently of the light's own sampling: uniform directions over the
/// hemisphere, each looked up with intersect()/escaped().
double irradianceByUniformDirections(const Light& light, const Vec3f& point, const Vec3f& normal) {
  const int n = 1 << 20;
  double sum = 0;
  const Frame frame(normal);
  for (int i = 0; i < n; ++i) {
    const Vec2f u = sample2D(uint32_t(i));
    const Vec3f local = sampleUniformCone(u, 1);
    const Vec3f direction = frame.toWorld(local);
    const auto hit = light.isInfinite() ? light.escaped(direction)
                                        : light.intersect(point, direction, kInfinity);
    if (hit) sum += luminance(hit->radiance) * local.z;
  }
  return sum * 2 * M_PI / n;
}

LightParams params(LightType type, const Transform& transform) {
  LightParams p;
  p.type = type;
  p.lightToWorld = transform;
  return p;
}

}  // namespace

TEST(Lights, PowerHeuristicHoldsWhereTheDensitiesSquaresLeaveFloatsRange) {
  // As it was, for densities whose squares float holds: f² / (f² + g²).
  EXPECT_EQ(powerHeuristic(2, 1), 0.8f);
  EXPECT_EQ(powerHeuristic(1, 2), 0.2f);
  EXPECT_EQ(powerHeuristic(0, 0), 0.0f);
  EXPECT_EQ(powerHeuristic(0, 3), 0.0f);
  EXPECT_EQ(powerHeuristic(3, 0), 1.0f);
  EXPECT_EQ(powerHeuristic(std::numeric_limits<float>::quiet_NaN(), 1), 0.0f);
  // A sphere light of radius 1e-12 four units away is sampled with density 5e24: its square
  // was infinite and the weight NaN (half the image). From the densities' ratio instead:
  EXPECT_EQ(powerHeuristic(5e24f, 1), 1.0f);
  EXPECT_GE(powerHeuristic(1, 5e24f), 0.0f);
  EXPECT_LT(powerHeuristic(1, 5e24f), 1e-30f);
  EXPECT_NEAR(powerHeuristic(3e20f, 1e20f), 0.9f, 1e-6f);
  EXPECT_NEAR(powerHeuristic(1e20f, 3e20f), 0.1f, 1e-6f);
  // and densities so small their squares vanish (a vast light): 0 before, whatever the ratio.
  EXPECT_NEAR(powerHeuristic(3e-25f, 1e-25f), 0.9f, 1e-6f);
  EXPECT_NEAR(powerHeuristic(1e-25f, 3e-25f), 0.1f, 1e-6f);
}

TEST(Lights, SamplingDensitiesIntegrateToOne) {
  const Vec3f point{0.3f, 0, -0.2f};
  LightParams rect = params(LightType::Rect, facingDown(0, 2, 0));
  rect.width = 1.5f;
  rect.height = 0.7f;
  LightParams disk = params(LightType::Disk, facingDown(0.5, 1.5, 0));
  disk.radius = 0.6f;
  LightParams sphere = params(LightType::Sphere, translation(1, 2, -1));
  sphere.radius = 0.5f;
  LightParams distant = params(LightType::Distant, facingDown(0, 0, 0));
  distant.angle = 10;
  const LightParams dome = params(LightType::Dome, Transform());
  LightParams cylinder = params(LightType::Cylinder, facingDown(0.2, 1.5, 0.1));
  cylinder.length = 2;
  cylinder.radius = 0.3f;
  LightParams texturedDome = params(LightType::Dome, facingDown(0, 0, 0));
  texturedDome.texture = skyTexture();
  LightParams texturedRect = rect;
  texturedRect.texture = std::make_shared<const LightTexture>(4, 2, checker(4, 2), false);
  for (const LightParams& p :
       {rect, disk, sphere, distant, dome, cylinder, texturedDome, texturedRect})
    EXPECT_NEAR(integratePdf(Light(p), point), 1.0, 0.01) << "light type " << int(p.type);
}

TEST(Lights, SampledDirectionsAgreeWithIntersection) {
  LightParams rect = params(LightType::Rect, facingDown(0, 2, 0));
  LightParams sphere = params(LightType::Sphere, translation(1, 2, -1));
  // Sheared by their transform (local X += 0.6 Y, then facing down): a parallelogram and an
  // ellipse whose axes are not perpendicular, which intersection must bound as sampling does.
  const double shearedDown[16] = {1, 0, 0, 0, 0.6, 0, -1, 0, 0, 1, 0, 0, 0.2, 2, 0.1, 1};
  LightParams shearedRect = params(LightType::Rect, Transform::fromRowMajor(shearedDown));
  shearedRect.width = 1.5f;
  LightParams shearedDisk = params(LightType::Disk, Transform::fromRowMajor(shearedDown));
  shearedDisk.radius = 0.6f;
  for (const LightParams& p : {rect, sphere, shearedRect, shearedDisk}) {
    SCOPED_TRACE(int(p.type));
    const Light light(p);
    for (uint32_t i = 0; i < 64; ++i) {
      const auto sample = light.sample({0, 0, 0}, sample2D(i));
      ASSERT_TRUE(sample);
      const auto hit = light.intersect({0, 0, 0}, sample->direction, kInfinity);
      ASSERT_TRUE(hit);
      EXPECT_NEAR(hit->distance, sample->distance, 1e-4f);
      EXPECT_NEAR(hit->pdf / sample->pdf, 1.0f, 1e-3f);
    }
  }
}

TEST(Lights, RectLightIrradianceMatchesTheFormFactor) {
  LightParams p = params(LightType::Rect, facingDown(0, 2, 0));
  p.width = 1.2f;
  p.height = 0.8f;
  p.intensity = 5;
  const double expected = 5 * M_PI * 4 * cornerFormFactor(0.6, 0.4, 2);
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / expected, 1.0, 0.01);
}

TEST(Lights, SphereLightIrradianceIsPiLTimesSubtendedSine) {
  LightParams p = params(LightType::Sphere, translation(1, 2, 0));
  p.radius = 0.25f;
  p.intensity = 3;
  const double d2 = 1 + 4;
  // A Lambertian sphere fully above the horizon: E = π L (r/d)² cos θ.
  const double expected = M_PI * 3 * (0.0625 / d2) * (2 / std::sqrt(d2));
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / expected, 1.0, 0.01);
}

TEST(Lights, DiskLightOnAxisIrradiance) {
  LightParams p = params(LightType::Disk, facingDown(0, 1.5, 0));
  p.radius = 0.5f;
  const double expected = M_PI * 0.25 / (0.25 + 2.25);
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / expected, 1.0, 0.01);
}

TEST(Lights, NormalizedDistantLightGivesIntensityAsIrradiance) {
  LightParams p = params(LightType::Distant, facingDown(0, 0, 0));
  p.angle = 2;
  p.intensity = 3;
  p.normalize = true;
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / 3, 1.0, 0.01);
  // Unnormalised, intensity is the radiance of the sun disk: E = L π sin²(angle/2).
  p.normalize = false;
  const double sinHalf = std::sin(M_PI / 180);
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / (3 * M_PI * sinHalf * sinHalf),
              1.0, 0.01);
}

TEST(Lights, DomeIrradianceIsPiL) {
  LightParams p = params(LightType::Dome, Transform());
  p.intensity = 0.5f;
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / (0.5 * M_PI), 1.0, 0.01);
}

TEST(Lights, RadianceCombinesColorIntensityExposureAndNormalize) {
  LightParams p = params(LightType::Rect, facingDown(0, 2, 0));
  p.color = {1, 0.5f, 0.25f};
  p.intensity = 3;
  p.exposure = 2;
  p.width = 2;
  p.height = 0.5f;
  const Light plain(p);
  EXPECT_FLOAT_EQ(plain.radiance().x, 12);
  EXPECT_FLOAT_EQ(plain.radiance().y, 6);
  p.normalize = true;
  EXPECT_FLOAT_EQ(Light(p).radiance().x, 12);  // area 1
  p.width = 4;
  EXPECT_FLOAT_EQ(Light(p).radiance().x, 6);
}

TEST(Lights, NormalizeUsesTheWorldSpaceArea) {
  LightParams p = params(LightType::Sphere, Transform());
  p.radius = 1;
  p.normalize = true;
  const double scale2[16] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1};
  p.lightToWorld = Transform::fromRowMajor(scale2);
  EXPECT_NEAR(Light(p).radiance().x, 1 / (4 * M_PI * 4), 1e-7);
}

TEST(Lights, DegenerateLightsAreRejected) {
  LightParams p = params(LightType::Rect, Transform());
  p.width = 0;
  EXPECT_THROW(Light{p}, std::invalid_argument);
  // A sphere scaled to nothing (how an animation puts a light out) is no point light.
  const double zero[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  LightParams sphere = params(LightType::Sphere, Transform::fromRowMajor(zero));
  sphere.radius = 1;
  EXPECT_THROW(Light{sphere}, std::invalid_argument);
  sphere.radius = 0;  // a bulb too
  EXPECT_THROW(Light{sphere}, std::invalid_argument);
}

TEST(Lights, ASphereOfRadiusZeroIsAPointLightOfANormalisedSpheresIntensity) {
  LightParams p = params(LightType::Sphere, translation(1, 2, 0));
  p.radius = 0;
  p.intensity = 3;
  const double d2 = 1 + 4;
  // Radiant intensity E / 4 whether normalised or not, treatAsPoint or not: E = I cos θ / d².
  const double expected = 0.75 * (2 / std::sqrt(d2)) / d2;
  for (const bool normalize : {false, true})
    for (const bool treatAsPoint : {false, true}) {
      p.normalize = normalize;
      p.treatAsPoint = treatAsPoint;
      const Light light(p);
      EXPECT_TRUE(light.isDelta());
      EXPECT_FALSE(light.isAreaLight());
      EXPECT_NEAR(estimateIrradiance(light, {0, 0, 0}, {0, 1, 0}) / expected, 1.0, 1e-5);
    }
  // The same as a normalised point-like sphere of any radius.
  p.radius = 0.25f;
  p.normalize = true;
  EXPECT_NEAR(estimateIrradiance(Light(p), {0, 0, 0}, {0, 1, 0}) / expected, 1.0, 1e-5);
}

TEST(Lights, ATransformThatCollapsesTheEmissionAxisIsRejectedWhereTheLightNeedsIt) {
  const double flatZ[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  // A mesh light's frame is its mesh's transform; its triangles are in world space already.
  LightParams card = params(LightType::Mesh, Transform::fromRowMajor(flatZ));
  card.meshTriangles = std::make_shared<const std::vector<Vec3f>>(
      std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  EXPECT_NO_THROW(Light{card});  // unshaped: no axis needed
  card.coneAngle = 30;
  EXPECT_THROW(Light{card}, std::invalid_argument);
  card.coneAngle = 90;
  card.focus = 2;
  EXPECT_THROW(Light{card}, std::invalid_argument);
  const LightParams sun = params(LightType::Distant, Transform::fromRowMajor(flatZ));
  EXPECT_THROW(Light{sun}, std::invalid_argument);
}

TEST(Color, BlackbodyIsNormalisedAndOrdered) {
  for (float kelvin : {2000.0f, 4000.0f, 6500.0f, 9000.0f})
    EXPECT_NEAR(luminance(blackbodyColor(kelvin)), 1.0f, 1e-4f);
  const Vec3f warm = blackbodyColor(2700), cool = blackbodyColor(9000),
              white = blackbodyColor(6504);
  EXPECT_GT(warm.x, warm.z * 2);
  EXPECT_GT(cool.z, cool.x);
  // A 6504 K blackbody is close to, not exactly, D65 white.
  EXPECT_NEAR(white.x / white.z, 1.0f, 0.1f);
}

TEST(Lights, SampledIrradianceMatchesAnIndependentEstimateForEveryShape) {
  LightParams cylinder = params(LightType::Cylinder, translation(0.3, 1.2, 0));
  cylinder.length = 1.5f;
  cylinder.radius = 0.2f;
  LightParams texturedDome = params(LightType::Dome, Transform());
  texturedDome.texture = skyTexture();
  LightParams texturedRect = params(LightType::Rect, facingDown(0, 1.5, 0.2));
  texturedRect.width = 2;
  texturedRect.texture = std::make_shared<const LightTexture>(4, 2, checker(4, 2), false);
  LightParams shaped = params(LightType::Disk, facingDown(0.4, 1, 0));
  shaped.radius = 0.3f;
  shaped.coneAngle = 30;
  shaped.coneSoftness = 0.5f;
  shaped.focus = 2;
  // Sheared along its axis: the cross-section's local Y leans along it.
  const double shear[16] = {1, 0.5, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.3, 1.2, 0, 1};
  LightParams sheared = cylinder;
  sheared.lightToWorld = Transform::fromRowMajor(shear);
  for (const LightParams& p : {cylinder, sheared, texturedDome, texturedRect, shaped}) {
    const Light light(p);
    const double expected = irradianceByUniformDirections(light, {0, 0, 0}, {0, 1, 0});
    ASSERT_GT(expected, 0) << "light type " << int(p.type);
    EXPECT_NEAR(estimateIrradiance(light, {0, 0, 0}, {0, 1, 0}) / expected, 1.0, 0.02)
        << "light type " << int(p.type);
  }
}

TEST(Lights, AMovingMeshLightIsSampledWhereItsMeshIsAtTheSamplesTime) {
  // A square facing down, moving and growing over the shutter: sampled at mid-shutter, it lights
  // a point below as the same square standing where it then is (its area there is 2.25 times
  // that at shutter open, by which it chose its triangles: the density must be its own).
  const double grown[16] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0.5, 1, 0, 1};
  auto moving = std::make_shared<MovingMeshLight>();
  moving->triangles.points = {
      {-0.5f, 0, -0.5f}, {0.5f, 0, -0.5f}, {0.5f, 0, 0.5f}, {-0.5f, 0, 0.5f}};
  moving->triangles.triangles = {0, 1, 2, 0, 2, 3};  // counter-clockwise seen from below
  moving->objectToWorld = MotionTransform({translation(0, 1, 0), Transform::fromRowMajor(grown)});
  const auto cornersAt = [&](float time) {
    auto corners = std::make_shared<std::vector<Vec3f>>();
    const Transform at = moving->objectToWorld.at(time);
    for (const uint32_t point : moving->triangles.triangles)
      corners->push_back(at.applyToPoint(moving->triangles.points[point]));
    return corners;
  };
  LightParams movingParams = params(LightType::Mesh, Transform());
  movingParams.meshTriangles = cornersAt(0);
  movingParams.meshMotion = moving;
  LightParams standing = params(LightType::Mesh, Transform());
  standing.meshTriangles = cornersAt(0.5f);
  const Light light(movingParams), still(standing);
  const Vec3f receiver(0.3f, 0, 0.1f), up(0, 1, 0);
  const int n = 1 << 16;
  double movingSum = 0, stillSum = 0;
  for (int i = 0; i < n; ++i) {
    const Vec2f u = sample2D(uint32_t(i));
    if (const auto sample = light.sample(receiver, u, up, 0.5f)) {
      EXPECT_NEAR(sample->pdfForWeights() / sample->pdf, 2.25, 1e-3);  // hits weigh by 1/area(0)
      movingSum += sample->radiance.x * std::max(0.0f, dot(sample->direction, up)) / sample->pdf;
    }
    if (const auto sample = still.sample(receiver, u, up))
      stillSum += sample->radiance.x * std::max(0.0f, dot(sample->direction, up)) / sample->pdf;
  }
  ASSERT_GT(stillSum, 0);
  EXPECT_NEAR(movingSum / stillSum, 1.0, 0.01);
  // At shutter open it is where meshTriangles has it.
  LightParams opening = params(LightType::Mesh, Transform());
  opening.meshTriangles = movingParams.meshTriangles;
  const auto atOpen = light.sample(receiver, {0.3f, 0.6f}, up, 0),
             expected = Light(opening).sample(receiver, {0.3f, 0.6f}, up);
  ASSERT_TRUE(atOpen && expected);
  EXPECT_NEAR(atOpen->distance, expected->distance, 1e-5f);
  EXPECT_NEAR(dot(atOpen->direction, expected->direction), 1.0f, 1e-6f);
  EXPECT_NEAR(atOpen->pdf / expected->pdf, 1.0f, 1e-5f);
}

TEST(Lights, DomeTexturesFollowOpenEXRLatLongOrientation) {
  LightParams p = params(LightType::Dome, Transform());
  p.texture = skyTexture();
  // The bright texel (column 8 of 16, row 3 of 8) is at longitude ~0, just above the horizon:
  // towards +Z.
  const Vec3f bright = normalize(Vec3f(-0.05f, 0.2f, 1));
  EXPECT_GT(Light(p).escaped(bright)->radiance.x, 100);
  EXPECT_LT(Light(p).escaped({0, 0.2f, -1})->radiance.x, 1);
  // Rotating the dome by 90° about Y carries the bright spot from +Z to +X (and local -X to +Z).
  const double rotate[16] = {0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1};
  p.lightToWorld = Transform::fromRowMajor(rotate);
  EXPECT_GT(Light(p).escaped(normalize(Vec3f(1, 0.2f, 0.05f)))->radiance.x, 100);
  // Importance sampling finds it: most samples go to the bright texel.
  int towardsBright = 0;
  for (uint32_t i = 0; i < 256; ++i)
    if (Light(p).sample({0, 0, 0}, sample2D(i))->direction.x > 0.8f) ++towardsBright;
  EXPECT_GT(towardsBright, 200);
}

TEST(Lights, ShapingConeCutsOffEmissionOutsideItsAngle) {
  LightParams p = params(LightType::Rect, facingDown(0, 1, 0));
  p.width = p.height = 0.1f;
  p.coneAngle = 20;
  const Light light(p);
  EXPECT_TRUE(light.sample({0.1f, 0, 0}, {0.5f, 0.5f}));
  EXPECT_GT(light.sample({0.1f, 0, 0}, {0.5f, 0.5f})->radiance.x, 0.99f);  // 5.7° off axis
  EXPECT_EQ(light.sample({1, 0, 0}, {0.5f, 0.5f})->radiance.x, 0);         // 45° off axis
  p.coneAngle = 90;
  p.focus = 4;
  const float cos45 = std::sqrt(0.5f);
  EXPECT_NEAR(Light(p).sample({1, 0, 0}, {0.5f, 0.5f})->radiance.x, std::pow(cos45, 4.0f), 1e-3f);
}

TEST(Lights, CylinderLightsEmitFromTheirSideOnly) {
  LightParams p = params(LightType::Cylinder, translation(0, 1, 0));
  p.length = 2;
  p.radius = 0.25f;
  p.normalize = true;
  const Light light(p);
  EXPECT_NEAR(light.radiance().x, 1 / (2 * M_PI * 0.25 * 2), 1e-6);
  EXPECT_TRUE(light.intersect({0, 0, 0}, {0, 1, 0}, kInfinity));
  EXPECT_NEAR(light.intersect({0, 0, 0}, {0, 1, 0}, kInfinity)->distance, 0.75f, 1e-5f);
  EXPECT_FALSE(light.intersect({3, 1, 0}, {-1, 0, 0}, kInfinity));  // along the axis: a cap
  EXPECT_FALSE(light.intersect({0, 1, 0}, {0, 1, 0}, kInfinity));   // from inside
}

TEST(Lights, DomeImportanceSamplingLowersVarianceWithTheSameMean) {
  LightParams p = params(LightType::Dome, Transform());
  p.texture = skyTexture();
  const Light light(p);
  const Vec3f normal{0, 1, 0};
  const int n = 1 << 14;
  double importance[2] = {0, 0}, uniform[2] = {0, 0};
  for (int i = 0; i < n; ++i) {
    const Vec2f u = sample2D(uint32_t(i));
    if (const auto s = light.sample({0, 0, 0}, u)) {
      const double value = luminance(s->radiance) * std::max(0.0f, s->direction.y) / s->pdf;
      importance[0] += value;
      importance[1] += value * value;
    }
    const Vec3f local = sampleUniformCone(u, 1);  // uniform over the upper hemisphere
    const double value =
        luminance(light.escaped(local.z * normal + Vec3f(local.x, 0, local.y))->radiance) *
        local.z * 2 * M_PI;
    uniform[0] += value;
    uniform[1] += value * value;
  }
  const auto meanAndVariance = [n](const double* sums) {
    const double mean = sums[0] / n;
    return std::pair<double, double>{mean, sums[1] / n - mean * mean};
  };
  const auto [importanceMean, importanceVariance] = meanAndVariance(importance);
  const auto [uniformMean, uniformVariance] = meanAndVariance(uniform);
  EXPECT_LT(importanceVariance * 10, uniformVariance);
  EXPECT_NEAR(importanceMean, uniformMean, 3 * std::sqrt(uniformVariance / n));
}

TEST(Lights, RectLightsSampledBySolidAngleHaveLessNoiseNearby) {
  // Close under a large panel, area sampling wastes samples on its grazing far parts; sampling
  // the solid angle it subtends does not. A uniform texture makes the same panel area-sampled.
  LightParams panel = params(LightType::Rect, facingDown(0, 0.2, 0));
  panel.width = panel.height = 2;
  LightParams areaSampled = panel;
  areaSampled.texture =
      std::make_shared<const LightTexture>(2, 2, std::vector<Vec3f>(4, Vec3f(1)), false);
  const auto meanAndVariance = [](const Light& light) {
    const int n = 1 << 14;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
      const auto s = light.sample({0.3f, 0, 0}, sample2D(uint32_t(i)));
      const double value = s ? luminance(s->radiance) * std::max(0.0f, s->direction.y) / s->pdf : 0;
      sum += value;
      sum2 += value * value;
    }
    return std::pair<double, double>{sum / n, sum2 / n - (sum / n) * (sum / n)};
  };
  const auto [solidAngleMean, solidAngleVariance] = meanAndVariance(Light(panel));
  const auto [areaMean, areaVariance] = meanAndVariance(Light(areaSampled));
  EXPECT_NEAR(solidAngleMean / areaMean, 1.0, 0.01);
  EXPECT_LT(solidAngleVariance * 30, areaVariance);  // measured: 66 times less
}
