#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "penumbra/spectrum.h"

using namespace penumbra;

namespace {

/// ∫ f(λ) renderingSpaceMatching(λ) dλ by the trapezoid rule on 0.1 nm steps: the "true" colour
/// of a spectrum, independent of the quadrature the upsampling fit uses.
template <typename F>
Vec3f integrateToRgb(const F& f) {
  constexpr int kSteps = 4700;
  const double h = double(kLambdaMax - kLambdaMin) / kSteps;
  double sum[3] = {0, 0, 0};
  for (int i = 0; i <= kSteps; ++i) {
    const float lambda = float(kLambdaMin + i * h);
    const double weight = (i == 0 || i == kSteps) ? 0.5 : 1.0;
    const double value = double(f(lambda)) * weight * h;
    const Vec3f m = renderingSpaceMatching(lambda);
    sum[0] += value * m.x;
    sum[1] += value * m.y;
    sum[2] += value * m.z;
  }
  return {float(sum[0]), float(sum[1]), float(sum[2])};
}

Vec3f roundTrip(const RgbSpectrum& s) {
  return integrateToRgb([&s](float lambda) { return s.at(lambda); });
}

/// Monte Carlo estimate of a spectrum's colour through sampleWavelengths and spectralToRgb.
/// `heroOnlyProbability`: the chance that a sample drops its secondary wavelengths.
template <typename F>
Vec3f monteCarloRgb(const F& f, int samples, float heroOnlyProbability, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  double sum[3] = {0, 0, 0};
  for (int i = 0; i < samples; ++i) {
    // Jittered (stratified) u: unbiased like independent u, with far less variance.
    SampledWavelengths wl =
        sampleWavelengths(std::min((float(i) + uniform(rng)) / float(samples), 0.99999994f));
    if (uniform(rng) < heroOnlyProbability) wl.keepHeroOnly();
    const Vec3f radiance{f(wl.lambda.x), f(wl.lambda.y), f(wl.lambda.z)};
    const Vec3f rgb = spectralToRgb(radiance, wl);
    sum[0] += rgb.x;
    sum[1] += rgb.y;
    sum[2] += rgb.z;
  }
  return {float(sum[0] / samples), float(sum[1] / samples), float(sum[2] / samples)};
}

float maxAbsDifference(const Vec3f& a, const Vec3f& b) {
  return maxAbsComponent(a - b);
}

}  // namespace

// Built ahead (as Scene::commit does for a dispersive scene), the table serves the same
// spectra as when it is built on first use: preparing it is only a matter of when.
TEST(SpectrumUpsampling, PreparedTableServesReflectances) {
  prepareSpectralTables();
  const Vec3f orange{0.8f, 0.3f, 0.05f};
  EXPECT_LT(maxAbsDifference(roundTrip(RgbSpectrum::reflectance(orange)), orange), 4e-3f);
}

TEST(SpectrumColor, MatchingFunctionsIntegrateToWhite) {
  const Vec3f white = integrateToRgb([](float) { return 1.0f; });
  EXPECT_NEAR(white.x, 1.0f, 1e-5f);
  EXPECT_NEAR(white.y, 1.0f, 1e-5f);
  EXPECT_NEAR(white.z, 1.0f, 1e-5f);
  // Ordinary colour science: the matching functions peak where the primaries are.
  EXPECT_GT(renderingSpaceMatching(450).z, renderingSpaceMatching(450).x);
  EXPECT_GT(renderingSpaceMatching(530).y, renderingSpaceMatching(530).x);
  EXPECT_GT(renderingSpaceMatching(620).x, renderingSpaceMatching(620).y);
}

TEST(SpectrumWavelengths, PdfIntegratesToOne) {
  constexpr int kSteps = 47000;
  const double h = double(kLambdaMax - kLambdaMin) / kSteps;
  double integral = 0;
  for (int i = 0; i <= kSteps; ++i)
    integral +=
        ((i == 0 || i == kSteps) ? 0.5 : 1.0) * h * visibleWavelengthPdf(float(kLambdaMin + i * h));
  EXPECT_NEAR(integral, 1.0, 1e-5);
  EXPECT_EQ(visibleWavelengthPdf(359.0f), 0.0f);
  EXPECT_EQ(visibleWavelengthPdf(831.0f), 0.0f);
  EXPECT_NEAR(sampleVisibleWavelength(0.0f), kLambdaMin, 1e-3f);
  EXPECT_NEAR(sampleVisibleWavelength(0.99999994f), kLambdaMax, 0.5f);
  // The density peaks near the middle of the visible range.
  EXPECT_GT(visibleWavelengthPdf(540), 2 * visibleWavelengthPdf(400));
  EXPECT_GT(visibleWavelengthPdf(540), 2 * visibleWavelengthPdf(750));
}

