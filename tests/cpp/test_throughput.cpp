// The ray log and Embree's raw speed on the path tracer's own rays (throughput.h).
#include <gtest/gtest.h>

#include <cstring>

#include "penumbra/branching.h"
#include "penumbra/dome_sampling.h"
#include "penumbra/filter.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "penumbra/ray_log.h"
#include "scene_builders.h"
#include "transforms.h"

using namespace penumbra;
using penumbra::test::addCamera;
using penumbra::test::addFloor;
using penumbra::test::addSphere;
using penumbra::test::facingDown;
using penumbra::test::syncedCamera;
using penumbra::test::translation;
using namespace penumbra::plugin;

namespace {

constexpr int kSize = 24;

/// A grey floor with a ball on it under a square lamp (shadow rays, some blocked) and a sky
/// (rays that escape), seen from above.
void ballUnderLamp(RenderDelegate& delegate) {
  addFloor(delegate, "/floor", 10);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  addSphere(delegate, "/ball", 0.5f, 12, 24);
  delegate.mesh("/ball").setTransform(translation(0, 0.5, 0));
  delegate.insertSprim("rectLight", "/lamp");
  delegate.light("/lamp").setParam("intensity", 10.0f);
  delegate.light("/lamp").setTransform(facingDown(0, 3, 0));
  delegate.insertSprim("domeLight", "/sky");
  delegate.light("/sky").setParam("intensity", 0.2f);
  addCamera(delegate, facingDown(0, 4, 0), 12);
}

/// The integrator settings a pass renders ballUnderLamp with at `size` pixels square (the
/// delegate's indirectSamples and lightSamples, other render settings at their defaults): the sky
/// at the first surfaces, the branches and the light estimates as the pass's pilots choose, and
/// the pass's branch counts per region where it has them (`pass` must outlive the settings).
IntegratorSettings passIntegrator(const RenderDelegate& delegate, const penumbra::Camera& camera,
                                  int size, const RenderPass& pass) {
  RenderSettings settings;
  settings.integrator.firstSurfaceConstantDomeShare =
      runDomeSamplingPilot(delegate.scene(), camera, size, size, settings).firstSurfaceShare();
  const BranchingPilot::Choice firstSurface =
      runBranchingPilot(delegate.scene(), camera, size, size, settings)
          .choose({delegate.settings().indirectSamples, delegate.settings().lightSamples});
  settings.integrator.indirectSamples = firstSurface.indirectSamples;
  settings.integrator.lightSamples = firstSurface.lightSamples;
  settings.integrator.regionBranches = pass.regionBranches();
  return settings.integrator;
}

bool sameBits(const Vec3f& a, const Vec3f& b) {
  return std::memcmp(&a, &b, sizeof(Vec3f)) == 0;
}

}  // namespace

TEST(RayLog, HoldsExactlyTheRaysEachSampleCountsAndChangesNoSample) {
  RenderDelegate delegate;
  ballUnderLamp(delegate);
  const penumbra::Camera camera = syncedCamera(delegate, kSize);
  const PixelFilter filter;
  IntegratorSettings settings;
  RayLog log;
  IntegratorSettings logging = settings;
  logging.rayLog = &log;
  uint64_t counted = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x)
      for (uint32_t s = 0; s < 2; ++s) {
        const CameraSample plain =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, settings);
        const CameraSample logged =
            renderCameraSample(delegate.scene(), camera, filter, x, y, s, logging);
        ASSERT_TRUE(sameBits(plain.radiance, logged.radiance)) << x << ", " << y;
        ASSERT_EQ(plain.rays, logged.rays);
        counted += logged.rays;
      }
  const std::vector<LoggedRay> rays = log.rays();
  ASSERT_EQ(rays.size(), counted);
  size_t cameraRays = 0, shadowRays = 0, blocked = 0;
  for (const LoggedRay& ray : rays) {
    cameraRays += !ray.shadow && ray.kind == RayKind::Camera;
    if (ray.shadow) {
      ++shadowRays;
      blocked += delegate.scene().geometry().occluded(ray.ray, ray.shadowLinkSlot);
    }
  }
  EXPECT_EQ(cameraRays, size_t(2 * kSize * kSize));  // one per sample, first
  EXPECT_GT(shadowRays, cameraRays);                 // lamp and sky at each hit
  EXPECT_GT(blocked, 0u);                            // the ball's shadow
  EXPECT_LT(blocked, shadowRays);
}

TEST(RawThroughput, TimesEmbreeOnTheRaysOneSamplePerPixelTraces) {
  RenderDelegate delegate;
  ballUnderLamp(delegate);
  delegate.settings().set("indirectSamples", 3);  // the pass's settings are the ones logged
  RenderPass pass(delegate, "/cam", kSize, kSize);
  const RawRayThroughput raw = pass.measureRawThroughput();
  const penumbra::Camera camera(delegate.camera("/cam").params(), kSize, kSize);
  const IntegratorSettings branched = passIntegrator(delegate, camera, kSize, pass);
  EXPECT_EQ(branched.indirectSamples, 3);
  // The ball, lit by the lamp, hides the sky from the floor: the pilot leaves the sky to BSDF
  // rays there, one shadow ray fewer than IntegratorSettings' default.
  EXPECT_EQ(branched.firstSurfaceConstantDomeShare, 0.0f);
  IntegratorSettings unbranched = branched;
  unbranched.indirectSamples = 1;
  uint64_t rays = 0, unbranchedRays = 0, skySampledRays = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      rays += renderCameraSample(delegate.scene(), camera, PixelFilter(), x, y, 0, branched).rays;
      unbranchedRays +=
          renderCameraSample(delegate.scene(), camera, PixelFilter(), x, y, 0, unbranched).rays;
      IntegratorSettings skySampled = branched;
      skySampled.firstSurfaceConstantDomeShare = 1;
      skySampledRays +=
          renderCameraSample(delegate.scene(), camera, PixelFilter(), x, y, 0, skySampled).rays;
    }
  EXPECT_EQ(raw.pathRayCount, rays);
  // So the count does say which settings were logged.
  EXPECT_GT(rays, unbranchedRays);
  EXPECT_GT(skySampledRays, rays);
  EXPECT_GT(raw.pathRays, 0);
  EXPECT_GT(raw.primary, 0);
}

TEST(RawThroughput, LargeImagesLogTheRaysOfEveryKthPixelEachWay) {
  RenderDelegate delegate;
  ballUnderLamp(delegate);
  constexpr int kLarge = 300;  // 90,000 pixels: every second pixel each way, 22,500 of them
  RenderPass pass(delegate, "/cam", kLarge, kLarge);
  const RawRayThroughput raw = pass.measureRawThroughput();
  const penumbra::Camera camera(delegate.camera("/cam").params(), kLarge, kLarge);
  const IntegratorSettings settings = passIntegrator(delegate, camera, kLarge, pass);
  uint64_t everySecond = 0;
  for (int y = 0; y < kLarge; y += 2)
    for (int x = 0; x < kLarge; x += 2)
      everySecond +=
          renderCameraSample(delegate.scene(), camera, PixelFilter(), x, y, 0, settings).rays;
  EXPECT_EQ(raw.pathRayCount, everySecond);
  EXPECT_LE(22500u, everySecond);  // a camera ray each at least
}
