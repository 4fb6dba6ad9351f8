#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "penumbra/hair_bsdf.h"
#include "penumbra/material_inputs.h"
#include "penumbra/mesh_shape.h"
#include "penumbra/sampler.h"
#include "penumbra/shading.h"

using namespace penumbra;

namespace {

// A fibre and a normal off the axes (the normal not quite perpendicular to the fibre: the BSDF
// projects it), so that the local frame is exercised.
const Vec3f kFibre = normalize(Vec3f(0.2f, 0.9f, -0.3f));
const Vec3f kNormal = normalize(Vec3f(0.8f, -0.1f, 0.5f) + kFibre * 0.05f);

/// The normal made perpendicular to the fibre, and the frame's third axis.
Vec3f across() {
  return normalize(kNormal - kFibre * dot(kNormal, kFibre));
}
Vec3f sideways() {
  return cross(across(), kFibre);
}

/// The direction at longitudinal angle θ (sin θ = w·fibre) whose offset across the fibre, seen
/// from it, is h (h = sin γ, γ the angle between its azimuth and the normal's).
Vec3f directionWithOffset(float thetaDegrees, float h) {
  const float theta = thetaDegrees * kPi / 180;
  const float cosGamma = std::sqrt(1 - h * h);
  return normalize(kFibre * std::sin(theta) +
                   (sideways() * -h + across() * cosGamma) * std::cos(theta));
}

/// The direction at longitudinal angle θ and azimuth φ about the fibre, from the normal.
Vec3f directionAt(float sinTheta, float phi) {
  const float cosTheta = std::sqrt(std::max(0.0f, 1 - sinTheta * sinTheta));
  return normalize(kFibre * sinTheta +
                   (across() * std::cos(phi) + sideways() * std::sin(phi)) * cosTheta);
}

struct HairConfig {
  float betaM = 0.3f, betaN = 0.3f, alphaDegrees = 2, ior = 1.55f;
  Vec3f absorption{0.0f};
};

MaterialParams hair(const HairConfig& c) {
  MaterialParams m;
  m.hair = true;
  m.hairLongitudinalRoughness = c.betaM;
  m.hairAzimuthalRoughness = c.betaN;
  m.hairCuticleAngle = c.alphaDegrees;
  m.hairIor = c.ior;
  m.hairAbsorption = c.absorption;
  return m;
}

HairBsdf makeHair(const MaterialParams& m) {
  return HairBsdf(m, kFibre, kNormal, kNormal);
}

double mean(const Vec3f& v) {
  return (double(v.x) + v.y + v.z) / 3;
}

/// ∫ evaluate(wo, wi) dωi by a stratified grid in (sin θi, φi) about the fibre — uniform over
/// the sphere and independent of the BSDF's sampling. `pdf`: integrate pdf() instead.
double integrateUniformly(const HairBsdf& bsdf, const Vec3f& wo, bool pdf = false, int n = 512) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const Vec3f wi = directionAt(-1 + 2 * (float(i) + 0.5f) / float(n),
                                   2 * kPi * (float(j) + 0.5f) / float(n));
      sum += pdf ? double(bsdf.pdf(wo, wi)) : mean(bsdf.evaluate(wo, wi));
    }
  }
  return sum * 4 * kPi / (double(n) * n);
}

/// The albedo for wo by the BSDF's own sampling: the mean of the sample weights.
Vec3f integrateByImportance(const HairBsdf& bsdf, const Vec3f& wo, uint32_t samples = 1u << 16) {
  Vec3f sum{0.0f};
  for (uint32_t i = 0; i < samples; ++i) {
    SampleStream stream(7, 1, 2, i);
    const float uLobe = stream.next1D();
    if (const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D()))
      sum += s->weight;
  }
  return sum / float(samples);
}

/// Unpolarised Fresnel reflectance of a dielectric of index eta at cos θ (written out here so
/// that the test does not share the BSDF's).
double fresnel(double cosTheta, double eta) {
  const double sinT2 = (1 - cosTheta * cosTheta) / (eta * eta);
  const double cosT = std::sqrt(1 - sinT2);
  const double s = (cosTheta - eta * cosT) / (cosTheta + eta * cosT);
  const double p = (eta * cosTheta - cosT) / (eta * cosTheta + cosT);
  return 0.5 * (s * s + p * p);
}