TEST(SpectrumWavelengths, SamplesFollowPdf) {
  constexpr int kBins = 47, kSamples = 400000;
  std::vector<int> histogram(kBins, 0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  float previous = kLambdaMin;
  for (int i = 0; i < kSamples; ++i) {
    const float lambda = sampleVisibleWavelength(std::min(uniform(rng), 0.99999994f));
    ASSERT_GE(lambda, kLambdaMin);
    ASSERT_LE(lambda, kLambdaMax);
    const int bin = std::min(kBins - 1, int((lambda - kLambdaMin) / 10));
    ++histogram[size_t(bin)];
  }
  for (int bin = 0; bin < kBins; ++bin) {
    double probability = 0;  // of the bin, by integrating the pdf finely
    for (int k = 0; k < 100; ++k)
      probability += visibleWavelengthPdf(kLambdaMin + 10 * bin + (k + 0.5f) * 0.1f) * 0.1;
    const double expected = probability * kSamples;
    EXPECT_NEAR(histogram[size_t(bin)], expected, 5 * std::sqrt(expected) + 1) << "bin " << bin;
  }
  // Monotone inverse CDF.
  for (int i = 1; i <= 1000; ++i) {
    const float lambda = sampleVisibleWavelength(std::min(i / 1000.0f, 0.99999994f));
    EXPECT_GE(lambda, previous);
    previous = lambda;
  }
}

TEST(SpectrumWavelengths, ThreeStratifiedWavelengths) {
  for (float u : {0.0f, 0.1f, 0.34f, 0.5f, 0.9f, 0.999f}) {
    const SampledWavelengths wl = sampleWavelengths(u);
    EXPECT_FALSE(wl.heroOnly());
    EXPECT_EQ(wl.hero(), wl.lambda.x);
    EXPECT_EQ(wl.lambda.x, sampleVisibleWavelength(u));
    int terciles[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i) {
      EXPECT_FLOAT_EQ(wl.pdf[i], visibleWavelengthPdf(wl.lambda[i]));
      // Which third of the CDF the wavelength lies in.
      const int third = wl.lambda[i] < sampleVisibleWavelength(1 / 3.0f)   ? 0
                        : wl.lambda[i] < sampleVisibleWavelength(2 / 3.0f) ? 1
                                                                           : 2;
      ++terciles[third];
    }
    EXPECT_EQ(terciles[0], 1) << u;
    EXPECT_EQ(terciles[1], 1) << u;
    EXPECT_EQ(terciles[2], 1) << u;
  }
  SampledWavelengths wl = sampleWavelengths(0.3f);
  wl.keepHeroOnly();
  EXPECT_TRUE(wl.heroOnly());
  EXPECT_GT(wl.pdf.x, 0);
  // Terminated channels are ignored, whatever they hold.
  EXPECT_EQ(maxAbsDifference(spectralToRgb({1, 5, 7}, wl), spectralToRgb({1, 0, 0}, wl)), 0.0f);
}

TEST(SpectrumColor, ConstantSpectrumIsWhiteInExpectation) {
  const auto constant = [](float) { return 1.0f; };
  const Vec3f all = monteCarloRgb(constant, 200000, 0.0f, 1);
  const Vec3f hero = monteCarloRgb(constant, 200000, 1.0f, 2);
  const Vec3f mixed = monteCarloRgb(constant, 200000, 0.5f, 3);
  for (const Vec3f& rgb : {all, hero, mixed}) {
    EXPECT_NEAR(rgb.x, 1.0f, 0.01f);
    EXPECT_NEAR(rgb.y, 1.0f, 0.01f);
    EXPECT_NEAR(rgb.z, 1.0f, 0.01f);
  }
  std::printf("constant 1: all %.4f %.4f %.4f, hero only %.4f %.4f %.4f\n", all.x, all.y, all.z,
              hero.x, hero.y, hero.z);
}

TEST(SpectrumColor, NarrowBandsHaveTheirHue) {
  const auto band = [](float centre) {
    return [centre](float lambda) {
      const float t = (lambda - centre) / 8.0f;
      return std::exp(-0.5f * t * t);
    };
  };
  const Vec3f blue = monteCarloRgb(band(450), 100000, 0.0f, 4);
  const Vec3f green = integrateToRgb(band(530));
  const Vec3f red = monteCarloRgb(band(650), 100000, 0.0f, 5);
  EXPECT_GT(blue.z, 2 * std::max(blue.x, blue.y));
  EXPECT_GT(green.y, 2 * std::max(green.x, green.z));
  EXPECT_GT(red.x, 2 * std::max(red.y, red.z));
  // Monte Carlo agrees with the integral.
  const Vec3f blueExact = integrateToRgb(band(450));
  EXPECT_NEAR(blue.z, blueExact.z, 0.02f * blueExact.z);
}

TEST(SpectrumColor, KeepHeroOnlyStaysUnbiased) {
  const RgbSpectrum spectrum = RgbSpectrum::reflectance({0.8f, 0.3f, 0.1f});
  const auto f = [&spectrum](float lambda) { return spectrum.at(lambda); };
  const Vec3f exact = integrateToRgb(f);
  for (float heroOnly : {0.0f, 0.5f, 1.0f}) {
    const Vec3f estimate = monteCarloRgb(f, 200000, heroOnly, 11);
    EXPECT_LT(maxAbsDifference(estimate, exact), 0.01f * maxComponent(exact)) << heroOnly;
  }
}

TEST(SpectrumUpsampling, GreyIsExactlyFlat) {
  for (float v : {0.0f, 1e-7f, 0.001f, 0.18f, 0.5f, 0.9f, 1.0f}) {
    const RgbSpectrum s = RgbSpectrum::reflectance(Vec3f(v));
    for (float lambda = kLambdaMin; lambda <= kLambdaMax; lambda += 10)
      EXPECT_NEAR(s.at(lambda), v, 1e-6f * std::max(v, 1e-3f)) << v << " at " << lambda;
    EXPECT_EQ(s.c0(), 0.0f);
    EXPECT_EQ(s.c1(), 0.0f);
  }
  for (float v : {0.25f, 3.0f, 1000.0f}) {
    const RgbSpectrum s = RgbSpectrum::unbounded(Vec3f(v));
    for (float lambda = kLambdaMin; lambda <= kLambdaMax; lambda += 10)
      EXPECT_NEAR(s.at(lambda), v, 1e-6f * v);
  }
  EXPECT_EQ(RgbSpectrum::reflectance(Vec3f(1.0f)).at(550), 1.0f);
  EXPECT_EQ(RgbSpectrum().at(550), 0.0f);
}

TEST(SpectrumUpsampling, RoundTripOverReflectanceGrid) {
  constexpr int kSteps = 10;
  float worstTable = 0, worstExact = 0;
  Vec3f worstTableColor, worstExactColor;
  double sumTable = 0;
  int count = 0;
  for (int r = 0; r <= kSteps; ++r)
    for (int g = 0; g <= kSteps; ++g)
      for (int b = 0; b <= kSteps; ++b) {
        const Vec3f rgb{float(r) / kSteps, float(g) / kSteps, float(b) / kSteps};
        const float tableError = maxAbsDifference(roundTrip(RgbSpectrum::reflectance(rgb)), rgb);
        const float exactError =
            maxAbsDifference(roundTrip(RgbSpectrum::reflectanceExact(rgb)), rgb);
        if (tableError > worstTable) worstTable = tableError, worstTableColor = rgb;
        if (exactError > worstExact) worstExact = exactError, worstExactColor = rgb;
        sumTable += tableError;
        ++count;
      }
  std::printf(
      "round trip over %d reflectances: table worst %.2e at (%.1f %.1f %.1f), mean %.2e; "
      "exact worst %.2e at (%.1f %.1f %.1f)\n",
      count, worstTable, worstTableColor.x, worstTableColor.y, worstTableColor.z, sumTable / count,
      worstExact, worstExactColor.x, worstExactColor.y, worstExactColor.z);
  // The fit itself (limited by its 5 nm Simpson quadrature) is within 1e-3; the table's trilinear
  // interpolation of coefficients adds up to a few 1e-3 (below 8-bit quantisation, 1/255).
  EXPECT_LT(worstExact, 1e-3f);
  EXPECT_LT(worstTable, 4e-3f);
  EXPECT_LT(sumTable / count, 1e-3);
}

TEST(SpectrumUpsampling, RoundTripOffGrid) {
  // Random colours (between table nodes) and very dark ones (below the first z node).
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  float worst = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3f rgb{uniform(rng), uniform(rng), uniform(rng)};
    worst = std::max(worst, maxAbsDifference(roundTrip(RgbSpectrum::reflectance(rgb)), rgb));
  }
  std::printf("round trip over 300 random reflectances: table worst %.2e\n", worst);
  EXPECT_LT(worst, 4e-3f);
  for (const Vec3f& dark :
       {Vec3f(1e-6f, 2e-6f, 0), Vec3f(0, 0, 3e-7f), Vec3f(0.004f, 0.001f, 0.002f)}) {
    const Vec3f back = roundTrip(RgbSpectrum::reflectance(dark));
    EXPECT_LT(maxAbsDifference(back, dark), 0.04f * maxComponent(dark))
        << back.x << " " << back.y << " " << back.z;
  }
}

