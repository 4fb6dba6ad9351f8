// Volumes against analytic values: the Henyey–Greenstein phase function, Beer–Lambert
// absorption, a scattering medium in a white furnace, emission's closed form, and the
// transmittance of a heterogeneous field against numerical integration.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "penumbra/light.h"
#include "penumbra/mesh.h"
#include "penumbra/phase.h"
#include "penumbra/random_stream.h"
#include "penumbra/scene.h"
#include "penumbra/vdb_field.h"
#include "penumbra/volume.h"
#include "transforms.h"

namespace penumbra {
namespace {

using test::translation;

/// A box of medium: x and y within ±halfWidth, z in [zLow, zHigh].
Bounds3f slab(float zLow, float zHigh, float halfWidth = 10) {
  return {{-halfWidth, -halfWidth, zLow}, {halfWidth, halfWidth, zHigh}};
}

VolumeMaterial absorbing(float sigma) {
  VolumeMaterial m;
  m.scattering = Vec3f(0.0f);
  m.absorption = Vec3f(sigma);
  m.principledAbsorption = Vec3f(0.0f);
  m.blackbodyIntensity = 0;
  return m;
}

/// A slab(−1, 1, halfWidth) of medium that scatters all the light it meets (albedo 1).
VolumeData whiteScatteringSlab(float density, float halfWidth = 10) {
  VolumeData data;
  data.material.density = density;
  data.material.scattering = Vec3f(1.0f);
  data.material.principledAbsorption = Vec3f(0.0f);
  data.objectBounds = slab(-1, 1, halfWidth);
  return data;
}

VolumeSet::VolumeId addVolume(Scene& scene, VolumeData data,
                              const Transform& placement = Transform()) {
  const VolumeSet::VolumeId id = scene.volumes().add();
  scene.volumes().setData(id, std::move(data));
  scene.volumes().setPlacement(id, placement, true);
  return id;
}

/// A white floor at z = −3, wider than any view here (the floor the shadow-ray tests light).
void addWhiteFloor(Scene& scene) {
  MeshData floor;
  floor.points = {{-20, -20, -3}, {20, -20, -3}, {20, 20, -3}, {-20, 20, -3}};
  floor.faceVertexCounts = {4};
  floor.faceVertexIndices = {0, 1, 2, 3};
  floor.displayColor = {{1, 1, 1}};
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setMeshGeometry(id, triangulate(floor));
  scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
}

void addLight(Scene& scene, const LightParams& params) {
  std::vector<Light> lights;
  lights.emplace_back(params);
  scene.lights().setLights(std::move(lights));
}

LightParams whiteDome() {
  LightParams dome;
  dome.type = LightType::Dome;
  return dome;
}

/// An orthographic camera at z = 6 looking down −z over a 1 × 1 window: every pixel's rays
/// run parallel to the z axis.
Camera orthographicCamera(int size) {
  CameraParams lens;
  lens.projection = Projection::Orthographic;
  lens.horizontalAperture = lens.verticalAperture = 10;  // tenths of a unit
  lens.cameraToWorld = translation(0, 0, 6);
  return Camera(lens, size, size);
}

/// Five standard deviations (plus a little for float sums) of the mean of `samples` draws that
/// are each 1 with probability `p` and 0 otherwise: camera samples through absorbing media,
/// which either pass or are absorbed.
double binomialTolerance(double p, double samples) {
  return 5 * std::sqrt(p * (1 - p) / samples) + 1e-3;
}

/// The mean radiance of every sample of a size × size image by orthographicCamera.
Vec3f meanColor(const Scene& scene, const IntegratorSettings& settings, int size,
                uint32_t samples) {
  const Camera camera = orthographicCamera(size);
  const PixelFilter filter;
  double sum[3] = {0, 0, 0};
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (uint32_t i = 0; i < samples; ++i) {
        const Vec3f radiance =
            renderCameraSample(scene, camera, filter, x, y, i, settings).radiance;
        for (int c = 0; c < 3; ++c) sum[c] += radiance[c];
      }
  const double count = double(size) * size * samples;
  return {float(sum[0] / count), float(sum[1] / count), float(sum[2] / count)};
}

/// Its channel average.
double meanRadiance(const Scene& scene, const IntegratorSettings& settings, int size,
                    uint32_t samples) {
  const Vec3f mean = meanColor(scene, settings, size, samples);
  return (double(mean.x) + mean.y + mean.z) / 3;
}

TEST(PhaseFunction, HenyeyGreensteinIntegratesToOneAndSamplesItsDensity) {
  const Vec3f incoming = normalize(Vec3f(0.3f, -0.5f, 0.8f));
  for (const float g : {-0.7f, 0.0f, 0.3f, 0.9f}) {
    const HenyeyGreenstein phase(g);
    // ∫ p dω = 2π ∫ p(cos θ) d cos θ, by the midpoint rule.
    const int steps = 200000;
    double integral = 0, meanCosine = 0;
    for (int i = 0; i < steps; ++i) {
      const float c = -1 + 2 * (float(i) + 0.5f) / steps;
      integral += 2 * M_PI * phase.density(c) * 2.0 / steps;
      meanCosine += 2 * M_PI * phase.density(c) * c * 2.0 / steps;
    }
    EXPECT_NEAR(integral, 1.0, 1e-3) << "g = " << g;
    EXPECT_NEAR(meanCosine, g, 2e-3) << "g = " << g;
    // Sampled cosines fall into 20 bins as often as the density says.
    const int bins = 20, n = 200000;
    std::vector<int> counts(bins, 0);
    RandomStream random(1, 2, 3, 4, 5);
    for (int i = 0; i < n; ++i) {
      const Vec3f d = phase.sample(incoming, random.next2D());
      ASSERT_NEAR(length(d), 1.0f, 1e-4f);
      const float c = std::clamp(dot(d, incoming), -1.0f, 0.999999f);
      ++counts[size_t((c + 1) / 2 * bins)];
    }
    for (int b = 0; b < bins; ++b) {
      double expected = 0;
      const int sub = 1000;
      for (int k = 0; k < sub; ++k) {
        const float c = -1 + (float(b) + (float(k) + 0.5f) / sub) * 2.0f / bins;
        expected += 2 * M_PI * phase.density(c) * (2.0 / bins) / sub;
      }
      const double sigma = std::sqrt(n * expected * (1 - expected)) + 1;
      EXPECT_NEAR(counts[size_t(b)], n * expected, 5 * sigma) << "g = " << g << ", bin " << b;
    }
  }
}

TEST(Volumes, AbsorbingSlabPassesBeerLambert) {
  for (const float sigma : {0.25f, 1.0f, 3.0f})
    for (const float thickness : {0.5f, 2.0f}) {
      const Device device;
      Scene scene(device);
      VolumeData data;
      data.material = absorbing(sigma);
      data.objectBounds = slab(-thickness / 2, thickness / 2);
      addVolume(scene, std::move(data));
      addLight(scene, whiteDome());
      scene.commit();
      const double expected = std::exp(-double(sigma) * thickness);
      // Each sample passes (1) or is absorbed (0): binomial noise over 8·8·128 samples.
      const double tolerance = binomialTolerance(expected, 8192);
      EXPECT_NEAR(meanRadiance(scene, IntegratorSettings(), 8, 128), expected, tolerance)
          << "sigma " << sigma << ", thickness " << thickness;
    }
}

TEST(Volumes, ADensityBeyondSinglePrecisionIsRefused) {
  // Its majorant was infinite, and free flights subtract majorants: every pixel behind it NaN.
  const Device device;
  Scene scene(device);
  EXPECT_THROW(scene.volumes().setData(scene.volumes().add(),
                                       whiteScatteringSlab(std::numeric_limits<float>::max())),
               std::invalid_argument);
  EXPECT_NO_THROW(scene.volumes().setData(scene.volumes().add(), whiteScatteringSlab(1e6f)));
}

TEST(Volumes, OverlappingVolumesAddTheirCoefficients) {
  // Six slabs (more than a ray keeps in place) overlapping over [−0.5, 0.5], two more
  // overlapping over half of that: T = exp(−(6 · 0.2 · 1 + 2 · 0.3 · 0.5)).
  const Device device;
  Scene scene(device);
  for (int i = 0; i < 6; ++i) {
    VolumeData data;
    data.material = absorbing(0.2f);
    data.objectBounds = slab(-0.5f - 0.1f * float(i), 0.5f + 0.1f * float(i));
    // Placed so that each covers exactly [−0.5, 0.5] along z: translated, scaled boxes.
    const double scale = 1 / (1 + 0.2 * i);
    const double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, scale, 0, 0, 0, 0, 1};
    addVolume(scene, std::move(data), Transform::fromRowMajor(m));
  }
  for (int i = 0; i < 2; ++i) {
    VolumeData data;
    data.material = absorbing(0.3f);
    data.objectBounds = slab(0, 0.5f);
    addVolume(scene, std::move(data));
  }
  addLight(scene, whiteDome());
  scene.commit();
  const double expected = std::exp(-(6 * 0.2 + 2 * 0.3 * 0.5));
  const double tolerance = binomialTolerance(expected, 8192);
  EXPECT_NEAR(meanRadiance(scene, IntegratorSettings(), 8, 128), expected, tolerance);
}

TEST(Volumes, AlphaIsTheMediumsOpacityAndDepthItsFirstCollision) {
  // Nothing behind the slab: a camera sample is opaque where it collided in the medium, so alpha
  // averages 1 − T, and its depth is where it collided (the slab's front at z = 0.5).
  const Device device;
  Scene scene(device);
  VolumeData data;
  data.material = absorbing(1);
  data.objectBounds = slab(-0.5f, 0.5f);
  addVolume(scene, std::move(data));
  scene.commit();
  const Camera camera = orthographicCamera(8);
  const PixelFilter filter;
  double alpha = 0;
  int collided = 0;
  for (uint32_t i = 0; i < 4096; ++i) {
    const CameraSample s = renderCameraSample(scene, camera, filter, int(i % 8), int(i / 8 % 8),
                                              i / 64, IntegratorSettings());
    alpha += s.alpha;
    if (s.alpha > 0) {
      ++collided;
      EXPECT_GE(s.depth, 5.5f - 1e-4f);  // the camera is at z = 6
      EXPECT_LE(s.depth, 6.5f + 1e-4f);
    } else {
      EXPECT_EQ(s.depth, kInfinity);
    }
  }
  const double expected = 1 - std::exp(-1.0);
  EXPECT_NEAR(alpha / 4096, expected, 5 * std::sqrt(expected * (1 - expected) / 4096));
  EXPECT_GT(collided, 0);
}

TEST(Volumes, ScatteringMediumUnderWhiteDomeStaysWhite) {
  for (const float g : {0.0f, 0.7f, -0.4f}) {
    const Device device;
    Scene scene(device);
    VolumeData data = whiteScatteringSlab(2, 0.4f);  // the camera sees its face and the dome
    data.material.anisotropy = g;
    addVolume(scene, std::move(data));
    addLight(scene, whiteDome());
    scene.commit();
    IntegratorSettings settings;
    settings.maxPathDepth = settings.maxVolumeDepth = 1000;
    EXPECT_NEAR(meanRadiance(scene, settings, 8, 128), 1.0, 0.01) << "g = " << g;
    // With the cap at its default, light is lost: the cap does act.
    EXPECT_LT(meanRadiance(scene, IntegratorSettings(), 8, 32), 0.97) << "g = " << g;
  }
}

TEST(Volumes, PathsBranchingAtAFloorBelowAScatteringMediumStayWhite) {
  // A white floor seen through a white scattering slab, under a white dome: camera rays that
  // reach the floor branch there (IntegratorSettings::indirectSamples), and the branches cross
  // the slab again with volume random numbers of their own, losing and adding no light.
  const Device device;
  Scene scene(device);
  addVolume(scene, whiteScatteringSlab(0.3f));
  addWhiteFloor(scene);
  addLight(scene, whiteDome());
  scene.commit();
  IntegratorSettings settings;
  settings.maxPathDepth = settings.maxDiffuseDepth = settings.maxVolumeDepth = 1000;
  settings.indirectSamples = 3;
  EXPECT_NEAR(meanRadiance(scene, settings, 8, 64), 1.0, 0.01);
}

TEST(Volumes, EmittingMediumMatchesItsClosedForm) {
  // dL/ds = E − σa L through a slab of thickness d, nothing behind: L = E/σa · (1 − e^(−σa d));
  // without absorption, L = E d.
  for (const float sigma : {0.0f, 0.5f, 2.0f}) {
    const Device device;
    Scene scene(device);
    VolumeData data;
    data.material = absorbing(sigma);
    data.material.emission = Vec3f(0.8f);
    const float thickness = 1.5f;
    data.objectBounds = slab(-thickness / 2, thickness / 2);
    addVolume(scene, std::move(data));
    scene.commit();
    const double expected =
        sigma > 0 ? 0.8 / sigma * (1 - std::exp(-double(sigma) * thickness)) : 0.8 * thickness;
    EXPECT_NEAR(meanRadiance(scene, IntegratorSettings(), 8, 64) / expected, 1.0, 0.02)
        << "sigma " << sigma;
  }
}

TEST(Volumes, BlackbodyEmissionFollowsStefanBoltzmann) {
  // Emission only: L = E d, with E's luminance σ_SB T⁴ 10⁻⁶/π × intensity.
  const Device device;
  Scene scene(device);
  VolumeData data;
  data.material = absorbing(0);
  data.material.blackbodyIntensity = 2;
  data.material.temperature = 1500;
  data.objectBounds = slab(-0.5f, 0.5f);
  addVolume(scene, std::move(data));
  scene.commit();
  // Where nothing absorbs, emission is collected at tentative collisions about two per unit of
  // length here: the estimate is noisy per sample, so take many.
  const Vec3f mean = meanColor(scene, IntegratorSettings(), 8, 128);
  const double expected = 5.670373e-8 * 1e-6 / M_PI * std::pow(1500.0, 4) * 2;
  EXPECT_NEAR(luminance(mean) / expected, 1.0, 0.03);
  EXPECT_GT(mean.x, mean.y);  // 1500 K glows red-orange
  EXPECT_GT(mean.y, mean.z);
}

/// Density varying along z (the rays' direction) with an empty gap, and its integral.
class StripedField final : public VolumeField {
 public:
  static float density(float z) { return std::abs(z) < 0.2f ? 0.0f : 1.5f + std::sin(4 * z); }
  int components() const override { return 1; }
  void sample(const Vec3f& p, float* value) const override { value[0] = density(p.z); }
  Bounds3f objectBounds() const override { return slab(-1, 1); }
  float maxIn(const Bounds3f& box) const override {
    // Exact enough: the largest of a fine scan over the box's z range.
    float largest = 0;
    for (int i = 0; i <= 256; ++i)
      largest = std::max(largest, density(box.lower.z + (box.upper.z - box.lower.z) * i / 256));
    return largest + 0.02f;
  }
  uint64_t activeVoxels() const override { return 1; }  // gridded: a majorant grid is built
  size_t memoryBytes() const override { return 0; }
};

double stripedOpticalDepth() {
  const int steps = 100000;
  double depth = 0;
  for (int i = 0; i < steps; ++i)
    depth += StripedField::density(-1 + 2 * (float(i) + 0.5f) / steps) * 2.0 / steps;
  return depth;
}

TEST(Volumes, HeterogeneousTransmittanceMatchesNumericalIntegration) {
  const double transmittance = std::exp(-stripedOpticalDepth());
  VolumeData data;
  data.density = std::make_shared<StripedField>();
  data.material = absorbing(1);
  {
    // Camera rays (free-flight sampling) through the field in front of the dome.
    const Device device;
    Scene scene(device);
    addVolume(scene, data);
    addLight(scene, whiteDome());
    scene.commit();
    const double tolerance = binomialTolerance(transmittance, 8192);
    EXPECT_NEAR(meanRadiance(scene, IntegratorSettings(), 8, 128), transmittance, tolerance);
  }
  // Shadow rays (ratio tracking): a white floor behind the field, lit by a distant light
  // shining down −z through it, looks T² as bright as without the field (T for the camera
  // ray, T for the shadow ray).
  double lit[2] = {0, 0};
  for (const bool withField : {false, true}) {
    const Device device;
    Scene scene(device);
    addWhiteFloor(scene);
    LightParams sun;
    sun.type = LightType::Distant;  // shines down its local −z
    sun.angle = 0;
    addLight(scene, sun);
    if (withField) addVolume(scene, data);
    scene.commit();
    IntegratorSettings settings;
    settings.maxPathDepth = 1;  // direct light only
    lit[withField] = meanRadiance(scene, settings, 8, 64);
  }
  ASSERT_GT(lit[0], 0.05);
  EXPECT_NEAR(lit[1] / lit[0], transmittance * transmittance, 0.03 * transmittance);
}

TEST(Volumes, OpenVdbGridTransmittanceMatchesNumericalIntegration) {
  // A sparse grid (NanoVDB) whose voxels vary at random along z and repeat across x and y, so
  // that every camera ray down −z sees the same profile: its transmittance must match the
  // numerical integral of the grid's own trilinear interpolant along the ray. Zero voxels (a gap)
  // stay inactive, so the majorant grid has empty cells to skip.
  const int nx = 24, ny = 24, nz = 40;
  std::vector<float> profile(nz);
  RandomStream random(7, 0, 0, 0, 0);
  for (int k = 0; k < nz; ++k) profile[size_t(k)] = k >= 15 && k < 22 ? 0 : 3 * random.next();
  std::vector<float> values;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) values.push_back(profile[size_t(k)]);
  const double voxel = 0.1;
  const double indexToObject[16] = {voxel, 0, 0,     0, 0,     voxel, 0,  0,
                                    0,     0, voxel, 0, -1.15, -1.15, -2, 1};
  VolumeData data;
  data.density = denseVdbField(nx, ny, nz, 1, values, Transform::fromRowMajor(indexToObject));
  data.material = absorbing(0.3f);
  double opticalDepth = 0;
  const int steps = 200000;
  const float zLow = -2.2f, zHigh = 2.2f;
  for (int i = 0; i < steps; ++i) {
    float density = 0;
    data.density->sample({0.1f, -0.2f, zLow + (zHigh - zLow) * (float(i) + 0.5f) / steps},
                         &density);
    opticalDepth += 0.3 * density * (zHigh - zLow) / steps;
  }
  const double transmittance = std::exp(-opticalDepth);
  ASSERT_GT(transmittance, 0.02);
  ASSERT_LT(transmittance, 0.9);
  const Device device;
  Scene scene(device);
  addVolume(scene, data, translation(0, 0, 0.3));
  addLight(scene, whiteDome());
  scene.commit();
  const double tolerance = binomialTolerance(transmittance, 8192);
  EXPECT_NEAR(meanRadiance(scene, IntegratorSettings(), 8, 128), transmittance, tolerance);
}

