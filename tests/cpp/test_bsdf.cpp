#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "penumbra/bsdf.h"
#include "penumbra/sampler.h"

using namespace penumbra;

namespace {

// A normal off the axes, so that the local frame is exercised.
const Vec3f kNormal = normalize(Vec3f(0.3f, -0.5f, 0.8f));

/// A direction at cos θ = cosTheta from `normal` (negative: behind it), at azimuth `phi`.
Vec3f directionAt(float cosTheta, float phi = 0.7f, const Vec3f& normal = kNormal) {
  const float sinTheta = std::sqrt(std::max(0.0f, 1 - cosTheta * cosTheta));
  return normalize(
      Frame(normal).toWorld({sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta}));
}

MaterialParams whiteMetal(float roughness) {
  MaterialParams m;
  m.diffuseColor = Vec3f(1.0f);
  m.metallic = 1;
  m.roughness = roughness;
  return m;
}

MaterialParams glass(float roughness) {
  MaterialParams m;
  m.opacity = 0;
  m.ior = 1.5f;
  m.roughness = roughness;
  return m;
}

/// A sheen over a white diffuse base (under the default specular layer).
MaterialParams sheenOverWhiteDiffuse(float sheenRoughness, const Vec3f& sheenColor = Vec3f(1.0f)) {
  MaterialParams m;
  m.diffuseColor = Vec3f(1.0f);
  m.sheen = 1;
  m.sheenColor = sheenColor;
  m.sheenRoughness = sheenRoughness;
  return m;
}

/// The sheen lobe alone among the non-delta lobes: the base is a black mirror (F0 = 0, a delta
/// lobe that evaluate() and pdf() leave out) over a black diffuse layer.
MaterialParams sheenAlone(float sheenRoughness) {
  MaterialParams m;
  m.diffuseColor = Vec3f(0.0f);
  m.useSpecularWorkflow = true;
  m.specularColor = Vec3f(0.0f);
  m.roughness = 0;
  m.sheen = 1;
  m.sheenRoughness = sheenRoughness;
  return m;
}

/// A white metal whose lobe is stretched along the tangent.
MaterialParams anisotropicWhiteMetal(float roughness, float anisotropy,
                                     AnisotropyModel model = AnisotropyModel::OpenPbr) {
  MaterialParams m = whiteMetal(roughness);
  m.anisotropy = anisotropy;
  m.anisotropyModel = model;
  return m;
}

/// A tangent off the normal's fixed frame (not orthogonal to kNormal: the BSDF projects it).
const Vec3f kTangent = normalize(Vec3f(1.0f, 0.4f, 0.2f));

/// Every layer of the opaque part (metal, coat, sheen) over a translucent share.
MaterialParams layeredMaterial() {
  MaterialParams m;
  m.diffuseColor = Vec3f(0.7f, 0.5f, 0.2f);
  m.metallic = 0.5f;
  m.roughness = 0.35f;
  m.clearcoat = 0.5f;
  m.clearcoatRoughness = 0.2f;
  m.opacity = 0.7f;
  m.sheen = 0.6f;
  return m;
}

/// Every component equal (what the bit-for-bit tests compare).
bool sameValue(const Vec3f& a, const Vec3f& b) {
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

PreviewSurfaceBsdf makeBsdf(const MaterialParams& m, DielectricKind kind = DielectricKind::Solid) {
  return PreviewSurfaceBsdf(m, kNormal, m.ior, kind, kTangent);
}

struct Albedo {
  double radiance = 0;  // E[weight]: what a white furnace shows (mean of the RGB channels)
  double flux = 0;      // E[weight · (n_i / n_o)²]: the fraction of the incident energy scattered
};

/// White furnace by the BSDF's own sampling: the directional albedo for light leaving along wo.
/// Radiance through a solid interface is scaled by (n_o/n_i)², so only the flux albedo — the
/// radiance weight times (n_i/n_o)², i.e. the energy leaving wo's point over the energy arriving
/// — must be 1 for a lossless dielectric.
Albedo furnace(const PreviewSurfaceBsdf& bsdf, const Vec3f& wo, float ior = 1,
               uint32_t samples = 1u << 16) {
  double radiance = 0, flux = 0;
  for (uint32_t i = 0; i < samples; ++i) {
    SampleStream stream(1, 2, 3, i);
    const float uLobe = stream.next1D();
    const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
    if (!s) continue;
    const double w = (s->weight.x + s->weight.y + s->weight.z) / 3.0;
    const double woSide = dot(wo, kNormal) > 0 ? 1.0 : ior;
    const double wiSide = dot(s->direction, kNormal) > 0 ? 1.0 : ior;
    radiance += w;
    flux += w * (wiSide / woSide) * (wiSide / woSide);
  }
  return {radiance / samples, flux / samples};
}

/// ∫ evaluate(wo, wi) dwi over the sphere, by a stratified grid in (cos θ, φ) around the normal —
/// independent of the BSDF's sampling.
double integrateEvaluate(const PreviewSurfaceBsdf& bsdf, const Vec3f& wo, int n = 768) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const Vec3f wi = directionAt(-1 + 2 * (float(i) + 0.5f) / float(n),
                                   2 * kPi * (float(j) + 0.5f) / float(n));
      const Vec3f f = bsdf.evaluate(wo, wi);
      sum += (f.x + f.y + f.z) / 3.0;
    }
  }
  return sum * 4 * kPi / (double(n) * n);
}

/// ∫ pdf(wo, wi) dwi over the sphere, on the same grid.
double integratePdf(const PreviewSurfaceBsdf& bsdf, const Vec3f& wo, int n = 512) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      sum += bsdf.pdf(wo, directionAt(-1 + 2 * (float(i) + 0.5f) / float(n),
                                      2 * kPi * (float(j) + 0.5f) / float(n)));
    }
  }
  return sum * 4 * kPi / (double(n) * n);
}

float angleBetween(const Vec3f& a, const Vec3f& b) {
  return std::acos(std::min(1.0f, std::max(-1.0f, dot(a, b))));
}

}  // namespace

TEST(BsdfFurnace, WhiteLambertianUnderASpecularLayerReflectsEverything) {
  for (float roughness : {0.0f, 0.5f, 1.0f}) {
    MaterialParams m;
    m.diffuseColor = Vec3f(1.0f);
    m.roughness = roughness;
    const PreviewSurfaceBsdf bsdf = makeBsdf(m);
    for (float cosTheta : {0.05f, 0.3f, 0.7f, 1.0f}) {
      const Albedo a = furnace(bsdf, directionAt(cosTheta));
      EXPECT_NEAR(a.radiance, 1.0, 0.01) << "roughness " << roughness << " cos " << cosTheta;
    }
  }
  // Seen from the back, the opaque part is the same (two-sided).
  MaterialParams m;
  m.diffuseColor = Vec3f(1.0f);
  EXPECT_NEAR(furnace(makeBsdf(m), directionAt(-0.6f)).radiance, 1.0, 0.01);
}

