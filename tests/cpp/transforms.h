// Transforms the C++ tests place things with (USD's row-vector convention).
#pragma once

#include <cmath>

#include "penumbra/math.h"

namespace penumbra::test {

inline Transform translation(double x, double y, double z) {
  const double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, y, z, 1};
  return Transform::fromRowMajor(m);
}

/// Local -Z onto world -Y, then a translation: cameras looking down, lights facing down.
inline Transform facingDown(double x, double y, double z) {
  const double m[16] = {1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, x, y, z, 1};
  return Transform::fromRowMajor(m);
}

/// A turn of `degrees` about Z, local -Z onto world +Z (a half turn about Y), then a
/// translation: lights facing a camera at the origin that looks down -Z.
inline Transform facingBack(double x, double y, double z, double degrees = 0) {
  const double c = std::cos(degrees * 3.14159265358979323846 / 180);
  const double s = std::sin(degrees * 3.14159265358979323846 / 180);
  const double m[16] = {-c, s, 0, 0, s, c, 0, 0, 0, 0, -1, 0, x, y, z, 1};
  return Transform::fromRowMajor(m);
}

}  // namespace penumbra::test
