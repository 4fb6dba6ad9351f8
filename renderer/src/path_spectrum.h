// What a path's three colour channels carry, shared by the path tracer (integrator.cpp) and the
// light tracer (caustics.cpp): RGB, or, in scenes with dispersion, three wavelengths
// (spectrum.h), with the scene's RGB inputs upsampled to smooth spectra (Jakob & Hanika 2019).
#pragma once

#include "penumbra/bsdf.h"
#include "penumbra/material.h"
#include "penumbra/spectrum.h"

namespace penumbra {

struct PathSpectrum {
  bool spectral = false;
  SampledWavelengths wavelengths;

  Vec3f emission(const Vec3f& rgb) const {
    return spectral ? RgbSpectrum::unbounded(rgb).at(wavelengths.lambda) : rgb;
  }
  Vec3f reflectance(const Vec3f& rgb) const {
    return spectral ? RgbSpectrum::reflectance(rgb).at(wavelengths.lambda) : rgb;
  }
  /// Whether `material` sends the wavelengths different ways (its index depends on them).
  bool disperses(const MaterialParams& material) const {
    return spectral && !material.hair && material.abbeNumber > 0 && material.opacity < 1;
  }
  /// `material`'s index of refraction: under dispersion, the hero wavelength's.
  float ior(const MaterialParams& material) const {
    return disperses(material)
               ? dispersiveIor(material.ior, material.abbeNumber, wavelengths.hero())
               : material.ior;
  }
  /// Each wavelength's index of a material that disperses (channel i at wavelength i).
  Vec3f channelIors(const MaterialParams& material) const {
    const Vec3f& lambda = wavelengths.lambda;
    return {dispersiveIor(material.ior, material.abbeNumber, lambda.x),
            dispersiveIor(material.ior, material.abbeNumber, lambda.y),
            dispersiveIor(material.ior, material.abbeNumber, lambda.z)};
  }
  /// A UsdPreviewSurface material's colours at the path's wavelengths (as reflectances) when it
  /// carries a spectrum. Only the lobes' colours: subsurface and absorption have their own.
  MaterialParams surfaceColours(const MaterialParams& authored) const {
    MaterialParams material = authored;
    if (!spectral) return material;
    material.specularColor = reflectance(material.specularColor);
    material.diffuseColor = reflectance(material.diffuseColor);
    if (material.sheen > 0) material.sheenColor = reflectance(material.sheenColor);
    if (material.clearcoat > 0) material.clearcoatColor = reflectance(material.clearcoatColor);
    return material;
  }
};

}  // namespace penumbra
