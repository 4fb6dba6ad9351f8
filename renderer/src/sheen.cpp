#include "sheen.h"

#include <algorithm>
#include <cmath>

namespace penumbra {

SheenTables::SheenTables() {
  for (int row = 0; row < kSize; ++row) {
    const float alpha = rowAlpha(row);
    for (int column = 0; column < kSize; ++column)
      projectedArea_[row * kSize + column] = integrateProjectedArea(columnCosine(column), alpha);
  }
  for (int row = 0; row < kSize; ++row) {
    const float alpha = rowAlpha(row);
    for (int column = 0; column < kSize; ++column) {
      const float cosThetaO = columnCosine(column);
      const Vec3f wo(std::sqrt(1 - cosThetaO * cosThetaO), 0, cosThetaO);
      const float lambdaO = lambda(cosThetaO, alpha);
      double sum = 0;
      for (int i = 0; i < kCosines; ++i) {
        const float z = (float(i) + 0.5f) / kCosines;
        const float radius = std::sqrt(1 - z * z);
        const float lambdaI = lambda(z, alpha);
        for (int j = 0; j < kAzimuths; ++j) {
          const float phi = kPi * (float(j) + 0.5f) / kAzimuths;
          const Vec3f wi(radius * std::cos(phi), radius * std::sin(phi), z);
          sum += reflection(wo, wi, alpha, lambdaO, lambdaI);
        }
      }
      // dωi = d(cos θi) dφ, doubled for φ in [π, 2π].
      albedo_[row * kSize + column] = float(sum * 2 * kPi / (double(kCosines) * kAzimuths));
    }
  }
}

float SheenTables::integrateProjectedArea(float cosTheta, float alpha) {
  const double sinTheta = std::sqrt(std::max(0.0, 1.0 - double(cosTheta) * cosTheta));
  double sum = 0;
  for (int k = 0; k < kAreaSteps; ++k) {
    const double z = (k + 0.5) / kAreaSteps;
    const double a = sinTheta * std::sqrt(1 - z * z), b = cosTheta * z;
    double arc;
    if (b >= a) {
      arc = 2 * kPi * b;
    } else {
      const double phi0 = std::acos(-b / a);
      arc = 2 * (a * std::sin(phi0) + b * phi0);
    }
    sum += arc * charlieDensity(float(z), alpha);
  }
  return float(sum / kAreaSteps);
}

}  // namespace penumbra