TEST(BsdfFurnace, WhiteLambertianUnderAClearcoatReflectsEverything) {
  // What the coat reflects, the layers under it do not get; what it lets through comes back
  // out: a white base under any coat is white. (The coat's transmittance for the incoming and
  // the outgoing direction lost the light the coat sends back down between them: 2.6–8 %.) What
  // is left is the specular layer's share under the coat, which keeps both transmittances:
  // 1.1–2.4 % towards grazing angles, under 1 % from cos θ = 0.7.
  for (float coatRoughness : {0.0f, 0.3f, 1.0f}) {
    MaterialParams m;
    m.diffuseColor = Vec3f(1.0f);
    m.clearcoat = 1;
    m.clearcoatRoughness = coatRoughness;
    const PreviewSurfaceBsdf bsdf = makeBsdf(m);
    for (float cosTheta : {0.05f, 0.3f, 0.7f, 1.0f}) {
      const Albedo a = furnace(bsdf, directionAt(cosTheta));
      EXPECT_NEAR(a.radiance, 1.0, cosTheta < 0.5f ? 0.025 : 0.01)
          << "coat roughness " << coatRoughness << " cos " << cosTheta;
    }
  }
}

TEST(BsdfFurnace, SmoothWhiteMetalIsAPerfectMirror) {
  const PreviewSurfaceBsdf bsdf = makeBsdf(whiteMetal(0));
  EXPECT_TRUE(bsdf.isPurelySpecular());
  for (float cosTheta : {0.1f, 0.5f, 1.0f}) {
    const Vec3f wo = directionAt(cosTheta);
    EXPECT_NEAR(furnace(bsdf, wo, 1, 256).radiance, 1.0, 0.01);
    const std::optional<BsdfSample> s = bsdf.sample(wo, 0.5f, {0.3f, 0.6f});
    ASSERT_TRUE(s);
    EXPECT_TRUE(s->isDelta);
    EXPECT_EQ(s->lobe, BsdfLobe::Specular);
    EXPECT_NEAR(dot(s->direction, kNormal), cosTheta, 1e-5f);
    EXPECT_NEAR(dot(s->direction, wo), 2 * cosTheta * cosTheta - 1, 1e-5f);
  }
}

// Without multiple-scattering compensation, roughness 1 at grazing angles keeps only ~60 %.
TEST(BsdfFurnace, RoughWhiteMetalLosesAtMostThreePercent) {
  for (float roughness : {0.25f, 0.5f, 0.75f, 1.0f}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(whiteMetal(roughness));
    for (float cosTheta : {0.1f, 0.3f, 0.6f, 1.0f}) {
      const Vec3f wo = directionAt(cosTheta);
      const double sampled = furnace(bsdf, wo).radiance;
      EXPECT_GE(sampled, 0.97) << "roughness " << roughness << " cos " << cosTheta;
      EXPECT_LE(sampled, 1.01) << "roughness " << roughness << " cos " << cosTheta;
      // The same integral of evaluate(), independent of the sampling (the grid resolves the
      // wider lobes only).
      if (roughness >= 0.5f) {
        EXPECT_NEAR(integrateEvaluate(bsdf, wo, 384), sampled, 0.01)
            << "roughness " << roughness << " cos " << cosTheta;
      }
    }
  }
}

TEST(BsdfFurnace, GlassScattersAllEnergyFromBothSides) {
  const float ior = 1.5f;
  for (float roughness : {0.0f, 0.3f, 0.5f}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(glass(roughness));
    EXPECT_TRUE(bsdf.hasTransmission());
    EXPECT_EQ(bsdf.isPurelySpecular(), roughness == 0);
    // From inside, beyond the critical angle (cos θc ≈ 0.745) everything is reflected.
    for (float cosTheta : {0.1f, 0.4f, 0.8f, 1.0f, -0.1f, -0.4f, -0.8f, -1.0f}) {
      const Albedo a = furnace(bsdf, directionAt(cosTheta), ior);
      EXPECT_NEAR(a.flux, 1.0, 0.02) << "roughness " << roughness << " cos " << cosTheta;
    }
  }
  // At normal incidence from outside, 4 % is reflected and the transmitted 96 % of the energy
  // carries radiance scaled by 1/η².
  const Albedo normal = furnace(makeBsdf(glass(0)), directionAt(1.0f), ior, 4096);
  EXPECT_NEAR(normal.radiance, 0.04 + 0.96 / (ior * ior), 0.005);
}

TEST(BsdfFurnace, ThinSheetTransmitsStraightThroughWithoutLoss) {
  for (float roughness : {0.0f, 0.4f}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(glass(roughness), DielectricKind::ThinSheet);
    for (float cosTheta : {0.2f, 0.9f, -0.5f}) {
      // No radiance scaling through a sheet: the radiance albedo is the flux albedo.
      const Albedo a = furnace(bsdf, directionAt(cosTheta));
      EXPECT_NEAR(a.radiance, 1.0, 0.02) << "roughness " << roughness << " cos " << cosTheta;
    }
  }
  const Vec3f wo = directionAt(0.6f);
  const std::optional<BsdfSample> s =
      makeBsdf(glass(0), DielectricKind::ThinSheet).sample(wo, 0.99f, {0.5f, 0.5f});
  ASSERT_TRUE(s);
  EXPECT_TRUE(s->transmitted);
  EXPECT_NEAR(dot(s->direction, wo), -1.0f, 1e-5f);
}

