// A field of a volume (density, temperature, colour, …): values in the volume's object space,
// sampled trilinearly between voxel centres. Two kinds: a constant (homogeneous media), and
// sparse voxel grids read from OpenVDB files (vdb_field.h). Plain data only; no USD.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "penumbra/math.h"

namespace penumbra {

/// An axis-aligned box; empty (lower > upper) by default.
struct Bounds3f {
  Vec3f lower{kInfinity, kInfinity, kInfinity};
  Vec3f upper{-kInfinity, -kInfinity, -kInfinity};

  bool empty() const { return lower.x > upper.x || lower.y > upper.y || lower.z > upper.z; }
  void extend(const Vec3f& point) {
    lower = componentMin(lower, point);
    upper = componentMax(upper, point);
  }
  void extend(const Bounds3f& other) {
    lower = componentMin(lower, other.lower);
    upper = componentMax(upper, other.upper);
  }
  bool contains(const Vec3f& p) const {
    return p.x >= lower.x && p.x <= upper.x && p.y >= lower.y && p.y <= upper.y && p.z >= lower.z &&
           p.z <= upper.z;
  }
};

/// The common part of two boxes (empty when they do not meet).
inline Bounds3f intersection(const Bounds3f& a, const Bounds3f& b) {
  return {componentMax(a.lower, b.lower), componentMin(a.upper, b.upper)};
}

class VolumeField {
 public:
  virtual ~VolumeField() = default;

  /// Components per value: 1 (a scalar: density, temperature) or 3 (a colour or vector).
  virtual int components() const = 0;
  /// The value at `objectPoint`: components() floats, trilinear between voxel centres and 0
  /// outside the grid's active voxels (and their one-voxel trilinear fringe). Finite, and not
  /// negative for scalars.
  virtual void sample(const Vec3f& objectPoint, float* value) const = 0;
  /// Where sample() may be non-zero, in object space; unbounded for a constant.
  virtual Bounds3f objectBounds() const = 0;
  /// An upper bound of every component of sample() anywhere in `objectBox` (majorants).
  virtual float maxIn(const Bounds3f& objectBox) const = 0;
  /// Voxels that hold a value (0 for a constant).
  virtual uint64_t activeVoxels() const = 0;
  /// Bytes it holds.
  virtual size_t memoryBytes() const = 0;
};

/// A field of the same value everywhere (`components` of `value`'s: 1 takes value.x).
std::shared_ptr<const VolumeField> constantField(const Vec3f& value, int components = 1);

}  // namespace penumbra
