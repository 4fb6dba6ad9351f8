// A field of a volume (density, temperature, colour, …): values in the volume's object space,
// sampled trilinearly between voxel centres. Two kinds: a constant (homogeneous media), and
// sparse voxel grids read from OpenVDB files (vdb_field.h). Plain data only; no USD.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "penumbra/math.h"

namespace penumbra {

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