TEST(BsdfPdf, IntegratesToTheFractionOfNonDeltaSamples) {
  MaterialParams coated;
  coated.diffuseColor = Vec3f(0.6f, 0.3f, 0.1f);
  coated.metallic = 0.3f;
  coated.roughness = 0.4f;
  coated.clearcoat = 1;
  coated.clearcoatRoughness = 0.3f;
  MaterialParams translucent = coated;
  translucent.opacity = 0.4f;
  translucent.transmissionRoughness = 0.5f;
  MaterialParams sheened = coated;
  sheened.sheen = 0.8f;
  sheened.sheenColor = Vec3f(0.9f, 0.5f, 0.7f);
  sheened.sheenRoughness = 0.4f;
  MaterialParams anisotropicCoat = coated;
  anisotropicCoat.anisotropy = 0.7f;
  anisotropicCoat.clearcoatAnisotropy = 0.5f;
  anisotropicCoat.anisotropyRotation = 0.1f;
  for (const MaterialParams& m :
       {whiteMetal(0.6f), glass(0.5f), coated, translucent, sheened, sheenAlone(0.3f),
        anisotropicWhiteMetal(0.5f, 0.8f),
        anisotropicWhiteMetal(0.6f, 0.6f, AnisotropyModel::StandardSurface), anisotropicCoat}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(m);
    for (float cosTheta : {0.3f, 0.9f, -0.6f}) {
      const Vec3f wo = directionAt(cosTheta);
      const uint32_t n = 1u << 15;
      uint32_t nonDelta = 0;
      for (uint32_t i = 0; i < n; ++i) {
        SampleStream stream(4, 5, 6, i);
        const float uLobe = stream.next1D();
        const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
        if (s && !s->isDelta) ++nonDelta;
      }
      EXPECT_NEAR(integratePdf(bsdf, wo), double(nonDelta) / n, 0.01) << "cos " << cosTheta;
    }
  }
}

// The directions sample() produces are distributed as pdf() says: a histogram over
// (cos θ, φ) around the normal, equal-solid-angle cells, against pdf() integrated over each cell.
TEST(BsdfPdf, MatchesTheHistogramOfSampledDirections) {
  MaterialParams coated;
  coated.diffuseColor = Vec3f(0.5f);
  coated.roughness = 0.3f;
  coated.clearcoat = 1;
  coated.clearcoatRoughness = 0.2f;
  MaterialParams translucent = glass(0.4f);
  translucent.opacity = 0.5f;
  translucent.diffuseColor = Vec3f(0.8f);
  constexpr int kRows = 24, kColumns = 48, kSub = 6;
  const std::pair<MaterialParams, DielectricKind> cases[] = {
      {whiteMetal(0.5f), DielectricKind::Solid},
      {glass(0.4f), DielectricKind::Solid},
      {glass(0.4f), DielectricKind::ThinSheet},
      {coated, DielectricKind::Solid},
      {translucent, DielectricKind::Solid},
      {sheenOverWhiteDiffuse(0.3f, Vec3f(0.8f, 0.6f, 0.4f)), DielectricKind::Solid},
      {sheenAlone(0.5f), DielectricKind::Solid},
      {anisotropicWhiteMetal(0.5f, 0.9f), DielectricKind::Solid},
      {anisotropicWhiteMetal(0.4f, 0.7f, AnisotropyModel::StandardSurface), DielectricKind::Solid}};
  for (const auto& [m, kind] : cases) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(m, kind);
    for (float cosTheta : {0.5f, -0.9f}) {
      const Vec3f wo = directionAt(cosTheta);
      const Frame frame(kNormal);
      std::vector<double> observed(kRows * kColumns, 0.0), expected(kRows * kColumns, 0.0);
      const uint32_t n = 1u << 17;
      for (uint32_t i = 0; i < n; ++i) {
        SampleStream stream(7, 8, 9, i);
        const float uLobe = stream.next1D();
        const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
        if (!s || s->isDelta) continue;
        const Vec3f local = frame.toLocal(s->direction);
        const int row = std::min(kRows - 1, int((local.z + 1) / 2 * kRows));
        float phi = std::atan2(local.y, local.x);
        if (phi < 0) phi += 2 * kPi;
        const int column = std::min(kColumns - 1, int(phi / (2 * kPi) * kColumns));
        observed[row * kColumns + column] += 1;
      }
      const double cellSolidAngle = 4 * kPi / (kRows * kColumns);
      for (int row = 0; row < kRows; ++row) {
        for (int column = 0; column < kColumns; ++column) {
          double sum = 0;
          for (int a = 0; a < kSub; ++a) {
            for (int b = 0; b < kSub; ++b) {
              const float z = -1 + 2 * (row + (a + 0.5f) / kSub) / kRows;
              const float phi = 2 * kPi * (column + (b + 0.5f) / kSub) / kColumns;
              sum += bsdf.pdf(wo, directionAt(z, phi));
            }
          }
          expected[row * kColumns + column] = sum / (kSub * kSub) * cellSolidAngle * n;
        }
      }
      double chiSquare = 0;
      int cells = 0;
      for (int k = 0; k < kRows * kColumns; ++k) {
        if (expected[k] < 20) continue;
        chiSquare += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
        ++cells;
      }
      ASSERT_GT(cells, 50);
      // Low-discrepancy samples make the statistic far smaller than the χ² expectation (≈ cells);
      // allow 2× for the quadrature error of the expected counts in peaked cells.
      EXPECT_LT(chiSquare / cells, 2.0) << "cos " << cosTheta << " cells " << cells;
    }
  }
}

