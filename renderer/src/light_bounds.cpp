// LightBounds: what a group of local lights can contribute to a receiver, for the light tree.
#include "penumbra/light.h"

namespace penumbra {

namespace {

/// cos(max(0, a - b)) from the cosines and sines of angles a, b in [0, π].
float cosOfClampedDifference(float cosA, float sinA, float cosB, float sinB) {
  if (cosA >= cosB) return 1;  // a <= b
  return cosA * cosB + sinA * sinB;
}

float sinOfClampedDifference(float cosA, float sinA, float cosB, float sinB) {
  if (cosA >= cosB) return 0;
  return sinA * cosB - cosA * sinB;
}

float sineOf(float cosine) {
  return std::sqrt(std::max(0.0f, 1 - cosine * cosine));
}

}  // namespace

LightCluster::LightCluster(const LightBounds& bounds)
    : center(bounds.centroid()),
      halfDiagonal2(0.25f * dot(bounds.upper - bounds.lower, bounds.upper - bounds.lower)),
      power(bounds.power),
      axis(bounds.axis),
      cosThetaO(bounds.cosThetaO),
      sinThetaO(sineOf(bounds.cosThetaO)),
      cosThetaE(bounds.cosThetaE) {}

float LightCluster::importance(const Receiver& receiver) const {
  if (!(power > 0)) return 0;
  const Vec3f offset = receiver.position - center;
  const float offset2 = dot(offset, offset);
  // At the box's centre the direction is undefined and the bound below is NaN, that is 0.
  if (!(offset2 > 0)) return 0;
  // Inside or near the box the distance is unknown: bound it below by a quarter of its size.
  const float distance2 = std::max(offset2, 0.25f * halfDiagonal2);
  const Vec3f fromLights = offset / std::sqrt(offset2);
  // The box seen from the receiver lies within a cone of half-angle thetaB about `fromLights`.
  const float cosThetaB =
      offset2 > halfDiagonal2 ? std::sqrt(std::max(0.0f, 1 - halfDiagonal2 / distance2)) : -1.0f;
  const float sinThetaB = sineOf(cosThetaB);
  // The smallest angle between an emission axis and a direction to the receiver. Lights that
  // emit every way (thetaO = π) face the receiver whatever the direction.
  float cosEmission = 1;
  if (cosThetaO > -1) {
    const float cosThetaW = dot(axis, fromLights);
    const float sinThetaW = sineOf(cosThetaW);
    const float cosX = cosOfClampedDifference(cosThetaW, sinThetaW, cosThetaO, sinThetaO);
    const float sinX = sinOfClampedDifference(cosThetaW, sinThetaW, cosThetaO, sinThetaO);
    cosEmission = cosOfClampedDifference(cosX, sinX, cosThetaB, sinThetaB);
  }
  if (cosEmission <= cosThetaE) return 0;
  float result = power * cosEmission / distance2;
  if (!isBlack(receiver.normal)) {
    // The smallest incidence angle on the receiving surface (either side).
    const float cosIncidence = std::fabs(dot(fromLights, receiver.normal));
    result *= cosOfClampedDifference(cosIncidence, sineOf(cosIncidence), cosThetaB, sinThetaB);
  }
  return std::max(0.0f, result);
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
