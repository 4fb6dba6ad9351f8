// Transforms the C++ tests place things with (USD's row-vector convention).
#pragma once

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

}  // namespace penumbra::test
