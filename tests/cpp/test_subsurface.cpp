// Random-walk subsurface scattering (subsurface.h) and the BSDF's Subsurface lobe: walks in
// closed meshes against energy conservation, Beer–Lambert absorption, the scaling of their
// spread with the mean free path and the albedo the inversion promises.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/bsdf.h"
#include "penumbra/camera.h"
#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "penumbra/light.h"
#include "penumbra/scene.h"
#include "penumbra/subsurface.h"
#include "penumbra/surface_hit.h"
#include "penumbra/warp.h"
#include "transforms.h"
#include "white_furnace.h"

using namespace penumbra;

namespace {

/// A closed UV sphere of `radius` about the origin, with outward faces.
TriangleMesh sphere(float radius, int rings, int segments) {
  MeshData data;
  data.points.push_back({0, radius, 0});
  for (int ring = 1; ring < rings; ++ring) {
    const float theta = kPi * float(ring) / float(rings);
    for (int segment = 0; segment < segments; ++segment) {
      const float phi = 2 * kPi * float(segment) / float(segments);
      data.points.push_back({radius * std::sin(theta) * std::cos(phi), radius * std::cos(theta),
                             radius * std::sin(theta) * std::sin(phi)});
    }
  }
  data.points.push_back({0, -radius, 0});
  const int bottom = int(data.points.size()) - 1;
  const auto vertex = [&](int ring, int segment) {
    return 1 + (ring - 1) * segments + segment % segments;
  };
  for (int segment = 0; segment < segments; ++segment) {
    data.faceVertexCounts.push_back(3);
    data.faceVertexIndices.insert(data.faceVertexIndices.end(),
                                  {0, vertex(1, segment + 1), vertex(1, segment)});
    for (int ring = 1; ring + 1 < rings; ++ring) {
      data.faceVertexCounts.push_back(4);
      data.faceVertexIndices.insert(data.faceVertexIndices.end(),
                                    {vertex(ring, segment), vertex(ring, segment + 1),
                                     vertex(ring + 1, segment + 1), vertex(ring + 1, segment)});
    }
    data.faceVertexCounts.push_back(3);
    data.faceVertexIndices.insert(data.faceVertexIndices.end(), {bottom, vertex(rings - 1, segment),
                                                                 vertex(rings - 1, segment + 1)});
  }
  return triangulate(data);
}

/// The closed cube [−1, 1]³ with outward faces.
TriangleMesh cube() {
  MeshData data;
  data.points = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                 {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
  data.faceVertexCounts = {4, 4, 4, 4, 4, 4};
  data.faceVertexIndices = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 0, 4, 7, 3, 1, 2, 6, 5};
  return triangulate(data);
}

/// A scene of one closed mesh, and the hit of a ray coming down the Y axis onto its top.
struct Solid {
  Device device;
  Scene scene{device};
  SurfaceHit top;