struct Case {
  HairConfig config;
  float thetaO, h;
};

const std::vector<Case> kFurnaceCases = {
    {{0.3f, 0.3f, 2, 1.55f}, 0, 0},       {{0.3f, 0.3f, 2, 1.55f}, 30, 0.5f},
    {{0.1f, 0.2f, 3, 1.55f}, -40, -0.7f}, {{0.6f, 0.8f, 0, 1.55f}, 60, 0.9f},
    {{0.2f, 0.5f, 8, 1.3f}, 15, -0.2f},   {{1.0f, 1.0f, 2, 1.55f}, -75, 0.3f},
    {{0.05f, 0.1f, 2, 1.55f}, 20, 0.4f},
};

}  // namespace

TEST(HairFurnace, LosslessFibreScattersEverythingByUniformSampling) {
  for (const Case& c : kFurnaceCases) {
    const HairBsdf bsdf = makeHair(hair(c.config));
    const Vec3f wo = directionWithOffset(c.thetaO, c.h);
    const double albedo = integrateUniformly(bsdf, wo);
    EXPECT_NEAR(albedo, 1.0, 0.003) << "βm " << c.config.betaM << " βn " << c.config.betaN << " α "
                                    << c.config.alphaDegrees << " θo " << c.thetaO << " h " << c.h;
  }
}

TEST(HairFurnace, LosslessFibreScattersEverythingByImportanceSampling) {
  for (const Case& c : kFurnaceCases) {
    const HairBsdf bsdf = makeHair(hair(c.config));
    const Vec3f albedo = integrateByImportance(bsdf, directionWithOffset(c.thetaO, c.h));
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(albedo[k], 1.0, 0.003) << "βm " << c.config.betaM << " θo " << c.thetaO;
  }
}

TEST(HairFurnace, BothEstimatesAgreeForAnAbsorbingTintedFibre) {
  HairConfig config;
  config.absorption = Vec3f(0.2f, 0.6f, 1.5f);
  MaterialParams m = hair(config);
  m.hairTintTT = Vec3f(0.9f, 0.5f, 0.7f);
  const HairBsdf bsdf = makeHair(m);
  for (float thetaO : {-30.0f, 10.0f, 50.0f}) {
    const Vec3f wo = directionWithOffset(thetaO, 0.35f);
    const double uniform = integrateUniformly(bsdf, wo);
    const double importance = mean(integrateByImportance(bsdf, wo));
    EXPECT_LT(uniform, 0.9);  // the absorption and tint remove light
    EXPECT_NEAR(importance, uniform, 0.005 * uniform) << "θo " << thetaO;
  }
}

TEST(HairFurnace, SurfacesWithoutAFibreDirectionConserveEnergyToo) {
  const HairBsdf bsdf(hair({}), Vec3f(0.0f), kNormal, kNormal);
  for (float cosTheta : {0.9f, 0.4f, -0.6f}) {
    const Vec3f wo =
        normalize(kNormal * cosTheta + sideways() * std::sqrt(1 - cosTheta * cosTheta));
    EXPECT_NEAR(integrateUniformly(bsdf, wo), 1.0, 0.003);
  }
}

TEST(HairSampling, PdfIntegratesToOne) {
  for (const Case& c : kFurnaceCases) {
    HairConfig config = c.config;
    config.absorption = Vec3f(0.5f, 1.0f, 2.0f);  // lobe probabilities away from the albedos
    const HairBsdf bsdf = makeHair(hair(config));
    EXPECT_NEAR(integrateUniformly(bsdf, directionWithOffset(c.thetaO, c.h), true), 1.0, 0.003)
        << "βm " << config.betaM << " θo " << c.thetaO;
  }
}

