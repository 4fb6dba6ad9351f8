// Spectral rendering support (for dispersion): hero-wavelength sampling, the conversion of
// wavelength samples back to the rendering space, and RGB → smooth spectrum upsampling.
//
// Rendering space and white. A spectrum that is constant 1 over [kLambdaMin, kLambdaMax] (CIE
// illuminant E, "equal energy") is the rendering space's white (1, 1, 1). The CIE 1931 XYZ of a
// spectrum (cieColorMatching, integrated over the range) is chromatically adapted from E's white to
// D65 with the Bradford transform and then mapped by xyzToLinearRec709; finally each row is
// rescaled by the tiny factor that makes illuminant E come out as exactly (1, 1, 1). The product is
// one 3×3 matrix; renderingSpaceMatching(λ) is that matrix applied to the CMFs, i.e. the rendering
// space's own colour-matching functions r̄, ḡ, b̄, each integrating to 1. Consequences: RGB mode and
// spectral mode agree on grey surfaces under white light (no illuminant multiplies light spectra,
// unlike pbrt's D65-white spaces), and saturated colours (narrow-band spectra, dispersion fringes)
// are seen by an observer adapted to equal-energy white.
//
// Hero-wavelength sampling (Wilkie et al. 2014). A camera path carries three wavelengths, held in a
// Vec3f so that the RGB-style BSDF code runs on them channel-wise. They are stratified in the
// primary sample space: λ_i = P⁻¹(frac(u + i/3)), P being the CDF of the visible-wavelength density
// p(λ) ∝ 1/cosh²(0.0072 (λ − 538 nm)) on [360, 830] nm (pbrt-v4's choice, close to the sum of the
// CMFs). Every λ_i then has the same marginal density p and the three cover the range evenly.
// (The lead's sketch rotated λ by equal offsets in nanometres instead; with a non-uniform density
// that gives λ_1, λ_2 shifted densities that no longer follow the CMFs — a peak at 538 nm turns
// into peaks at 695 and 381 nm — so their samples would be noisy or need a multiple-importance
// sum.)
//
// Upsampling (Jakob & Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral
// Upsampling"): s(λ) = scale · σ(c0 t² + c1 t + c2), t = (λ − 360)/470, σ(x) = ½ + x/(2√(1 + x²)).
// The coefficients are fitted by Newton's method (the Gauss–Newton step of a square system) so that
// the spectrum integrated against renderingSpaceMatching reproduces the RGB. A table over RGB,
// parametrised by the largest component z and the other two divided by it (3 tables of 32³ nodes,
// z from 0.1 to 1 − 3e-5 clustered towards 1, interpolation weights linear in σ⁻¹(z)), holds the
// fitted coefficients; lookups interpolate them trilinearly. Colours darker than z = 0.1 get the
// spectrum of the same chromaticity at z = 0.1, scaled down (the model's own dark spectra are too
// broad to reach saturated dark colours). Built on first use, or by prepareSpectralTables(), with
// TBB: about 0.3–0.5 s on 2 cores, 1.2 MB.
#pragma once

#include "penumbra/math.h"

namespace penumbra {

constexpr float kLambdaMin = 360.0f;  // nm
constexpr float kLambdaMax = 830.0f;  // nm

/// The rendering space's colour-matching functions at `lambdaNm`: the adapted CIE 1931 observer
/// described above. ∫ renderingSpaceMatching(λ) dλ over [kLambdaMin, kLambdaMax] = (1, 1, 1), so
/// the rendering-space colour of a spectrum L is ∫ L(λ) renderingSpaceMatching(λ) dλ.
Vec3f renderingSpaceMatching(float lambdaNm);

/// Density (per nm) of sampleVisibleWavelength on [kLambdaMin, kLambdaMax]; 0 outside.
float visibleWavelengthPdf(float lambdaNm);
/// Inverse CDF of visibleWavelengthPdf: u in [0, 1) → λ in [kLambdaMin, kLambdaMax].
float sampleVisibleWavelength(float u);

/// The wavelengths a path carries. Channel i of a spectral Vec3f (throughput, radiance, a
/// spectrum's values) belongs to lambda[i]; lambda.x is the hero wavelength.
struct SampledWavelengths {
  Vec3f lambda;  // nm
  /// Density of each wavelength (per nm). 0 marks a terminated secondary wavelength.
  Vec3f pdf;