  explicit Solid(TriangleMesh mesh) {
    const Geometry::MeshId id = scene.geometry().addMesh();
    scene.geometry().setMeshGeometry(id, std::move(mesh));
    scene.geometry().setMeshInstance(id, Transform(), MaterialTable::kNoMaterial, true);
    scene.commit();
    Ray ray;
    // Above the largest solid (radius 50), and far: the entry point is rebuilt from the top
    // face's corners, so it lies on the face whatever the distance (as origin + distance ·
    // direction from y = 1000 it lay 6e-5 above it on an AMD EPYC, more than the walk's spawn
    // offset of 2e-5, and every walk re-entered the face).
    ray.origin = {0, 1000, 0};
    ray.direction = {0, -1, 0};
    top = *intersectSurface(scene, ray, RayKind::Camera);
  }
};

MaterialParams subsurfaceMaterial(const Vec3f& color, const Vec3f& radius, float g = 0) {
  MaterialParams m;
  m.subsurface = 1;
  m.subsurfaceColor = color;
  m.subsurfaceRadius = radius;
  m.subsurfaceAnisotropy = g;
  return m;
}

/// What `count` walks from the solid's top give: the mean exit weight (absorbed walks count 0),
/// how many exited, and the weight-averaged distance from the entry to the exit.
struct WalkStatistics {
  Vec3f meanWeight{0.0f};
  int exits = 0;
  double meanDistance = 0;
};

WalkStatistics walk(const Solid& solid, const SubsurfaceMedium& medium, int count,
                    bool straightDown = false) {
  WalkStatistics result;
  double weightSum = 0, weightedDistance = 0;
  for (int i = 0; i < count; ++i) {
    RandomStream random(7, 0, 0, uint32_t(i), 0);
    const Vec3f inward =
        straightDown ? Vec3f(0, -1, 0)
                     : Frame(-solid.top.normal).toWorld(sampleCosineHemisphere(random.next2D()));
    const std::optional<SubsurfaceExit> exit =
        subsurfaceRandomWalk(solid.scene, solid.top, inward, medium, random, 0);
    if (!exit) continue;
    EXPECT_TRUE(exit->sameObject);
    EXPECT_GT(dot(exit->direction, exit->hit.normal), 0);  // leaving through the outward face
    ++result.exits;
    result.meanWeight += exit->weight;
    const float w = luminance(exit->weight);
    weightSum += w;
    weightedDistance += w * length(exit->hit.position - solid.top.position);
  }
  result.meanWeight = result.meanWeight * (1.0f / float(count));
  result.meanDistance = weightedDistance / weightSum;
  return result;
}

}  // namespace

TEST(Subsurface, MediumFollowsTheAuthoredColourRadiusAndAnisotropy) {
  // The fit's end points, to its printed precision.
  EXPECT_NEAR(subsurfaceSingleScatteringAlbedo(0), 0, 1e-4f);
  EXPECT_NEAR(subsurfaceSingleScatteringAlbedo(1), 1, 1e-4f);
  EXPECT_EQ(subsurfaceSingleScatteringAlbedo(-3), subsurfaceSingleScatteringAlbedo(0));
  // Multiple scattering needs a far brighter single-scattering albedo, increasingly so.
  float previous = 0;
  for (const float a : {0.1f, 0.3f, 0.5f, 0.7f, 0.9f}) {
    const float alpha = subsurfaceSingleScatteringAlbedo(a);
    EXPECT_GT(alpha, a);
    EXPECT_GT(alpha, previous);
    previous = alpha;
  }
  const SubsurfaceMedium isotropic =
      subsurfaceMedium(subsurfaceMaterial({0.2f, 0.5f, 0.9f}, {0.5f, 1, 0}));
  EXPECT_FLOAT_EQ(isotropic.extinction.x, 2);
  EXPECT_FLOAT_EQ(isotropic.extinction.y, 1);
  EXPECT_FLOAT_EQ(isotropic.extinction.z, 1 / kMinSubsurfaceRadius);
  EXPECT_FLOAT_EQ(isotropic.albedo.y, subsurfaceSingleScatteringAlbedo(0.5f));
  EXPECT_EQ(isotropic.anisotropy, 0);
  // Anisotropic: the similarity-reduced albedo and mean free path are those authored.
  for (const float g : {0.6f, -0.4f}) {
    const SubsurfaceMedium m = subsurfaceMedium(subsurfaceMaterial(Vec3f(0.5f), Vec3f(2), g));
    const float alpha = m.albedo.x;
    EXPECT_NEAR(alpha * (1 - g) / (1 - alpha * g), subsurfaceSingleScatteringAlbedo(0.5f), 1e-6f);
    EXPECT_NEAR(1 / (m.extinction.x * (1 - alpha * g)), 2, 1e-5f);
  }
  EXPECT_EQ(subsurfaceMedium(subsurfaceMaterial(Vec3f(0.5f), Vec3f(1), 3)).anisotropy,
            kMaxSubsurfaceAnisotropy);
}