TEST(HairSampling, SamplesWeighEvaluateOverPdf) {
  HairConfig config;
  config.absorption = Vec3f(0.3f, 0.8f, 2.0f);
  MaterialParams m = hair(config);
  m.hairTintR = Vec3f(0.5f, 0.6f, 0.7f);
  const HairBsdf bsdf = makeHair(m);
  const Vec3f wo = directionWithOffset(25, -0.4f);
  int checked = 0;
  for (uint32_t i = 0; i < 2000; ++i) {
    SampleStream stream(3, 4, 5, i);
    const float uLobe = stream.next1D();
    const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
    ASSERT_TRUE(s.has_value());
    EXPECT_NEAR(length(s->direction), 1.0f, 1e-5f);
    EXPECT_FALSE(s->isDelta);
    const float pdf = bsdf.pdf(wo, s->direction);
    EXPECT_NEAR(s->pdf, pdf, 1e-3f * pdf);
    const Vec3f expected = bsdf.evaluate(wo, s->direction) / pdf;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s->weight[k], expected[k], 1e-3f * expected[k] + 1e-6f);
    EXPECT_EQ(s->transmitted, dot(s->direction, kNormal) * dot(wo, kNormal) < 0);
    ++checked;
  }
  EXPECT_EQ(checked, 2000);
}

TEST(HairSampling, TransmissionIsTheTTLobe) {
  MaterialParams m = hair({});
  m.hairTintR = m.hairTintTRT = Vec3f(0.0f);  // TT alone
  const HairBsdf bsdf = makeHair(m);
  const Vec3f wo = directionWithOffset(10, 0.1f);
  int through = 0;
  for (uint32_t i = 0; i < 500; ++i) {
    SampleStream stream(9, 0, 0, i);
    const float uLobe = stream.next1D();
    const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
    ASSERT_TRUE(s.has_value());
    EXPECT_EQ(s->lobe, BsdfLobe::Transmission);
    through += s->transmitted;
  }
  // TT leaves on the far side of the fibre (Φ ≈ π ± the logistic's spread).
  EXPECT_GT(through, 450);

  MaterialParams reflectionOnly = hair({});
  reflectionOnly.hairTintTT = Vec3f(0.0f);
  const HairBsdf glossy = makeHair(reflectionOnly);
  for (uint32_t i = 0; i < 200; ++i) {
    SampleStream stream(9, 1, 0, i);
    const float uLobe = stream.next1D();
    const std::optional<BsdfSample> s = glossy.sample(wo, uLobe, stream.next2D());
    ASSERT_TRUE(s.has_value());
    EXPECT_EQ(s->lobe, BsdfLobe::Glossy);
  }
  Vec3f diffusePart{1.0f};
  glossy.evaluate(wo, directionWithOffset(-10, 0.1f), &diffusePart);
  EXPECT_TRUE(isBlack(diffusePart));
  EXPECT_FALSE(glossy.isPurelySpecular());
  EXPECT_TRUE(glossy.hasTransmission());
}

TEST(HairReciprocity, LongitudinalLobeIsSymmetric) {
  for (float v : {0.005f, 0.05f, 0.3f}) {
    const float a = 0.4f, b = -0.9f;
    EXPECT_NEAR(hairLongitudinalScattering(std::sin(a), std::cos(a), std::sin(b), std::cos(b), v),
                hairLongitudinalScattering(std::sin(b), std::cos(b), std::sin(a), std::cos(a), v),
                1e-5f);
  }
}

TEST(HairReciprocity, IndexOneWithoutTiltOrAbsorptionIsReciprocal) {
  HairConfig config;
  config.ior = 1;
  config.alphaDegrees = 0;
  const HairBsdf bsdf = makeHair(hair(config));
  for (uint32_t i = 0; i < 200; ++i) {
    SampleStream stream(11, 0, 0, i);
    const Vec2f a = stream.next2D(), b = stream.next2D();
    const Vec3f wo = directionAt(2 * a.x - 1, 2 * kPi * a.y);
    const Vec3f wi = directionAt(2 * b.x - 1, 2 * kPi * b.y);
    const float forward = bsdf.evaluate(wo, wi).x, backward = bsdf.evaluate(wi, wo).x;
    EXPECT_NEAR(forward, backward, 1e-4f * std::max(forward, 1.0f));
  }
}

