// LightBounds: what a group of local lights can contribute to a receiver, for the light tree.
#include <cstdint>
#include <cstring>

#include "penumbra/light.h"

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace penumbra {

namespace {

// Four floats operated on lane by lane (GCC and Clang vector extensions: SSE on x86-64). Each
// lane does exactly the arithmetic a scalar evaluation would, in the same order, so the results
// do not depend on which lane or how many lanes are used.
typedef float Float4 __attribute__((vector_size(16)));
typedef int32_t Mask4 __attribute__((vector_size(16)));  // comparisons: -1 true, 0 false

Float4 broadcast(float x) {
  return Float4{x, x, x, x};
}

Float4 load(const float* lanes) {
  Float4 result;
  std::memcpy(&result, lanes, sizeof(result));
  return result;
}

Float4 select(Mask4 condition, Float4 ifTrue, Float4 ifFalse) {
  return condition ? ifTrue : ifFalse;
}

/// std::max's and std::min's lane-wise: the first argument unless the order says otherwise.
Float4 max(Float4 a, Float4 b) {
  return select(a < b, b, a);
}

Float4 squareRoot(Float4 x) {
#if defined(__SSE__)
  return _mm_sqrt_ps(x);
#else
  for (int lane = 0; lane < 4; ++lane) x[lane] = std::sqrt(x[lane]);
  return x;
#endif
}

Float4 absolute(Float4 x) {
  return Float4(Mask4(x) & Mask4{0x7fffffff, 0x7fffffff, 0x7fffffff, 0x7fffffff});
}

Float4 sineOf(Float4 cosine) {
  return squareRoot(max(broadcast(0), 1 - cosine * cosine));
}

/// cos(max(0, a - b)) from the cosines and sines of angles a, b in [0, π].
Float4 cosOfClampedDifference(Float4 cosA, Float4 sinA, Float4 cosB, Float4 sinB) {
  return select(cosA >= cosB, broadcast(1), cosA * cosB + sinA * sinB);
}

Float4 sinOfClampedDifference(Float4 cosA, Float4 sinA, Float4 cosB, Float4 sinB) {
  return select(cosA >= cosB, broadcast(0), sinA * cosB - cosA * sinB);
}

}  // namespace

void LightClusters::set(int lane, const LightBounds& bounds) {
  const Vec3f center = bounds.centroid();
  centerX_[lane] = center.x;
  centerY_[lane] = center.y;
  centerZ_[lane] = center.z;
  halfDiagonal2_[lane] = bounds.halfDiagonal2();
  power_[lane] = bounds.power;
  axisX_[lane] = bounds.axis.x;
  axisY_[lane] = bounds.axis.y;
  axisZ_[lane] = bounds.axis.z;
  cosThetaO_[lane] = bounds.cosThetaO;
  sinThetaO_[lane] = std::sqrt(std::max(0.0f, 1 - bounds.cosThetaO * bounds.cosThetaO));
  cosThetaE_[lane] = bounds.cosThetaE;
  omnidirectional_ = true;
  for (int k = 0; k < kLanes; ++k)
    omnidirectional_ = omnidirectional_ && (!(power_[k] > 0) || cosThetaO_[k] <= -1);
}

inline std::array<float, LightClusters::kLanes> LightClusters::evaluate(
    const Receiver& receiver) const {
  static_assert(kLanes == 4, "one Float4 holds the lanes");
  const Float4 halfDiagonal2 = load(halfDiagonal2_), power = load(power_);
  const Float4 offsetX = receiver.position.x - load(centerX_);
  const Float4 offsetY = receiver.position.y - load(centerY_);
  const Float4 offsetZ = receiver.position.z - load(centerZ_);
  const Float4 offset2 = offsetX * offsetX + offsetY * offsetY + offsetZ * offsetZ;
  // Inside or near the box the distance is unknown: bound it below by a quarter of its size.
  const Float4 distance2 = max(offset2, 0.25f * halfDiagonal2);
  const Float4 inverseDistance = 1.0f / squareRoot(offset2);
  const Float4 fromLightsX = offsetX * inverseDistance, fromLightsY = offsetY * inverseDistance,
               fromLightsZ = offsetZ * inverseDistance;
  // The box seen from the receiver lies within a cone of half-angle thetaB about `fromLights`.
  const Float4 cosThetaB =
      select(offset2 > halfDiagonal2, squareRoot(max(broadcast(0), 1 - halfDiagonal2 / distance2)),
             broadcast(-1));
  const Float4 sinThetaB = sineOf(cosThetaB);
  // The smallest angle between an emission axis and a direction to the receiver. Lights that
  // emit every way (thetaO = π) face the receiver whatever the direction; when every lane holds
  // such lights or none (its importance 0 whatever this is), the angles are not computed.
  Float4 cosEmission = broadcast(1);
  if (!omnidirectional_) {
    const Float4 cosThetaO = load(cosThetaO_), sinThetaO = load(sinThetaO_);
    const Float4 cosThetaW =
        load(axisX_) * fromLightsX + load(axisY_) * fromLightsY + load(axisZ_) * fromLightsZ;
    const Float4 sinThetaW = sineOf(cosThetaW);
    const Float4 cosX = cosOfClampedDifference(cosThetaW, sinThetaW, cosThetaO, sinThetaO);
    const Float4 sinX = sinOfClampedDifference(cosThetaW, sinThetaW, cosThetaO, sinThetaO);
    cosEmission = select(cosThetaO > -1.0f,
                         cosOfClampedDifference(cosX, sinX, cosThetaB, sinThetaB), broadcast(1));
  }
  Float4 result = power * cosEmission / distance2;
  if (!isBlack(receiver.normal)) {
    // The smallest incidence angle on the receiving surface (either side).
    const Float4 cosIncidence =
        absolute(fromLightsX * receiver.normal.x + fromLightsY * receiver.normal.y +
                 fromLightsZ * receiver.normal.z);
    result *= cosOfClampedDifference(cosIncidence, sineOf(cosIncidence), cosThetaB, sinThetaB);
  }
  // No lights; a receiver at the box's centre, where the direction is undefined; or beyond
  // every light's emission: 0.
  const Mask4 dark = ~(power > 0) | ~(offset2 > 0) | (cosEmission <= load(cosThetaE_));
  const Float4 lit = select(dark, broadcast(0), max(broadcast(0), result));
  return {lit[0], lit[1], lit[2], lit[3]};
}

std::array<float, LightClusters::kLanes> LightClusters::importance(const Receiver& receiver) const {
  return evaluate(receiver);
}

void LightClusters::importances(const LightClusters* const* clusters, size_t count,
                                const Receiver& receiver, std::array<float, kLanes>* out) {
  for (size_t i = 0; i < count; ++i) out[i] = clusters[i]->evaluate(receiver);
}

LightBounds unite(const LightBounds& a, const LightBounds& b) {
  if (!(a.power > 0) && a.lower.x > a.upper.x) return b;
  if (!(b.power > 0) && b.lower.x > b.upper.x) return a;
  LightBounds result;
  result.lower = componentMin(a.lower, b.lower);
  result.upper = componentMax(a.upper, b.upper);
  result.power = a.power + b.power;
  result.cosThetaE = std::min(a.cosThetaE, b.cosThetaE);
  // The cone of axes: the smallest cone holding both cones.
  const float thetaA = std::acos(std::clamp(a.cosThetaO, -1.0f, 1.0f));
  const float thetaB = std::acos(std::clamp(b.cosThetaO, -1.0f, 1.0f));
  const float between = std::acos(std::clamp(dot(a.axis, b.axis), -1.0f, 1.0f));
  result.axis = a.axis;
  result.cosThetaO = -1;
  if (std::min(between + thetaB, kPi) <= thetaA) {
    result.cosThetaO = a.cosThetaO;
  } else if (std::min(between + thetaA, kPi) <= thetaB) {
    result.axis = b.axis;
    result.cosThetaO = b.cosThetaO;
  } else {
    const float theta = 0.5f * (thetaA + between + thetaB);
    const Vec3f across = b.axis - a.axis * dot(a.axis, b.axis);
    if (theta < kPi && length(across) > 1e-6f) {
      // Turn a's axis towards b's by the part of the new half-angle a's cone does not cover.
      const float turn = theta - thetaA;
      result.axis = normalize(a.axis * std::cos(turn) + normalize(across) * std::sin(turn));
      result.cosThetaO = std::cos(theta);
    }
  }
  return result;
}

}  // namespace penumbra