TEST(Subsurface, TransmissionAbsorptionIsBeerLambertOverTheDepth) {
  MaterialParams m;
  m.transmissionColor = {0.5f, 1, 0.25f};
  EXPECT_TRUE(isBlack(transmissionAbsorption(m)));  // depth 0: clear
  m.transmissionDepth = 2;
  const Vec3f sigma = transmissionAbsorption(m);
  EXPECT_FLOAT_EQ(sigma.x, std::log(2.0f) / 2);
  EXPECT_FLOAT_EQ(sigma.y, 0);
  EXPECT_FLOAT_EQ(sigma.z, std::log(4.0f) / 2);
  // Through depth units of it, the colour is what remains.
  EXPECT_NEAR(std::exp(-sigma.z * 2), 0.25f, 1e-6f);
  m.transmissionDepth = -1;
  EXPECT_TRUE(isBlack(transmissionAbsorption(m)));
}

TEST(Subsurface, WhiteMediumReturnsAllEnergy) {
  // A furnace: with albedo 1 every walk leaves, and the chromatic free-flight weights average
  // to 1 in each channel.
  const Solid solid(sphere(1, 48, 96));
  const SubsurfaceMedium medium = subsurfaceMedium(subsurfaceMaterial(Vec3f(1), {0.1f, 0.3f, 1}));
  const int count = 20000;
  const WalkStatistics s = walk(solid, medium, count);
  EXPECT_GE(s.exits, count * 995 / 1000);  // the step cap may stop a few
  EXPECT_NEAR(s.meanWeight.x, 1, 0.02f);
  EXPECT_NEAR(s.meanWeight.y, 1, 0.02f);
  EXPECT_NEAR(s.meanWeight.z, 1, 0.02f);
}

TEST(Subsurface, PureAbsorptionAttenuatesStraightPathsByBeerLambert) {
  // Albedo 0: only walks that cross the cube's height 2 without an event leave, with each
  // channel's transmittance e^(−2/radius) on average.
  const Solid solid(cube());
  const Vec3f radius{0.5f, 1, 2};
  const SubsurfaceMedium medium = subsurfaceMedium(subsurfaceMaterial(Vec3f(0), radius));
  const WalkStatistics s = walk(solid, medium, 100000, true);
  EXPECT_NEAR(s.meanWeight.x / std::exp(-2 / radius.x), 1, 0.03f);
  EXPECT_NEAR(s.meanWeight.y / std::exp(-2 / radius.y), 1, 0.03f);
  EXPECT_NEAR(s.meanWeight.z / std::exp(-2 / radius.z), 1, 0.03f);
  EXPECT_NEAR(s.meanDistance, 2, 1e-3);  // straight through, to the bottom face
}

TEST(Subsurface, SpreadScalesWithTheRadius) {
  // In a sphere 100 mean free paths wide (a semi-infinite medium, near enough), doubling the
  // radius doubles the distance light travels under the surface.
  const Solid solid(sphere(50, 96, 192));
  const int count = 20000;
  const double near =
      walk(solid, subsurfaceMedium(subsurfaceMaterial(Vec3f(0.7f), Vec3f(0.25f))), count)
          .meanDistance;
  const double far =
      walk(solid, subsurfaceMedium(subsurfaceMaterial(Vec3f(0.7f), Vec3f(0.5f))), count)
          .meanDistance;
  EXPECT_GT(near, 0.25);
  EXPECT_NEAR(far / near, 2, 0.1);
}

TEST(Subsurface, WalksShowTheAuthoredColourOnAThickSolid) {
  // The inversion's promise: entered and left through cosine lobes, a semi-infinite medium
  // returns the authored multiple-scattering albedo.
  const Solid solid(sphere(50, 96, 192));
  const int count = 20000;
  for (const float g : {0.0f, 0.5f, -0.3f}) {
    for (const float target : {0.2f, 0.5f, 0.8f, 0.9f}) {
      SCOPED_TRACE(::testing::Message() << "g " << g << ", albedo " << target);
      const WalkStatistics s =
          walk(solid, subsurfaceMedium(subsurfaceMaterial(Vec3f(target), Vec3f(0.25f), g)), count);
      EXPECT_NEAR(s.meanWeight.x, target, 0.015f);  // measured: within 0.008
    }
  }
}