TEST(HairReciprocity, SurfaceReflectionIsReciprocalAboutTheMirrorDirection) {
  HairConfig config;
  config.alphaDegrees = 0;
  MaterialParams m = hair(config);
  m.hairTintTT = m.hairTintTRT = Vec3f(0.0f);  // R alone
  const HairBsdf bsdf = makeHair(m);
  for (float thetaO : {-50.0f, 5.0f, 35.0f})
    for (float h : {-0.6f, 0.2f, 0.8f}) {
      const Vec3f wo = directionWithOffset(thetaO, h);
      // Its mirror image about the normal of the point it meets: θ → −θ, h → −h.
      const Vec3f wi = directionWithOffset(-thetaO, -h);
      EXPECT_NEAR(bsdf.evaluate(wo, wi).x, bsdf.evaluate(wi, wo).x,
                  1e-4f * bsdf.evaluate(wo, wi).x);
      EXPECT_GT(bsdf.evaluate(wo, wi).x, 0.0f);
    }
}

TEST(HairAbsorption, StronglyAbsorbingFibreReflectsOnlyAtItsSurface) {
  for (const Case& c : kFurnaceCases) {
    HairConfig config = c.config;
    config.absorption = Vec3f(60.0f);
    const HairBsdf bsdf = makeHair(hair(config));
    const Vec3f wo = directionWithOffset(c.thetaO, c.h);
    // Only the R lobe is left: its albedo is Fresnel's at cos θo cos γo.
    const double theta = c.thetaO * kPi / 180;
    const double r = fresnel(std::cos(theta) * std::sqrt(1 - double(c.h) * c.h), config.ior);
    const double albedo = integrateUniformly(bsdf, wo);
    EXPECT_LE(albedo, r * 1.01 + 1e-4) << "θo " << c.thetaO << " h " << c.h;
    EXPECT_GE(albedo, r * 0.98) << "θo " << c.thetaO << " h " << c.h;
  }
}

TEST(HairAbsorption, AbsorptionFromColourFollowsChiangsFormula) {
  // β_n = 0: the denominator is 5.969; β_n = 1: 5.969 − 0.215 + 2.532 − 10.73 + 5.574 + 0.245.
  const Vec3f fromColour =
      hairAbsorptionFromColor(Vec3f(std::exp(-1.0f), std::exp(-2.0f), 1.0f), 0.0f);
  EXPECT_NEAR(fromColour.x, std::pow(1 / 5.969, 2), 1e-6);
  EXPECT_NEAR(fromColour.y, std::pow(2 / 5.969, 2), 1e-6);
  EXPECT_EQ(fromColour.z, 0.0f);
  const Vec3f rough = hairAbsorptionFromColor(Vec3f(std::exp(-2.0f)), 1.0f);
  EXPECT_NEAR(rough.x, std::pow(2 / 3.375, 2), 1e-5);
  const Vec3f colour(0.6f, 0.3f, 0.05f);
  const Vec3f back = hairColorFromAbsorption(hairAbsorptionFromColor(colour, 0.4f), 0.4f);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], colour[k], 1e-5f);
  // Black is clamped to 0.001 (MaterialX).
  EXPECT_NEAR(hairAbsorptionFromColor(Vec3f(0.0f), 0.0f).x, std::pow(std::log(0.001) / 5.969, 2),
              1e-4);
}

TEST(HairAbsorption, AbsorptionFromMelaninFollowsDEonsFormula) {
  // Concentration 1 − 1/e is one unit of melanin: the pigments' own absorption.
  const float oneUnit = 1 - std::exp(-1.0f);
  const Vec3f eumelanin = hairAbsorptionFromMelanin(oneUnit, 0);
  EXPECT_NEAR(eumelanin.x, 0.419f, 1e-4f);
  EXPECT_NEAR(eumelanin.y, 0.697f, 1e-4f);
  EXPECT_NEAR(eumelanin.z, 1.37f, 1e-4f);
  const Vec3f pheomelanin = hairAbsorptionFromMelanin(oneUnit, 1);
  EXPECT_NEAR(pheomelanin.x, 0.187f, 1e-4f);
  EXPECT_NEAR(pheomelanin.y, 0.4f, 1e-4f);
  EXPECT_NEAR(pheomelanin.z, 1.05f, 1e-4f);
  // Two units, half red: one of each.
  const Vec3f mixed = hairAbsorptionFromMelanin(1 - std::exp(-2.0f), 0.5f);
  EXPECT_NEAR(mixed.x, 0.419f + 0.187f, 2e-4f);
  EXPECT_NEAR(mixed.z, 1.37f + 1.05f, 2e-4f);
  EXPECT_TRUE(isBlack(hairAbsorptionFromMelanin(0, 0.3f)));
}

