// Bitwise equality of arrays, for deciding whether an edit left a shape's traced surface as it
// was (Shape::tracesAs).
#pragma once

#include <cstring>
#include <type_traits>
#include <vector>

namespace penumbra {

template <typename T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
  static_assert(std::is_trivially_copyable_v<T>);
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

/// The same for arrays of arrays (motion steps).
template <typename T>
bool sameBits(const std::vector<std::vector<T>>& a, const std::vector<std::vector<T>>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!sameBits(a[i], b[i])) return false;
  return true;
}

}  // namespace penumbra