TEST(Subsurface, SubsurfaceLobeCarriesWhatTheDiffuseLobeWouldReflect) {
  const Vec3f normal = normalize(Vec3f(0.2f, 0.9f, -0.3f));
  MaterialParams diffuse;
  diffuse.diffuseColor = Vec3f(1);
  diffuse.roughness = 0.4f;
  MaterialParams translucent = diffuse;
  translucent.subsurface = 0.75f;
  translucent.subsurfaceColor = Vec3f(1);
  const PreviewSurfaceBsdf reflecting(diffuse, normal, 1.5f);
  const PreviewSurfaceBsdf entering(translucent, normal, 1.5f, DielectricKind::Solid);
  const Vec3f wo = normalize(normal + Vec3f(0.5f, 0, 0.4f));
  const int count = 200000;
  Vec3f reflected(0.0f), total(0.0f), entered(0.0f);
  int subsurfaceSamples = 0;
  for (int i = 0; i < count; ++i) {
    RandomStream random(5, 0, 0, uint32_t(i), 0);
    const float uLobe = random.next();
    const Vec2f u = random.next2D();
    if (const std::optional<BsdfSample> s = reflecting.sample(wo, uLobe, u)) reflected += s->weight;
    const std::optional<BsdfSample> s = entering.sample(wo, uLobe, u);
    if (!s) continue;
    total += s->weight;  // a white walk returns all that enters
    if (s->lobe != BsdfLobe::Subsurface) continue;
    ++subsurfaceSamples;
    entered += s->weight;
    EXPECT_TRUE(s->transmitted);
    EXPECT_FALSE(s->isDelta);
    EXPECT_LT(dot(s->direction, normal), 0);
  }
  EXPECT_GT(subsurfaceSamples, count / 4);
  // With a white walk, the surface keeps the energy of the all-diffuse one.
  EXPECT_NEAR(total.x / reflected.x, 1, 0.01f);
  // No light arrives through the entry: evaluate and pdf see the diffuse lobe's 1 − s share.
  MaterialParams quarter = diffuse;
  quarter.diffuseColor = Vec3f(0.25f);
  const PreviewSurfaceBsdf reduced(quarter, normal, 1.5f);
  const Vec3f wi = normalize(normal + Vec3f(-0.3f, 0.1f, 0.6f));
  EXPECT_NEAR(entering.evaluate(wo, wi).x, reduced.evaluate(wo, wi).x, 1e-6f);
  EXPECT_TRUE(isBlack(entering.evaluate(wo, -wi)));
  EXPECT_GT(entered.x, 0);
}

TEST(Subsurface, SheetsReflectTheSubsurfaceShareDiffusely) {
  const Vec3f normal{0, 0, 1};
  MaterialParams sheet;
  sheet.diffuseColor = {0.9f, 0.1f, 0.1f};
  sheet.subsurface = 1;
  sheet.subsurfaceColor = {0.2f, 0.6f, 0.3f};
  MaterialParams plain;
  plain.diffuseColor = sheet.subsurfaceColor;
  const PreviewSurfaceBsdf open(sheet, normal, 1.5f, DielectricKind::ThinSheet);
  const PreviewSurfaceBsdf reference(plain, normal, 1.5f, DielectricKind::ThinSheet);
  const Vec3f wo = normalize(Vec3f(0.3f, 0, 1)), wi = normalize(Vec3f(-0.2f, 0.4f, 1));
  const Vec3f a = open.evaluate(wo, wi), b = reference.evaluate(wo, wi);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.z, b.z);
  for (int i = 0; i < 64; ++i) {
    const std::optional<BsdfSample> s = open.sample(wo, (float(i) + 0.5f) / 64, {0.3f, 0.7f});
    ASSERT_TRUE(s);
    EXPECT_NE(s->lobe, BsdfLobe::Subsurface);
  }
}