namespace {

/// A hair material whose `input` reads the uniform primvar `primvar`.
Material hairReading(std::vector<std::pair<MaterialInput, std::string>> readers) {
  Material material;
  material.constants.hair = true;
  for (const auto& [input, primvar] : readers) {
    InputConnection connection;
    connection.input = input;
    connection.primvar = PrimvarName(primvar);
    connection.channelCount = isVectorInput(input) ? 3 : 1;
    material.connections.push_back(connection);
  }
  return material;
}

/// The parameters of `material` on each of the two triangles of a square whose uniform
/// primvars are `primvars`.
std::array<MaterialParams, 2> onBothTriangles(const Material& material,
                                              std::vector<Primvar> primvars) {
  MeshData data;
  data.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  data.faceVertexCounts = {3, 3};
  data.faceVertexIndices = {0, 1, 2, 0, 2, 3};
  TriangleMesh mesh = triangulate(data);
  mesh.primvars = std::move(primvars);
  const MeshShape shape(mesh);
  const TextureSystem textures;
  std::array<MaterialParams, 2> params;
  for (uint32_t triangle = 0; triangle < 2; ++triangle) {
    SurfacePoint point = shape.pointAt(triangle, 0.3f, 0.3f, 0);
    point.normal = point.shadingNormal = {0, 0, 1};
    Vec3f shadingNormal = point.shadingNormal;
    params[triangle] = evaluateMaterial(material, textures, point, &shadingNormal);
  }
  return params;
}

void expectNear(const Vec3f& a, const Vec3f& b) {
  EXPECT_NEAR(a.x, b.x, 1e-6f * std::max(1.0f, std::abs(b.x)));
  EXPECT_NEAR(a.y, b.y, 1e-6f * std::max(1.0f, std::abs(b.y)));
  EXPECT_NEAR(a.z, b.z, 1e-6f * std::max(1.0f, std::abs(b.z)));
}

}  // namespace

TEST(HairAbsorption, AbsorptionAtAHitIsAsGivenByDefault) {
  MaterialParams m;
  m.hairAbsorption = Vec3f(0.5f, 1.0f, 2.0f);
  m.hairColor = Vec3f(0.2f);
  m.hairMelanin = 0.9f;
  expectNear(hairAbsorptionAt(m), m.hairAbsorption);
}

TEST(HairAbsorption, AbsorptionAtAHitDerivesFromEachPointsColour) {
  Material material = hairReading({{MaterialInput::HairColor, "strandColor"}});
  material.constants.hairAbsorptionFromColor = true;
  material.constants.hairAzimuthalRoughness = 0.45f;
  const Vec3f redBrown(0.35f, 0.12f, 0.05f), blond(0.85f, 0.65f, 0.4f);
  const auto params =
      onBothTriangles(material, {{"strandColor",
                                  {redBrown.x, redBrown.y, redBrown.z, blond.x, blond.y, blond.z},
                                  3,
                                  Interpolation::Uniform}});
  expectNear(hairAbsorptionAt(params[0]), hairAbsorptionFromColor(redBrown, 0.45f));
  expectNear(hairAbsorptionAt(params[1]), hairAbsorptionFromColor(blond, 0.45f));
  // The albedo AOV's colour is the strand's own.
  expectNear(hairColorAt(params[1]), blond);
  // The node's own β_n, where given, converts the colour instead.
  MaterialParams own = params[0];
  own.hairColorAzimuthalRoughness = 0.2f;
  expectNear(hairAbsorptionAt(own), hairAbsorptionFromColor(redBrown, 0.2f));
  expectNear(hairColorAt(own), redBrown);
}