TEST(BsdfSample, WeightIsEvaluateOverPdf) {
  MaterialParams m = layeredMaterial();
  m.clearcoatRoughness = 0.1f;
  m.clearcoatColor = Vec3f(0.9f, 0.6f, 0.3f);
  m.sheenColor = Vec3f(0.3f, 0.9f, 0.6f);
  m.sheenRoughness = 0.5f;
  m.anisotropy = 0.6f;
  m.clearcoatAnisotropy = 0.3f;
  m.anisotropyRotation = 0.3f;
  const PreviewSurfaceBsdf bsdf = makeBsdf(m);
  int checked = 0;
  for (float cosTheta : {0.2f, 0.8f, -0.4f}) {
    const Vec3f wo = directionAt(cosTheta);
    for (uint32_t i = 0; i < 512; ++i) {
      SampleStream stream(2, 2, 2, i);
      const float uLobe = stream.next1D();
      const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
      if (!s || s->isDelta) continue;
      const float pdf = bsdf.pdf(wo, s->direction);
      const Vec3f f = bsdf.evaluate(wo, s->direction);
      ASSERT_GT(pdf, 0);
      EXPECT_NEAR(s->pdf, pdf, 1e-4f * pdf);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(s->weight[c], f[c] / pdf, 1e-4f * f[c] / pdf + 1e-7f);
      EXPECT_EQ(s->transmitted, dot(s->direction, kNormal) * dot(wo, kNormal) < 0);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

// The light tracer takes the light of a plastic's layers above its diffuse one
// (caustics.h): sampled alone, they must integrate to what the whole BSDF's samples give for
// evaluate() less its diffuse part. Rough and mirror-like specular layers, with a clearcoat.
TEST(BsdfSample, AboveDiffuseIntegratesTheLayersOverTheDiffuseOne) {
  MaterialParams m;
  m.diffuseColor = Vec3f(0.8f, 0.2f, 0.1f);
  m.clearcoat = 0.5f;
  m.clearcoatRoughness = 0.1f;
  for (float roughness : {0.3f, 0.0f}) {
    m.roughness = roughness;
    const PreviewSurfaceBsdf bsdf = makeBsdf(m);
    for (float cosTheta : {0.9f, 0.4f, -0.6f}) {
      const Vec3f wo = directionAt(cosTheta);
      constexpr uint32_t kSamples = 1 << 18;
      std::array<double, 3> above{}, reference{};
      for (uint32_t i = 0; i < kSamples; ++i) {
        SampleStream stream(3, 3, 3, i);
        const float uLobe = stream.next1D();
        const Vec2f u = stream.next2D();
        if (const std::optional<BsdfSample> s = bsdf.sampleAboveDiffuse(wo, uLobe, u)) {
          ASSERT_GT(s->pdf, 0);
          ASSERT_NE(s->lobe, BsdfLobe::Diffuse);
          ASSERT_FALSE(s->transmitted);
          if (!s->isDelta) {  // its weight is the part above the diffuse layer over its density
            Vec3f diffusePart;
            const Vec3f f = bsdf.evaluate(wo, s->direction, &diffusePart);
            for (int c = 0; c < 3; ++c)
              ASSERT_NEAR(s->weight[c] * s->pdf, f[c] - diffusePart[c], 1e-4f * f[c] + 1e-7f);
          }
          for (int c = 0; c < 3; ++c) above[size_t(c)] += s->weight[c];
        }
        if (const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, u)) {
          Vec3f diffusePart;
          const Vec3f f = s->isDelta ? Vec3f(0.0f) : bsdf.evaluate(wo, s->direction, &diffusePart);
          for (int c = 0; c < 3; ++c)
            reference[size_t(c)] += s->isDelta ? s->weight[c] : (f[c] - diffusePart[c]) / s->pdf;
        }
      }
      for (size_t c = 0; c < 3; ++c) {
        EXPECT_GT(reference[c], 0.02 * kSamples);  // what lies above: Fresnel's share at least
        EXPECT_NEAR(above[c] / reference[c], 1.0, 0.01)
            << "roughness " << roughness << ", cos θo " << cosTheta << ", channel " << c;
      }
    }
  }
}

// The integrator takes both from one call where it needs both: they must be the very same bits.
TEST(BsdfEvaluate, WithPdfIsEvaluateAndPdfBitForBit) {
  const MaterialParams layered = layeredMaterial();
  MaterialParams anisotropic = layered;
  anisotropic.anisotropy = 0.6f;
  anisotropic.clearcoatAnisotropy = 0.3f;
  MaterialParams plastic;
  plastic.diffuseColor = Vec3f(0.8f, 0.15f, 0.1f);
  plastic.roughness = 0.35f;
  int nonZero = 0;
  for (const MaterialParams& m : {layered, anisotropic, plastic, glass(0.3f), whiteMetal(0.5f)}) {
    for (const DielectricKind kind : {DielectricKind::Solid, DielectricKind::ThinSheet}) {
      const PreviewSurfaceBsdf bsdf = makeBsdf(m, kind);
      for (uint32_t i = 0; i < 512; ++i) {
        SampleStream stream(7, 7, 7, i);
        const Vec2f u = stream.next2D(), v = stream.next2D();
        const Vec3f wo = directionAt(2 * u.x - 1, 2 * kPi * u.y);
        const Vec3f wi = directionAt(2 * v.x - 1, 2 * kPi * v.y);
        Vec3f diffuse, diffuseTogether;
        const Vec3f f = bsdf.evaluate(wo, wi, &diffuse);
        const float pdf = bsdf.pdf(wo, wi);
        const BsdfEvaluation together = bsdf.evaluateWithPdf(wo, wi, &diffuseTogether);
        EXPECT_TRUE(sameValue(together.value, f));
        EXPECT_TRUE(sameValue(diffuseTogether, diffuse));
        EXPECT_EQ(together.pdf, pdf);
        nonZero += pdf > 0 && !isBlack(f);
      }
    }
  }
  EXPECT_GT(nonZero, 2000);  // most pairs scatter: the comparison saw real values
}

TEST(BsdfEvaluate, TurnedPrototypeIsTheBsdfOfItsMaterialBitForBit) {
  // What a non-varying material's BSDF set up once, facing +z, gives once turned to a hit's
  // normal: every evaluation and sample the same as a BSDF set up at that hit.
  MaterialParams layered = layeredMaterial();
  layered.subsurface = 0.4f;
  int scattered = 0;
  for (const MaterialParams& m : {layered, glass(0.3f), whiteMetal(0.5f), sheenAlone(0.4f)}) {
    for (const DielectricKind kind : {DielectricKind::Solid, DielectricKind::ThinSheet}) {
      const PreviewSurfaceBsdf prototype(m, Vec3f(0, 0, 1), m.ior, kind);
      ASSERT_TRUE(prototype.isotropic());
      const PreviewSurfaceBsdf turned(prototype, kNormal);
      const PreviewSurfaceBsdf direct(m, kNormal, m.ior, kind);
      EXPECT_EQ(turned.isPurelySpecular(), direct.isPurelySpecular());
      EXPECT_EQ(turned.hasTransmission(), direct.hasTransmission());
      for (uint32_t i = 0; i < 256; ++i) {
        SampleStream stream(5, 6, 7, i);
        const Vec2f u = stream.next2D(), v = stream.next2D(), w = stream.next2D();
        const Vec3f wo = directionAt(2 * u.x - 1, 2 * kPi * u.y);
        const Vec3f wi = directionAt(2 * v.x - 1, 2 * kPi * v.y);
        Vec3f diffuseTurned, diffuseDirect;
        const BsdfEvaluation a = turned.evaluateWithPdf(wo, wi, &diffuseTurned);
        const BsdfEvaluation b = direct.evaluateWithPdf(wo, wi, &diffuseDirect);
        EXPECT_TRUE(sameValue(a.value, b.value));
        EXPECT_TRUE(sameValue(diffuseTurned, diffuseDirect));
        EXPECT_EQ(a.pdf, b.pdf);
        const std::optional<BsdfSample> sa = turned.sample(wo, w.x, {w.y, u.x});
        const std::optional<BsdfSample> sb = direct.sample(wo, w.x, {w.y, u.x});
        ASSERT_EQ(sa.has_value(), sb.has_value());
        if (!sa) continue;
        EXPECT_TRUE(sameValue(sa->direction, sb->direction));
        EXPECT_TRUE(sameValue(sa->weight, sb->weight));
        EXPECT_EQ(sa->pdf, sb->pdf);
        EXPECT_EQ(sa->lobe, sb->lobe);
        scattered += !isBlack(sa->weight);
      }
    }
  }
  EXPECT_GT(scattered, 1000);  // the comparison saw real samples
  // The frame is the hit's, not the prototype's: facing +z, it would scatter differently.
  const PreviewSurfaceBsdf facingUp(whiteMetal(0.3f), Vec3f(0, 0, 1), 1.5f);
  const Vec3f wo = directionAt(0.9f), wi = directionAt(0.8f, 2.0f);
  EXPECT_FALSE(
      sameValue(PreviewSurfaceBsdf(facingUp, kNormal).evaluate(wo, wi), facingUp.evaluate(wo, wi)));
}

TEST(BsdfEvaluate, ReflectionIsReciprocal) {
  MaterialParams layered;
  layered.diffuseColor = Vec3f(0.9f, 0.4f, 0.2f);
  layered.metallic = 0.3f;
  layered.roughness = 0.45f;
  layered.clearcoat = 0.8f;
  layered.clearcoatRoughness = 0.25f;
  MaterialParams specularWorkflow = layered;
  specularWorkflow.useSpecularWorkflow = true;
  specularWorkflow.specularColor = Vec3f(0.3f, 0.5f, 0.9f);
  int checked = 0;
  // Rough glass is left out: its energy compensation divides by the albedo for wo; so are
  // layers under a sheen (same albedo scaling), but the sheen lobe itself is symmetric.
  MaterialParams anisotropic = layered;
  anisotropic.anisotropy = 0.8f;
  anisotropic.clearcoatAnisotropy = 0.4f;
  anisotropic.anisotropyRotation = 0.2f;
  for (const MaterialParams& m : {layered, specularWorkflow, sheenAlone(0.4f), anisotropic}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(m);
    for (uint32_t i = 0; i < 256; ++i) {
      SampleStream stream(9, 9, 9, i);
      const Vec2f a = stream.next2D(), b = stream.next2D();
      const Vec3f wo = directionAt(2 * a.x - 1, 2 * kPi * a.y);
      const Vec3f wi = directionAt(2 * b.x - 1, 2 * kPi * b.y);
      const float cosO = std::fabs(dot(wo, kNormal)), cosI = std::fabs(dot(wi, kNormal));
      if (cosO < 0.02f || cosI < 0.02f) continue;
      const Vec3f forward = bsdf.evaluate(wo, wi) / cosI;
      const Vec3f backward = bsdf.evaluate(wi, wo) / cosO;
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(forward[c], backward[c], 1e-3f * std::max(forward[c], 1e-3f));
      }
      if (forward.x > 0) ++checked;
    }
  }
  EXPECT_GT(checked, 330);
}

TEST(BsdfGlossy, LobeWidthGrowsWithRoughness) {
  const Vec3f wo = directionAt(0.7f);
  const Vec3f mirror = kNormal * (2 * dot(wo, kNormal)) - wo;
  float previousReflection = 0, previousTransmission = 0;
  for (float roughness : {0.1f, 0.25f, 0.4f, 0.6f, 0.8f}) {
    const PreviewSurfaceBsdf metal = makeBsdf(whiteMetal(roughness));
    const PreviewSurfaceBsdf sheet = makeBsdf(glass(roughness), DielectricKind::ThinSheet);
    double reflection = 0, transmission = 0;
    int reflected = 0, transmitted = 0;
    for (uint32_t i = 0; i < 4096; ++i) {
      SampleStream stream(3, 3, 3, i);
      const float uLobe = stream.next1D();
      const Vec2f u = stream.next2D();
      if (const std::optional<BsdfSample> s = metal.sample(wo, uLobe, u)) {
        reflection += angleBetween(s->direction, mirror);
        ++reflected;
      }
      const std::optional<BsdfSample> t = sheet.sample(wo, uLobe, u);
      if (t && t->transmitted) {
        transmission += angleBetween(t->direction, -wo);
        ++transmitted;
      }
    }
    const float meanReflection = float(reflection / reflected);
    const float meanTransmission = float(transmission / transmitted);
    EXPECT_GT(meanReflection, previousReflection * 1.1f) << "roughness " << roughness;
    EXPECT_GT(meanTransmission, previousTransmission * 1.1f) << "roughness " << roughness;
    previousReflection = meanReflection;
    previousTransmission = meanTransmission;
  }
}

TEST(BsdfLayers, FresnelReflectanceAtNormalIncidenceFollowsTheWorkflow) {
  const Vec3f wo = directionAt(1.0f);
  const auto mirrorWeight = [&](const MaterialParams& m) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(m);
    Vec3f total(0.0f);
    for (uint32_t i = 0; i < 1024; ++i) {
      SampleStream stream(1, 1, 1, i);
      const float uLobe = stream.next1D();
      const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
      if (s && s->isDelta) total += s->weight / 1024.0f;
    }
    return total;
  };
  MaterialParams plastic;
  plastic.roughness = 0;
  plastic.ior = 2.0f;
  EXPECT_NEAR(mirrorWeight(plastic).y, 1.0f / 9.0f, 0.003f);  // ((1 − 2)/(1 + 2))²
  MaterialParams specular;
  specular.roughness = 0;
  specular.useSpecularWorkflow = true;
  specular.specularColor = Vec3f(0.2f, 0.5f, 0.8f);
  const Vec3f f0 = mirrorWeight(specular);
  EXPECT_NEAR(f0.x, 0.2f, 0.005f);
  EXPECT_NEAR(f0.y, 0.5f, 0.005f);
  EXPECT_NEAR(f0.z, 0.8f, 0.005f);
  MaterialParams coated = whiteMetal(0.5f);
  coated.clearcoat = 1;
  coated.clearcoatRoughness = 0;
  EXPECT_NEAR(mirrorWeight(coated).y, 0.04f, 0.002f);
}