TEST(Subsurface, AnotherObjectInsideEndsTheWalkAndOpenMeshesLoseIt) {
  // A clear medium (a mean free path far longer than the solid): the walk goes straight down.
  const SubsurfaceMedium clear = subsurfaceMedium(subsurfaceMaterial(Vec3f(0.5f), Vec3f(1e6f)));
  Solid solid(sphere(5, 24, 48));
  const Geometry::MeshId inner = solid.scene.geometry().addMesh();
  solid.scene.geometry().setMeshGeometry(inner, cube());
  solid.scene.geometry().setMeshInstance(inner, Transform(), MaterialTable::kNoMaterial, true);
  solid.scene.commit();
  RandomStream random(1, 0, 0, 0, 0);
  const std::optional<SubsurfaceExit> exit =
      subsurfaceRandomWalk(solid.scene, solid.top, {0, -1, 0}, clear, random, 0);
  ASSERT_TRUE(exit);
  EXPECT_FALSE(exit->sameObject);
  EXPECT_EQ(exit->hit.meshId, inner);
  EXPECT_NEAR(exit->hit.position.y, 1, 1e-4f);  // the cube's top
  // Walking away from every surface: nothing ahead, the light is lost.
  EXPECT_FALSE(subsurfaceRandomWalk(solid.scene, solid.top, {0, 1, 0}, clear, random, 0));
}

namespace {

/// A unit sphere whose material is all subsurface (no specular layer): white-coloured with mean
/// free path `radius`.
struct SubsurfaceSphere {
  Device device;
  Scene scene{device};
  explicit SubsurfaceSphere(float radius) {
    Material material;
    material.constants.useSpecularWorkflow = true;
    material.constants.specularColor = Vec3f(0.0f);
    material.constants.diffuseColor = Vec3f(1.0f);
    material.constants.subsurface = 1;
    material.constants.subsurfaceColor = Vec3f(1.0f);
    material.constants.subsurfaceRadius = Vec3f(radius);
    scene.setMaterial(0, material);
    const Geometry::MeshId id = scene.geometry().addMesh();
    scene.geometry().setMeshGeometry(id, sphere(1, 48, 96));
    scene.geometry().setMeshInstance(id, Transform(), 0, true);
  }
};

/// Lights the sphere from the right (+x) by a distant light, and commits its scene.
void lightFromTheRight(SubsurfaceSphere& s) {
  LightParams sun;
  sun.type = LightType::Distant;
  const double towardsMinusX[16] = {0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1};
  sun.lightToWorld = Transform::fromRowMajor(towardsMinusX);  // local −z onto world −x
  sun.angle = 0;
  std::vector<Light> lights;
  lights.emplace_back(sun);
  s.scene.lights().setLights(std::move(lights));
  s.scene.commit();
}

/// A camera `size` pixels square on the z axis at z = 6, looking at the sphere.
Camera cameraInFront(int size) {
  CameraParams lens;
  lens.cameraToWorld = test::translation(0, 0, 6);
  return Camera(lens, size, size);
}

/// The mean radiance of the left (x < 0) and right halves of the sphere, lit from the right
/// (+x) by a distant light, seen from z = 6.
std::pair<double, double> halvesLitFromTheRight(float radius) {
  SubsurfaceSphere s(radius);
  lightFromTheRight(s);
  const int size = 24;
  const Camera camera = cameraInFront(size);
  const PixelFilter filter;
  IntegratorSettings settings;
  settings.maxPathDepth = settings.maxDiffuseDepth = 8;
  double halves[2] = {0, 0};
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (uint32_t i = 0; i < 32; ++i)
        halves[x >= size / 2] +=
            luminance(renderCameraSample(s.scene, camera, filter, x, y, i, settings).radiance);
  return {halves[0], halves[1]};
}

}  // namespace

TEST(Subsurface, WhiteSubsurfaceSphereUnderAWhiteDomeIsWhite) {
  // End to end through the integrator: entry lobe, walk, Lambertian exit and its next-event
  // estimation together lose and add no light; so do paths that branch at the sphere, each
  // branch walking with random numbers of its own.
  for (const float radius : {0.05f, 0.5f})
    for (const int indirectSamples : {1, 3}) {
      SubsurfaceSphere s(radius);
      const test::FurnaceImage image = test::renderUnderWhiteDome(s.scene, indirectSamples);
      ASSERT_GT(image.coverage, 0.3);
      const double sphereMean = (image.meanRadiance - (1 - image.coverage)) / image.coverage;
      EXPECT_NEAR(sphereMean, 1.0, 0.02)
          << "radius " << radius << ", " << indirectSamples << " indirect samples";
    }
}