TEST(Volumes, PlacementMovesTheMedium) {
  // The same slab moved out of the view no longer darkens it.
  const Device device;
  Scene scene(device);
  VolumeData data;
  data.material = absorbing(2);
  data.objectBounds = slab(-0.5f, 0.5f, 0.6f);
  addVolume(scene, data, translation(5, 0, 0));
  addLight(scene, whiteDome());
  scene.commit();
  EXPECT_DOUBLE_EQ(meanRadiance(scene, IntegratorSettings(), 4, 8), 1.0);
}

TEST(Volumes, InvalidVolumesAreRefused) {
  const auto refused = [](const VolumeData& data) {
    try {
      validateVolume(data);
    } catch (const std::invalid_argument&) {
      return true;
    }
    return false;
  };
  VolumeData good;
  good.objectBounds = slab(0, 1);
  EXPECT_FALSE(refused(good));
  VolumeData bad = good;
  bad.material.density = NAN;
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad.material.anisotropy = 1;
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad.material.scattering = {0.5f, -1, 0.5f};
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad.density = constantField(Vec3f(1.0f), 3);  // a vector cannot be a density
  EXPECT_TRUE(refused(bad));
  bad = VolumeData();  // no fields, no box
  EXPECT_TRUE(refused(bad));
  bad.density = constantField(Vec3f(1.0f));  // a constant has no bounds of its own
  EXPECT_TRUE(refused(bad));
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

/// A floor at z = −3 lit by a distant light shining down −z (link slot `slot`) through an
/// absorbing slab of optical depth 0.5 that is of linking class `linkingClass`, whose class 1
/// leaves slot 0 out of its light link (`lightLink`) or its shadow link; the floor's mean
/// radiance, direct light only.
double floorUnderLinkedSlab(int slot, uint32_t linkingClass, bool lightLink) {
  const Device device;
  Scene scene(device);
  addWhiteFloor(scene);
  LightParams sun;
  sun.type = LightType::Distant;
  sun.angle = 0;
  sun.linkSlot = slot;
  addLight(scene, sun);
  VolumeData data;
  data.material = absorbing(0.25f);
  data.objectBounds = slab(-1, 1);
  const VolumeSet::VolumeId volume = addVolume(scene, std::move(data));
  scene.volumes().setLinkingClass(volume, linkingClass);
  LinkingClass excluded;
  (lightLink ? excluded.lightExcludedSlots : excluded.shadowExcludedSlots) = {0};
  scene.geometry().setLinkingClasses({excluded});
  scene.commit();
  IntegratorSettings settings;
  settings.maxPathDepth = 1;
  return meanRadiance(scene, settings, 8, 64);
}

TEST(Volumes, AVolumeOutsideALightsShadowLinkLetsItsShadowRaysPass) {
  const double transmittance = std::exp(-0.5);
  // Linked (the light links everything, or the volume's class is 0): the floor looks T² as
  // bright as unshadowed (T for the camera ray, T for the shadow ray); outside the shadow
  // link, T (camera rays still cross the medium).
  const double linked = floorUnderLinkedSlab(-1, 1, false);
  const double ofClassZero = floorUnderLinkedSlab(0, 0, false);
  const double passed = floorUnderLinkedSlab(0, 1, false);
  ASSERT_GT(passed, 0.01);
  EXPECT_EQ(linked, ofClassZero);
  // The same camera flights in both: the ratio is the shadow rays' mean transmittance over the
  // ~T × 4096 samples that reach the floor, each 0 or 1 here (a constant medium's majorant is
  // its extinction): binomial noise.
  const double reaching = transmittance * 4096;
  EXPECT_NEAR(linked / passed, transmittance, binomialTolerance(transmittance, reaching));
  // A light link only (the shadow link includes it): the slab still shadows.
  EXPECT_EQ(floorUnderLinkedSlab(0, 1, true), linked);
}

TEST(Volumes, AVolumeOutsideALightsLightLinkScattersNoneOfItsLight) {
  // An albedo-1 slab under a white dome: about 1 when linked (the white furnace); outside the
  // dome's light link, only the dome seen through it without a collision, e^(−σd).
  const auto render = [](uint32_t linkingClass) {
    const Device device;
    Scene scene(device);
    const VolumeSet::VolumeId volume = addVolume(scene, whiteScatteringSlab(1));
    scene.volumes().setLinkingClass(volume, linkingClass);
    LightParams dome = whiteDome();
    dome.linkSlot = 0;
    addLight(scene, dome);
    LinkingClass excluded;
    excluded.lightExcludedSlots = {0};
    scene.geometry().setLinkingClasses({excluded});
    scene.commit();
    IntegratorSettings settings;
    settings.maxPathDepth = settings.maxVolumeDepth = 1000;
    return meanRadiance(scene, settings, 8, 128);
  };
  EXPECT_NEAR(render(0), 1.0, 0.03);  // the furnace through the whole view: 8192 samples' noise
  const double uncollided = std::exp(-2.0);
  EXPECT_NEAR(render(1), uncollided, binomialTolerance(uncollided, 8192));
}

}  // namespace
}  // namespace penumbra