TEST(HairAbsorption, AbsorptionAtAHitDerivesFromEachPointsMelanin) {
  Material material = hairReading(
      {{MaterialInput::HairMelanin, "melanin"}, {MaterialInput::HairMelaninRedness, "redness"}});
  material.constants.hairAbsorptionFromMelanin = true;
  const auto params =
      onBothTriangles(material, {{"melanin", {0.8f, 0.2f}, 1, Interpolation::Uniform},
                                 {"redness", {0.1f, 0.7f}, 1, Interpolation::Uniform}});
  expectNear(hairAbsorptionAt(params[0]), hairAbsorptionFromMelanin(0.8f, 0.1f));
  expectNear(hairAbsorptionAt(params[1]), hairAbsorptionFromMelanin(0.2f, 0.7f));
  expectNear(hairColorAt(params[0]),
             hairColorFromAbsorption(hairAbsorptionFromMelanin(0.8f, 0.1f), 0.3f));
}

TEST(HairRoughness, MappingsFollowThePaper) {
  EXPECT_NEAR(hairLongitudinalVariance(0.3f),
              std::pow(0.726 * 0.3 + 0.812 * 0.09 + 3.7 * std::pow(0.3, 20), 2), 1e-6);
  EXPECT_NEAR(hairLongitudinalVariance(1.0f), std::pow(0.726 + 0.812 + 3.7, 2), 1e-3);
  EXPECT_NEAR(hairAzimuthalScale(1.0f), std::sqrt(kPi / 8) * (0.265 + 1.194 + 5.372), 1e-4);
}

TEST(HairLobes, ReflectionPeaksAtTheMirrorAngleTurnedByTwiceTheCuticleTilt) {
  for (float alpha : {0.0f, 3.0f, 8.0f}) {
    HairConfig config;
    config.betaM = 0.1f;
    config.alphaDegrees = alpha;
    MaterialParams m = hair(config);
    m.hairTintTT = m.hairTintTRT = Vec3f(0.0f);  // R alone
    const HairBsdf bsdf = makeHair(m);
    const float thetaO = 30;
    const Vec3f wo = directionWithOffset(thetaO, 0);
    // h = 0: R leaves in wo's azimuthal plane, towards the normal.
    float best = 0, bestTheta = 0;
    for (int i = -900; i <= 900; ++i) {
      const float theta = float(i) * 0.1f;
      const float f = bsdf.evaluate(wo, directionWithOffset(theta, 0)).x;
      if (f > best) {
        best = f;
        bestTheta = theta;
      }
    }
    EXPECT_NEAR(bestTheta, -thetaO + 2 * alpha, 0.5f) << "α " << alpha;
  }
}

TEST(HairLobes, ReflectionLeavesTowardsTheMirrorImageAboutTheCylindersNormal) {
  // A round fibre met at offset h has, there, the normal at angle γ = asin h from wo's azimuth:
  // R's azimuthal peak is wo mirrored about it, which is the direction of offset −h.
  HairConfig config;
  config.betaM = 0.2f;
  config.betaN = 0.1f;
  config.alphaDegrees = 0;
  MaterialParams m = hair(config);
  m.hairTintTT = m.hairTintTRT = Vec3f(0.0f);  // R alone
  const HairBsdf bsdf = makeHair(m);
  for (float h : {-0.7f, -0.3f, 0.4f, 0.8f}) {
    const Vec3f wo = directionWithOffset(20, h);
    float best = 0, bestOffset = 0;
    // Directions at −θo across the offsets h' (their azimuth ranges over the half facing the
    // normal).
    for (int i = -999; i <= 999; ++i) {
      const float offset = float(i) / 1000;
      const float f = bsdf.evaluate(wo, directionWithOffset(-20, offset)).x;
      if (f > best) {
        best = f;
        bestOffset = offset;
      }
    }
    EXPECT_NEAR(bestOffset, -h, 0.01f) << "h " << h;
  }
}