TEST(BsdfLayers, ClearcoatNeverCreatesEnergy) {
  for (float coatRoughness : {0.0f, 0.3f, 0.8f}) {
    MaterialParams m = whiteMetal(0.3f);
    m.clearcoat = 1;
    m.clearcoatRoughness = coatRoughness;
    for (float cosTheta : {0.1f, 0.5f, 1.0f}) {
      const double albedo = furnace(makeBsdf(m), directionAt(cosTheta), 1, 1u << 14).radiance;
      EXPECT_LE(albedo, 1.005) << "coat roughness " << coatRoughness << " cos " << cosTheta;
      EXPECT_GE(albedo, 0.8) << "coat roughness " << coatRoughness << " cos " << cosTheta;
    }
  }
}

// The sheen lobe by itself (∫ f cos θi over the hemisphere, independent of the sampling) reflects
// at most all energy; it is brightest at grazing angles. Measured: at cos θo = 1, 0.002 (roughness
// 0.1), 0.04 (0.3), 0.16 (1); at cos θo = 0.05, 0.49 (roughness 0, α = 0.01) to 0.82 (1).
TEST(BsdfSheen, LobeAloneNeverCreatesEnergy) {
  for (float sheenRoughness : {0.0f, 0.1f, 0.3f, 0.6f, 1.0f}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(sheenAlone(sheenRoughness));
    EXPECT_FALSE(bsdf.isPurelySpecular());
    double previous = 2;
    for (float cosTheta : {0.05f, 0.3f, 0.7f, 1.0f}) {
      const Vec3f wo = directionAt(cosTheta);
      const double albedo = integrateEvaluate(bsdf, wo, 512);
      EXPECT_GT(albedo, 0.0) << "roughness " << sheenRoughness << " cos " << cosTheta;
      EXPECT_LE(albedo, 1.0) << "roughness " << sheenRoughness << " cos " << cosTheta;
      EXPECT_LT(albedo, previous) << "roughness " << sheenRoughness << " cos " << cosTheta;
      previous = albedo;
      // The sampled estimate agrees. The mirror's Schlick reflectance is not 0 at grazing
      // angles: its (delta) samples are left out.
      double sampled = 0;
      const uint32_t n = 1u << 15;
      for (uint32_t i = 0; i < n; ++i) {
        SampleStream stream(1, 2, 3, i);
        const float uLobe = stream.next1D();
        const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, stream.next2D());
        if (s && !s->isDelta) sampled += (s->weight.x + s->weight.y + s->weight.z) / (3.0 * n);
      }
      EXPECT_NEAR(sampled, albedo, 0.01 + 0.02 * albedo)
          << "roughness " << sheenRoughness << " cos " << cosTheta;
    }
  }
}

