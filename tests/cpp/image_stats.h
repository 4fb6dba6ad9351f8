// Statistics and crops of the images the C++ render tests compare.
#pragma once

#include <cstddef>
#include <vector>

#include "penumbra/film.h"

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

/// The pixels `crop` of a row-major image `width` pixels wide with `channels` per pixel.
inline std::vector<float> cropOf(const std::vector<float>& image, int width, int channels,
                                 const PixelRect& crop) {
  std::vector<float> result;
  for (int y = crop.y; y < crop.y + crop.height; ++y) {
    const auto row = image.begin() + std::ptrdiff_t((size_t(y) * size_t(width) + size_t(crop.x)) *
                                                    size_t(channels));
    result.insert(result.end(), row, row + std::ptrdiff_t(crop.width * channels));
  }
  return result;
}

}  // namespace penumbra::test
