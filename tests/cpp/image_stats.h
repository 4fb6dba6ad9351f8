// Statistics of the RGBA images the C++ render tests compare.
#pragma once

#include <cstddef>
#include <vector>

namespace penumbra::test {

/// Mean of the red channel of an RGBA image.
inline double meanRed(const std::vector<float>& rgba) {
  double sum = 0;
  for (size_t i = 0; i < rgba.size(); i += 4) sum += rgba[i];
  return sum / double(rgba.size() / 4);
}

/// Mean squared difference of the red channel of two RGBA images (of two seeds' renders: twice
/// the variance of one).
inline double redSquaredDifference(const std::vector<float>& a, const std::vector<float>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); i += 4) sum += double(a[i] - b[i]) * double(a[i] - b[i]);
  return sum / double(a.size() / 4);
}

}  // namespace penumbra::test