// Albedo scaling: the base loses exactly what the white sheen reflects, so a white diffuse base
// under a white sheen (and the default specular layer) reflects all energy, within the error of
// the tabulated sheen albedo (measured: 0.996–1.0005 for sheen roughness 0.05–1, the lowest at
// cos θo = 0.05); a coloured sheen reflects less.
TEST(BsdfSheen, WhiteDiffuseUnderAWhiteSheenReflectsEverything) {
  for (float sheenRoughness : {0.05f, 0.3f, 0.6f, 1.0f}) {
    const PreviewSurfaceBsdf bsdf = makeBsdf(sheenOverWhiteDiffuse(sheenRoughness));
    for (float cosTheta : {0.05f, 0.3f, 0.7f, 1.0f, -0.5f}) {
      const Albedo a = furnace(bsdf, directionAt(cosTheta));
      EXPECT_NEAR(a.radiance, 1.0, 0.005) << "roughness " << sheenRoughness << " cos " << cosTheta;
    }
  }
  const PreviewSurfaceBsdf red = makeBsdf(sheenOverWhiteDiffuse(0.3f, Vec3f(1, 0, 0)));
  const Vec3f wo = directionAt(0.1f);
  Vec3f total(0.0f);
  const uint32_t n = 1u << 15;
  for (uint32_t i = 0; i < n; ++i) {
    SampleStream stream(5, 5, 5, i);
    const float uLobe = stream.next1D();
    if (const std::optional<BsdfSample> s = red.sample(wo, uLobe, stream.next2D()))
      total += s->weight / float(n);
  }
  EXPECT_NEAR(total.x, 1.0f, 0.01f);
  EXPECT_LT(total.y, 0.9f);  // the sheen's albedo at cos θo = 0.1 is taken from green and blue
  EXPECT_NEAR(total.y, total.z, 0.005f);
}

// The delta lobes under the sheen (a mirror, a smooth clearcoat) lose what the sheen reflects too.
TEST(BsdfSheen, MirrorUnderAWhiteSheenReflectsEverything) {
  MaterialParams mirror = whiteMetal(0);
  mirror.sheen = 1;
  mirror.sheenRoughness = 0.4f;
  MaterialParams coated = sheenOverWhiteDiffuse(0.4f);
  coated.clearcoat = 1;
  coated.clearcoatRoughness = 0;
  for (float cosTheta : {0.1f, 0.5f, 1.0f}) {
    EXPECT_NEAR(furnace(makeBsdf(mirror), directionAt(cosTheta)).radiance, 1.0, 0.005)
        << "cos " << cosTheta;
    // The clearcoat drops the light bouncing between coat and base (BsdfLayers above).
    const double albedo = furnace(makeBsdf(coated), directionAt(cosTheta)).radiance;
    EXPECT_LE(albedo, 1.005) << "cos " << cosTheta;
    EXPECT_GE(albedo, 0.85) << "cos " << cosTheta;
  }
}

TEST(BsdfSheen, ZeroSheenLeavesTheBsdfUnchanged) {
  MaterialParams plain;
  plain.diffuseColor = Vec3f(0.6f, 0.4f, 0.2f);
  plain.roughness = 0.4f;
  plain.clearcoat = 0.5f;
  MaterialParams unused = plain;
  unused.sheenColor = Vec3f(0.1f, 0.9f, 0.3f);
  unused.sheenRoughness = 0.8f;
  const PreviewSurfaceBsdf a = makeBsdf(plain), b = makeBsdf(unused);
  for (uint32_t i = 0; i < 256; ++i) {
    SampleStream stream(6, 6, 6, i);
    const Vec2f u = stream.next2D(), v = stream.next2D();
    const Vec3f wo = directionAt(2 * u.x - 1, 2 * kPi * u.y);
    const Vec3f wi = directionAt(2 * v.x - 1, 2 * kPi * v.y);
    const Vec3f fa = a.evaluate(wo, wi), fb = b.evaluate(wo, wi);
    EXPECT_TRUE(fa.x == fb.x && fa.y == fb.y && fa.z == fb.z);
    EXPECT_EQ(a.pdf(wo, wi), b.pdf(wo, wi));
    const float uLobe = stream.next1D();
    const Vec2f w = stream.next2D();
    const std::optional<BsdfSample> sa = a.sample(wo, uLobe, w), sb = b.sample(wo, uLobe, w);
    ASSERT_EQ(sa.has_value(), sb.has_value());
    if (sa) {
      EXPECT_EQ(sa->pdf, sb->pdf);
      EXPECT_TRUE(sa->direction.x == sb->direction.x && sa->direction.z == sb->direction.z);
    }
  }
}