  float hero() const { return lambda.x; }
  /// Drops the secondary wavelengths: for paths whose direction depends on the wavelength (a
  /// dispersive interface). The hero alone stays an unbiased estimate (it has density p).
  void keepHeroOnly() { pdf.y = pdf.z = 0; }
  bool heroOnly() const { return pdf.y == 0 && pdf.z == 0; }
};

/// Three stratified wavelengths from one uniform number u in [0, 1) (see above).
SampledWavelengths sampleWavelengths(float u);

/// Radiance samples at the path's wavelengths → rendering-space (linear Rec.709, E white) RGB: the
/// average over the live wavelengths of L(λ_i) renderingSpaceMatching(λ_i) / pdf_i, an unbiased
/// estimate of ∫ L(λ) renderingSpaceMatching(λ) dλ. Terminated channels are ignored.
Vec3f spectralToRgb(const Vec3f& radiance, const SampledWavelengths& wavelengths);

/// A smooth spectrum upsampled from an RGB colour: scale · σ(c0 t² + c1 t + c2) (see above).
/// 16 bytes; evaluation costs a few multiplies and a square root per wavelength.
class RgbSpectrum {
 public:
  /// The zero spectrum.
  RgbSpectrum() = default;

  /// A reflectance: values in [0, 1] at every wavelength for rgb in [0, 1]³ (table lookup, ~70 ns
  /// with three evaluations). Round trip: mean error 4e-4, worst measured 2.6e-3 (between table
  /// nodes; below 8-bit quantisation). Negative components are clamped to 0. Grey (r = g = b) is
  /// exactly constant. A colour with a component above 1 cannot be a bounded reflectance: it is
  /// upsampled as unbounded(rgb) (the round trip still holds, values exceed 1).
  static RgbSpectrum reflectance(const Vec3f& rgb);
  /// Any non-negative colour (emission, light colours): 2·max(rgb) times the reflectance spectrum
  /// of rgb / (2·max(rgb)) (pbrt's trick; the factor 2 keeps the fit away from the saturated
  /// corners). Negative components are clamped to 0. Grey is exactly constant.
  static RgbSpectrum unbounded(const Vec3f& rgb);
  /// reflectance(rgb) refined by Newton iterations on the fit's quadrature: round trip
  /// within 2.5e-4 over [0, 1]³ (the 5 nm Simpson quadrature's error against the exact integral).
  /// About 3 µs: for material constants converted once, not per hit.
  static RgbSpectrum reflectanceExact(const Vec3f& rgb);

  /// The spectrum's value at one wavelength (nm).
  float at(float lambdaNm) const;
  /// Values at a path's three wavelengths (a spectral Vec3f).
  Vec3f at(const Vec3f& lambdaNm) const { return {at(lambdaNm.x), at(lambdaNm.y), at(lambdaNm.z)}; }

  float c0() const { return c0_; }
  float c1() const { return c1_; }
  float c2() const { return c2_; }
  float scale() const { return scale_; }

 private:
  RgbSpectrum(float c0, float c1, float c2, float scale)
      : c0_(c0), c1_(c1), c2_(c2), scale_(scale) {}

  float c0_ = 0, c1_ = 0, c2_ = 0, scale_ = 0;
};

/// Builds the upsampling table now (it is otherwise built by the first lookup, which then blocks
/// every other thread that needs it). Call at scene load when spectral rendering will be used.
void prepareSpectralTables();

}  // namespace penumbra
