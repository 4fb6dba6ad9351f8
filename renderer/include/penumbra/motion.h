// Motion over the shutter: transforms and points are sampled at K uniformly spaced times over the
// normalised shutter interval [0, 1] (the layout Embree's motion blur uses). Transforms are
// interpolated as translation, rotation and scale/shear separately, rotations by slerp, so that
// a turning object travels on an arc rather than on the chord between its keys.
#pragma once

#include <array>
#include <vector>

#include "penumbra/math.h"

namespace penumbra {

struct Quaternion {
  double w = 1, x = 0, y = 0, z = 0;
};

/// Spherical linear interpolation along the shorter arc.
Quaternion slerp(const Quaternion& a, const Quaternion& b, double t);

/// M = translate · rotate · scaleShear, with scaleShear upper triangular (column-vector form).
struct TransformDecomposition {
  std::array<double, 3> translation{0, 0, 0};
  Quaternion rotation;
  // Upper-triangular scale/shear: {xx, xy, xz, yy, yz, zz}. A mirroring transform has zz < 0.
  std::array<double, 6> scaleShear{1, 0, 0, 1, 0, 1};
};

TransformDecomposition decompose(const Transform& transform);
Transform compose(const TransformDecomposition& decomposition);
TransformDecomposition interpolate(const TransformDecomposition& a, const TransformDecomposition& b,
                                   double t);

/// Where a normalised time falls between uniformly spaced steps: step index and fraction.
struct StepPosition {
  size_t step;
  float fraction;
};
StepPosition locateStep(size_t stepCount, float time);

/// Point `index` of points sampled at uniformly spaced steps (`first` at step 0, `later` at
/// steps 1..K-1; empty: static) at normalised shutter time `time`, linearly between the steps
/// around it as Embree interpolates them.
inline Vec3f pointAtTime(const std::vector<Vec3f>& first,
                         const std::vector<std::vector<Vec3f>>& later, size_t index, float time) {
  if (later.empty()) return first[index];
  const StepPosition where = locateStep(later.size() + 1, time);
  const Vec3f& from = where.step == 0 ? first[index] : later[where.step - 1][index];
  const Vec3f& to = later[where.step][index];
  return from * (1 - where.fraction) + to * where.fraction;
}

/// A transform sampled at uniformly spaced times over the shutter (one step: static).
class MotionTransform {
 public:
  MotionTransform() : steps_{Transform()} {}
  MotionTransform(const Transform& transform) : steps_{transform} {}  // NOLINT: a static motion
  /// Throws std::invalid_argument when empty.
  explicit MotionTransform(std::vector<Transform> steps);

  bool isAnimated() const { return steps_.size() > 1; }
  const std::vector<Transform>& steps() const { return steps_; }
  /// The steps decomposed (empty when static), once here rather than on every lookup.
  const std::vector<TransformDecomposition>& decompositions() const { return decompositions_; }
  const Transform& first() const { return steps_.front(); }
  /// The transform at normalised shutter time `time` in [0, 1].
  Transform at(float time) const;

 private:
  std::vector<Transform> steps_;
  std::vector<TransformDecomposition> decompositions_;
};

}  // namespace penumbra