// The clearcoat's colour tints what lies under it, not the coat's own (white) reflection.
TEST(BsdfLayers, ClearcoatColorTintsTheLayersUnderIt) {
  MaterialParams clear;
  clear.diffuseColor = Vec3f(1.0f);
  clear.roughness = 0.4f;
  clear.clearcoat = 1;
  clear.clearcoatRoughness = 0.3f;
  MaterialParams tinted = clear;
  tinted.clearcoatColor = Vec3f(1.0f, 0.5f, 0.25f);
  const PreviewSurfaceBsdf a = makeBsdf(clear), b = makeBsdf(tinted);
  int checked = 0;
  for (uint32_t i = 0; i < 256; ++i) {
    SampleStream stream(8, 8, 8, i);
    const Vec2f u = stream.next2D(), v = stream.next2D();
    const Vec3f wo = directionAt(0.05f + 0.95f * u.x, 2 * kPi * u.y);
    const Vec3f wi = directionAt(0.05f + 0.95f * v.x, 2 * kPi * v.y);
    const Vec3f fa = a.evaluate(wo, wi), fb = b.evaluate(wo, wi);
    EXPECT_EQ(fa.x, fb.x);  // red is untinted
    // f = coat + tint × under: what the tint removes from green and blue is in ratio 0.5 : 0.75.
    const Vec3f removed = fa - fb;
    EXPECT_NEAR(removed.z, 1.5f * removed.y, 1e-4f * fa.y + 1e-7f);
    EXPECT_GT(removed.y, 0.0f);
    ++checked;
  }
  EXPECT_EQ(checked, 256);
  for (float cosTheta : {0.1f, 0.6f, 1.0f}) {
    Vec3f clearTotal(0.0f), tintedTotal(0.0f);
    const uint32_t n = 1u << 14;
    for (uint32_t i = 0; i < n; ++i) {
      SampleStream stream(3, 1, 4, i);
      const float uLobe = stream.next1D();
      const Vec2f u = stream.next2D();
      if (const std::optional<BsdfSample> s = a.sample(directionAt(cosTheta), uLobe, u))
        clearTotal += s->weight / float(n);
      if (const std::optional<BsdfSample> s = b.sample(directionAt(cosTheta), uLobe, u))
        tintedTotal += s->weight / float(n);
    }
    EXPECT_NEAR(tintedTotal.x, clearTotal.x, 0.01f) << "cos " << cosTheta;
    EXPECT_LT(tintedTotal.y, 0.6f * clearTotal.y + 0.1f) << "cos " << cosTheta;
    EXPECT_LT(tintedTotal.z, tintedTotal.y) << "cos " << cosTheta;
  }
}

TEST(BsdfDispersion, CauchyFitThroughTheAbbeNumber) {
  const float nd = 1.5168f, vd = 64.17f;  // N-BK7
  EXPECT_NEAR(dispersiveIor(nd, vd, 587.6f), nd, 1e-6f);
  const float nF = dispersiveIor(nd, vd, 486.1f), nC = dispersiveIor(nd, vd, 656.3f);
  EXPECT_NEAR(nF - nC, (nd - 1) / vd, 1e-6f);
  EXPECT_GT(dispersiveIor(nd, vd, 400), dispersiveIor(nd, vd, 700));  // normal dispersion
  for (float wavelength : {380.0f, 486.1f, 587.6f, 780.0f}) {
    EXPECT_EQ(dispersiveIor(nd, 0, wavelength), nd);
  }
}

/// Unpolarised Fresnel reflectance from outside an interface of index n at cos θ (n > 1).
double fresnelFromOutside(double cosTheta, double n) {
  const double cosT = std::sqrt(1 - (1 - cosTheta * cosTheta) / (n * n));
  const double perpendicular = (cosTheta - n * cosT) / (cosTheta + n * cosT);
  const double parallel = (n * cosTheta - cosT) / (n * cosTheta + cosT);
  return 0.5 * (perpendicular * perpendicular + parallel * parallel);
}

TEST(BsdfDispersion, ReflectionKeepsEveryWavelengthAndRefractionOnlyTheHeros) {
  // Abbe number 2: the channels' indices (the hero's first) far enough apart that their Fresnel
  // factors differ by far more than the tolerance.
  const float nd = 1.6f;
  const Vec3f iors(dispersiveIor(nd, 2, 450), dispersiveIor(nd, 2, 650), dispersiveIor(nd, 2, 550));
  MaterialParams m = glass(0);
  m.ior = nd;
  for (const DielectricKind kind : {DielectricKind::Solid, DielectricKind::ThinSheet}) {
    const bool sheet = kind == DielectricKind::ThinSheet;
    for (float cosTheta : {0.15f, 0.6f, 1.0f}) {
      const Vec3f wo = directionAt(cosTheta);
      PreviewSurfaceBsdf bsdf(m, kNormal, iors.x, kind, kTangent);
      ASSERT_TRUE(bsdf.disperse(wo, iors, nd));
      // The same material whose channels' indices are the other way round: its reflect/refract
      // choice must be the same, as it may not depend on the wavelengths.
      PreviewSurfaceBsdf swapped(m, kNormal, iors.z, kind, kTangent);
      ASSERT_TRUE(swapped.disperse(wo, {iors.z, iors.y, iors.x}, nd));
      std::array<double, 3> reflected{}, transmitted{};
      const int n = 1 << 14;
      for (int i = 0; i < n; ++i) {
        const float uLobe = (float(i) + 0.5f) / float(n);
        const std::optional<BsdfSample> s = bsdf.sample(wo, uLobe, {0.5f, 0.5f});
        const std::optional<BsdfSample> t = swapped.sample(wo, uLobe, {0.5f, 0.5f});
        ASSERT_TRUE(s && t);
        ASSERT_EQ(s->transmitted, t->transmitted) << "u " << uLobe;
        ASSERT_TRUE(s->isDelta);
        EXPECT_EQ(s->heroOnly, s->transmitted && !sheet);
        for (int c = 0; c < 3; ++c)
          (s->transmitted ? transmitted : reflected)[size_t(c)] += s->weight[c] / double(n);
        if (s->transmitted && !sheet) {  // Snell's law at the hero's index
          const Vec3f sideways = s->direction - kNormal * dot(s->direction, kNormal);
          EXPECT_NEAR(length(sideways) * iors.x, std::sqrt(1 - cosTheta * cosTheta), 1e-5f);
        }
      }
      for (int c = 0; c < 3; ++c) {
        const double f = fresnelFromOutside(cosTheta, iors[c]);
        const double r = sheet ? 2 * f / (1 + f) : f;  // a thin slab's, all bounces inside
        EXPECT_NEAR(reflected[size_t(c)], r, 1e-3)
            << "kind " << sheet << " cos " << cosTheta << " c " << c;
        const double expected = sheet ? 1 - r : c == 0 ? (1 - r) / (iors.x * iors.x) : 0.0;
        EXPECT_NEAR(transmitted[size_t(c)], expected, 1e-3)
            << "kind " << sheet << " cos " << cosTheta << " c " << c;
      }
    }
  }
  // Elsewhere the BSDF cannot tell refraction apart when it is chosen: the path keeps the hero.
  const Vec3f wo = directionAt(0.6f);
  PreviewSurfaceBsdf solid(m, kNormal, iors.x);
  EXPECT_FALSE(solid.disperse(-wo, iors, nd));  // from inside: total internal reflection
  EXPECT_FALSE(solid.disperse(wo, {iors.x, 0.9f, iors.z}, nd));
  EXPECT_FALSE(solid.disperse(wo, iors, std::nanf("")));
  MaterialParams rough = glass(0.3f), translucent = m;
  translucent.opacity = 0.5f;
  for (const MaterialParams& other : {rough, translucent}) {
    PreviewSurfaceBsdf bsdf(other, kNormal, iors.x);
    EXPECT_FALSE(bsdf.disperse(wo, iors, nd));
  }
}