TEST(SpectrumUpsampling, ReflectancesStayWithinUnitInterval) {
  constexpr int kSteps = 8;
  for (int r = 0; r <= kSteps; ++r)
    for (int g = 0; g <= kSteps; ++g)
      for (int b = 0; b <= kSteps; ++b) {
        const Vec3f rgb{float(r) / kSteps, float(g) / kSteps, float(b) / kSteps};
        for (const RgbSpectrum& s :
             {RgbSpectrum::reflectance(rgb), RgbSpectrum::reflectanceExact(rgb)})
          for (float lambda = kLambdaMin; lambda <= kLambdaMax; lambda += 5) {
            const float v = s.at(lambda);
            ASSERT_GE(v, 0.0f) << rgb.x << " " << rgb.y << " " << rgb.z;
            ASSERT_LE(v, 1.0f) << rgb.x << " " << rgb.y << " " << rgb.z;
          }
      }
  // Out-of-range input: negatives clamp to 0.
  const RgbSpectrum clamped = RgbSpectrum::reflectance({-0.5f, 0.5f, 0.5f});
  EXPECT_LT(maxAbsDifference(roundTrip(clamped), {0, 0.5f, 0.5f}), 4e-3f);
}

TEST(SpectrumUpsampling, UnboundedScales) {
  for (const Vec3f& rgb : {Vec3f(10, 5, 1), Vec3f(0.2f, 0.05f, 0.9f), Vec3f(300, 0, 40)}) {
    const RgbSpectrum s = RgbSpectrum::unbounded(rgb);
    EXPECT_FLOAT_EQ(s.scale(), 2 * maxComponent(rgb));
    const Vec3f back = roundTrip(s);
    EXPECT_LT(maxAbsDifference(back, rgb), 1e-2f * maxComponent(rgb))
        << back.x << " " << back.y << " " << back.z;
    // Linear in the colour: the same chromaticity scaled.
    const RgbSpectrum doubled = RgbSpectrum::unbounded(rgb * 2);
    for (float lambda : {400.0f, 550.0f, 700.0f})
      EXPECT_NEAR(doubled.at(lambda), 2 * s.at(lambda), 1e-6f * doubled.at(lambda) + 1e-30f);
  }
  // A "reflectance" above 1 is upsampled as unbounded.
  const Vec3f bright{1.5f, 0.5f, 0.2f};
  EXPECT_LT(maxAbsDifference(roundTrip(RgbSpectrum::reflectance(bright)), bright), 1.5e-2f);
  EXPECT_EQ(RgbSpectrum::unbounded(Vec3f(0.0f)).at(500), 0.0f);
}
