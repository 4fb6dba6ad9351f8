// Colour science helpers: CIE 1931 observer and blackbody emission.
#pragma once

#include "penumbra/math.h"

namespace penumbra {

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at a wavelength in nanometres, from the
/// multi-lobe Gaussian fit of Wyman, Sloan & Shirley (JCGT 2013).
Vec3f cieColorMatching(float wavelengthNm);

/// Linear Rec.709 (D65) RGB of a CIE XYZ tristimulus.
Vec3f xyzToLinearRec709(const Vec3f& xyz);

/// Linear Rec.709 colour of a blackbody at `kelvin`, normalised to luminance 1 (UsdLux
/// colorTemperature). Temperatures are clamped to UsdLux's range [1000, 10000] K.
Vec3f blackbodyColor(float kelvin);

}  // namespace penumbra