TEST(BsdfAnisotropy, WhiteMetalKeepsTheIsotropicEnergy) {
  // The multiple-scattering term compensates the single-scattering lobe's loss by the azimuthal
  // albedo table: energy never exceeds 1 (beyond the table's interpolation error) and stays close
  // to the isotropic lobe's.
  for (const AnisotropyModel model : {AnisotropyModel::OpenPbr, AnisotropyModel::StandardSurface}) {
    for (float roughness : {0.3f, 0.6f, 0.9f}) {
      for (float anisotropy : {0.5f, 0.9f}) {
        const PreviewSurfaceBsdf bsdf =
            makeBsdf(anisotropicWhiteMetal(roughness, anisotropy, model));
        const PreviewSurfaceBsdf isotropic = makeBsdf(whiteMetal(roughness));
        for (float cosTheta : {0.1f, 0.4f, 1.0f}) {
          for (float phi : {0.0f, 0.8f, 1.6f}) {
            const Vec3f wo = directionAt(cosTheta, phi);
            const double albedo = furnace(bsdf, wo, 1, 1u << 14).radiance;
            const double reference = furnace(isotropic, wo, 1, 1u << 14).radiance;
            const auto where = [&] {
              return ::testing::Message()
                     << "model " << int(model) << " roughness " << roughness << " anisotropy "
                     << anisotropy << " cos " << cosTheta << " phi " << phi;
            };
            EXPECT_LE(albedo, 1.01) << where();
            EXPECT_NEAR(albedo, reference, 0.03) << where();
          }
        }
      }
    }
  }
}

TEST(BsdfAnisotropy, NoAnisotropyIgnoresTangentAndRotation) {
  MaterialParams m = whiteMetal(0.4f);
  m.clearcoat = 0.5f;
  m.clearcoatRoughness = 0.3f;
  const PreviewSurfaceBsdf plain(m, kNormal, m.ior);
  m.anisotropyRotation = 0.3f;
  m.anisotropyModel = AnisotropyModel::StandardSurface;
  const PreviewSurfaceBsdf turned(m, kNormal, m.ior, DielectricKind::Solid, kTangent);
  for (uint32_t i = 0; i < 64; ++i) {
    SampleStream stream(3, 1, 4, i);
    const Vec2f a = stream.next2D(), b = stream.next2D();
    const Vec3f wo = directionAt(a.x, 2 * kPi * a.y), wi = directionAt(b.x, 2 * kPi * b.y);
    const Vec3f f = plain.evaluate(wo, wi), g = turned.evaluate(wo, wi);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(f[c], g[c]);  // bit-identical
    EXPECT_EQ(plain.pdf(wo, wi), turned.pdf(wo, wi));
  }
}

namespace {
/// Second moments of the reflected directions' offsets from the mirror direction, along `along`
/// and `across` (unit vectors in the surface's plane), for light arriving along the normal.
std::pair<double, double> spreadOfReflection(const PreviewSurfaceBsdf& bsdf, const Vec3f& along,
                                             const Vec3f& across) {
  double alongSum = 0, acrossSum = 0;
  const uint32_t n = 1u << 14;
  for (uint32_t i = 0; i < n; ++i) {
    SampleStream stream(5, 5, 5, i);
    const float uLobe = stream.next1D();
    const std::optional<BsdfSample> s = bsdf.sample(kNormal, uLobe, stream.next2D());
    if (!s) continue;
    const float x = dot(s->direction, along), y = dot(s->direction, across);
    alongSum += x * x;
    acrossSum += y * y;
  }
  return {alongSum / n, acrossSum / n};
}
}  // namespace

TEST(BsdfAnisotropy, LobeStretchesAlongTheTurnedTangent) {
  const Frame frame = Frame::withTangent(kNormal, kTangent);
  for (const AnisotropyModel model : {AnisotropyModel::OpenPbr, AnisotropyModel::StandardSurface}) {
    MaterialParams m = anisotropicWhiteMetal(0.4f, 0.8f, model);
    const auto [alongTangent, alongBitangent] = spreadOfReflection(makeBsdf(m), frame.s, frame.t);
    EXPECT_GT(alongTangent, 4 * alongBitangent) << int(model);
    // A quarter turn counter-clockwise about the normal: the tangent becomes the bitangent.
    m.anisotropyRotation = 0.25f;
    const auto [turnedTangent, turnedBitangent] = spreadOfReflection(makeBsdf(m), frame.s, frame.t);
    EXPECT_GT(turnedBitangent, 4 * turnedTangent) << int(model);
    EXPECT_NEAR(turnedBitangent, alongTangent, 0.05 * alongTangent) << int(model);
  }
}
