#include "penumbra/color.h"

namespace penumbra {
namespace {

float piecewiseGaussian(float x, float mean, float sigmaBelow, float sigmaAbove) {
  const float t = (x - mean) / (x < mean ? sigmaBelow : sigmaAbove);
  return std::exp(-0.5f * t * t);
}

/// Planck's law, spectral radiance per metre of wavelength (the scale cancels on normalising).
double planck(double wavelengthMetres, double kelvin) {
  constexpr double h = 6.62607015e-34, c = 2.99792458e8, kB = 1.380649e-23;
  const double l5 = std::pow(wavelengthMetres, 5);
  return 2 * h * c * c / (l5 * (std::exp(h * c / (wavelengthMetres * kB * kelvin)) - 1));
}

}  // namespace

Vec3f cieColorMatching(float nm) {
  const float x = 1.056f * piecewiseGaussian(nm, 599.8f, 37.9f, 31.0f) +
                  0.362f * piecewiseGaussian(nm, 442.0f, 16.0f, 26.7f) -
                  0.065f * piecewiseGaussian(nm, 501.1f, 20.4f, 26.2f);
  const float y = 0.821f * piecewiseGaussian(nm, 568.8f, 46.9f, 40.5f) +
                  0.286f * piecewiseGaussian(nm, 530.9f, 16.3f, 31.1f);
  const float z = 1.217f * piecewiseGaussian(nm, 437.0f, 11.8f, 36.0f) +
                  0.681f * piecewiseGaussian(nm, 459.0f, 26.0f, 13.8f);
  return {x, y, z};
}

Vec3f xyzToLinearRec709(const Vec3f& xyz) {
  return {3.2404542f * xyz.x - 1.5371385f * xyz.y - 0.4985314f * xyz.z,
          -0.9692660f * xyz.x + 1.8760108f * xyz.y + 0.0415560f * xyz.z,
          0.0556434f * xyz.x - 0.2040259f * xyz.y + 1.0572252f * xyz.z};
}

Vec3f blackbodyColor(float kelvin) {
  const double temperature = std::clamp(double(kelvin), 1000.0, 10000.0);
  double X = 0, Y = 0, Z = 0;
  for (int nm = 360; nm <= 830; ++nm) {
    const double power = planck(nm * 1e-9, temperature);
    const Vec3f cmf = cieColorMatching(float(nm));
    X += power * cmf.x;
    Y += power * cmf.y;
    Z += power * cmf.z;
  }
  // Warm temperatures fall outside Rec.709: clip the negative primaries before normalising.
  Vec3f rgb = xyzToLinearRec709({float(X / Y), 1.0f, float(Z / Y)});
  rgb = {std::max(rgb.x, 0.0f), std::max(rgb.y, 0.0f), std::max(rgb.z, 0.0f)};
  return rgb / luminance(rgb);
}

}  // namespace penumbra