TEST(Subsurface, LongerMeanFreePathsCarryLightIntoTheShadow) {
  // Lit from the right, the left half of the sphere is in shadow: only light that travels
  // through the material reaches it, more of it the longer the mean free path.
  const auto [shortLeft, shortRight] = halvesLitFromTheRight(0.01f);
  const auto [longLeft, longRight] = halvesLitFromTheRight(0.5f);
  const double shortShare = shortLeft / shortRight, longShare = longLeft / longRight;
  RecordProperty("shadowShareRadius0.01", std::to_string(shortShare));
  RecordProperty("shadowShareRadius0.5", std::to_string(longShare));
  EXPECT_LT(shortShare, 0.05);
  EXPECT_GT(longShare, 4 * shortShare);
  EXPECT_GT(longShare, 0.1);
}

TEST(Subsurface, EachBranchKeepsTheLightItsWalkFindsAtItsExit) {
  // Paths that branch at the sphere each walk through it and are lit at their own exits. Cut
  // after the walk, that light is all a branch finds: the difference of a sample's two
  // branches (which the branching pilot takes for the noise beyond the first surface) then
  // averages 0. Credited to the wrong branch, it would average twice the sample's radiance.
  SubsurfaceSphere s(0.5f);
  lightFromTheRight(s);
  const int size = 24;
  const Camera camera = cameraInFront(size);
  const PixelFilter filter;
  IntegratorSettings settings;
  settings.indirectSamples = 2;
  settings.maxPathDepth = 1;
  double radiance = 0, difference = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (uint32_t i = 0; i < 32; ++i) {
        const CameraSample sample = renderCameraSample(s.scene, camera, filter, x, y, i, settings);
        radiance += luminance(sample.radiance);
        difference += luminance(sample.branchDifference);
      }
  ASSERT_GT(radiance, 0);
  RecordProperty("differenceOverRadiance", std::to_string(difference / radiance));
  EXPECT_LT(std::abs(difference), 0.1 * radiance);
}

TEST(Subsurface, AbsorbingGlassFollowsBeerLambertEndToEnd) {
  // A clear cube of index 1 (no reflection, no bending) 2 units thick in front of a white dome:
  // the camera sees transmissionColor^(2 / transmissionDepth) through it.
  Device device;
  Scene scene(device);
  Material glass;
  glass.constants.opacity = 0;
  glass.constants.ior = 1;
  glass.constants.roughness = 0;
  glass.constants.transmissionColor = {0.5f, 0.8f, 1.0f};
  glass.constants.transmissionDepth = 1;
  scene.setMaterial(0, glass);
  const Geometry::MeshId id = scene.geometry().addMesh();
  scene.geometry().setMeshGeometry(id, cube());
  scene.geometry().setMeshInstance(id, Transform(), 0, true);
  LightParams dome;
  dome.type = LightType::Dome;
  std::vector<Light> lights;
  lights.emplace_back(dome);
  scene.lights().setLights(std::move(lights));
  scene.commit();
  CameraParams lens;
  lens.projection = Projection::Orthographic;
  lens.horizontalAperture = lens.verticalAperture = 10;  // a 1 × 1 window inside the cube's face
  lens.cameraToWorld = test::translation(0, 0, 6);
  const Camera camera(lens, 4, 4);
  const PixelFilter filter;
  Vec3f sum{0.0f};
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      for (uint32_t i = 0; i < 4; ++i)
        sum += renderCameraSample(scene, camera, filter, x, y, i, IntegratorSettings()).radiance;
  const Vec3f mean = sum / 64.0f;
  EXPECT_NEAR(mean.x, 0.25f, 1e-3f);
  EXPECT_NEAR(mean.y, 0.64f, 1e-3f);
  EXPECT_NEAR(mean.z, 1.0f, 1e-3f);
}
