#include "penumbra/hair_bsdf.h"

#include <algorithm>
#include <cmath>

#include "microfacet.h"

namespace penumbra {
namespace {

constexpr double kLn2 = 0.69314718055994530942;
constexpr float kTwoPi = 2 * kPi;

/// `value` within [low, high]; NaN becomes `low`.
float clampOrLow(float value, float low, float high) {
  return value > low ? (value < high ? value : high) : low;
}

/// Components at least 0; NaN becomes 0.
Vec3f nonNegative(const Vec3f& v) {
  return {clampOrLow(v.x, 0, kInfinity), clampOrLow(v.y, 0, kInfinity),
          clampOrLow(v.z, 0, kInfinity)};
}

/// The modified Bessel function I0 by its power series Σ (x²/4)^k / (k!)², for x ≤ 30.
double besselI0(double x) {
  const double quarterSquare = 0.25 * x * x;
  double term = 1, sum = 1;
  for (int k = 1; term > 1e-17 * sum; ++k) {
    term *= quarterSquare / (double(k) * double(k));
    sum += term;
  }
  return sum;
}

/// ln I0(x); above 30, the asymptotic series e^x/√(2πx)·(1 + 1/(8x) + 9/(128x²) + 225/(3072x³))
/// (relative error below 2e-7), as I0 overflows doubles beyond x ≈ 713.
double logBesselI0(double x) {
  if (x <= 30) return std::log(besselI0(x));
  const double inverse = 1 / x;
  const double series = 1 + inverse * (1.0 / 8 + inverse * (9.0 / 128 + inverse * (225.0 / 3072)));
  return x - 0.5 * std::log(2 * double(kPi) * x) + std::log(series);
}

/// The logistic distribution of scale s, its CDF, and the logistic trimmed to [−π, π].
float logistic(float x, float s) {
  const float e = std::exp(-std::fabs(x) / s);
  return e / (s * (1 + e) * (1 + e));
}
float logisticCdf(float x, float s) {
  return 1 / (1 + std::exp(-x / s));
}
float trimmedLogistic(float x, float s) {
  return logistic(x, s) / (logisticCdf(kPi, s) - logisticCdf(-kPi, s));
}
/// Inverts the trimmed logistic's CDF at u ∈ [0, 1].
float sampleTrimmedLogistic(float u, float s) {
  const float low = logisticCdf(-kPi, s);
  const float k = logisticCdf(kPi, s) - low;
  const float x = -s * std::log(1 / (u * k + low) - 1);
  return clampOrLow(x, -kPi, kPi);
}

/// The ideal exit azimuth of lobe p relative to φo.
float exitAzimuth(int p, float gammaO, float gammaT) {
  return 2 * float(p) * gammaT - 2 * gammaO + float(p) * kPi;
}

/// The frame with x along the fibre and z the normal made perpendicular to it (any
/// perpendicular where the normal lies along the fibre).
Frame fibreFrame(const Vec3f& fibreDirection, const Vec3f& normal, const Vec3f& shadingNormal) {
  const float fibreLength = length(fibreDirection);
  const bool isFibre = fibreLength > 0 && std::isfinite(fibreLength);
  const Vec3f along = isFibre ? fibreDirection / fibreLength : Frame(shadingNormal).s;
  const Vec3f across = isFibre ? normal : shadingNormal;
  const Vec3f perpendicular = across - along * dot(across, along);
  const float perpendicularLength = length(perpendicular);
  Frame frame(perpendicularLength > 1e-6f ? perpendicular / perpendicularLength : Frame(along).s);
  frame.s = along;
  frame.t = cross(frame.n, along);
  return frame;
}

/// Chiang et al.'s fit of √σa·(this) = −ln c against β_n (eq. 9).
float colorFitDenominator(float azimuthalRoughness) {
  const float b = azimuthalRoughness;
  const float b2 = b * b, b4 = b2 * b2;
  return 5.969f - 0.215f * b + 2.532f * b2 - 10.73f * b2 * b + 5.574f * b4 + 0.245f * b4 * b;
}

}  // namespace

Vec3f hairAbsorptionFromColor(const Vec3f& color, float azimuthalRoughness) {
  const float denominator = colorFitDenominator(azimuthalRoughness);
  const auto channel = [&](float c) {
    return square(std::log(clampOrLow(c, 0.001f, 1)) / denominator);
  };
  return {channel(color.x), channel(color.y), channel(color.z)};
}

Vec3f hairColorFromAbsorption(const Vec3f& absorption, float azimuthalRoughness) {
  const float denominator = colorFitDenominator(azimuthalRoughness);
  const auto channel = [&](float a) {
    return std::exp(-std::sqrt(clampOrLow(a, 0, kInfinity)) * denominator);
  };
  return {channel(absorption.x), channel(absorption.y), channel(absorption.z)};
}

Vec3f hairAbsorptionFromMelanin(float concentration, float redness, const Vec3f& eumelaninColor,
                                const Vec3f& pheomelaninColor) {
  const float melanin = -std::log(std::max(1 - concentration, 1e-4f));
  const float eumelanin = melanin * (1 - redness);
  const float pheomelanin = melanin * redness;
  const auto absorption = [](float c) { return -std::log(std::max(c, 1e-30f)); };
  return nonNegative(Vec3f(absorption(eumelaninColor.x), absorption(eumelaninColor.y),
                           absorption(eumelaninColor.z)) *
                         eumelanin +
                     Vec3f(absorption(pheomelaninColor.x), absorption(pheomelaninColor.y),
                           absorption(pheomelaninColor.z)) *
                         pheomelanin);
}

namespace {

/// β_n a material's colour is converted with (MaterialParams::hairColorAzimuthalRoughness).
float colorAzimuthalRoughness(const MaterialParams& material) {
  return material.hairColorAzimuthalRoughness >= 0 ? material.hairColorAzimuthalRoughness
                                                   : material.hairAzimuthalRoughness;
}

}  // namespace

Vec3f hairAbsorptionAt(const MaterialParams& material) {
  if (material.hairAbsorptionFromColor)
    return hairAbsorptionFromColor(material.hairColor, colorAzimuthalRoughness(material));
  if (material.hairAbsorptionFromMelanin)
    return hairAbsorptionFromMelanin(material.hairMelanin, material.hairMelaninRedness);
  return material.hairAbsorption;
}

Vec3f hairColorAt(const MaterialParams& material) {
  const float roughness = material.hairAbsorptionFromColor ? colorAzimuthalRoughness(material)
                                                           : material.hairAzimuthalRoughness;
  return hairColorFromAbsorption(hairAbsorptionAt(material), roughness);
}

float hairLongitudinalVariance(float b) {
  return square(0.726f * b + 0.812f * b * b + 3.7f * std::pow(b, 20.0f));
}

float hairAzimuthalScale(float b) {
  constexpr float kSqrtPiOver8 = 0.626657069f;
  return kSqrtPiOver8 * (0.265f * b + 1.194f * b * b + 5.372f * std::pow(b, 22.0f));
}

float hairLongitudinalScattering(float sinThetaI, float cosThetaI, float sinThetaO, float cosThetaO,
                                 float variance) {
  const double v = variance;
  const double a = double(cosThetaI) * cosThetaO / v;
  const double b = double(sinThetaI) * sinThetaO / v;
  // csch(1/v)/(2v)·e^(−b)·I0(a); for small v, sinh(1/v) ≈ e^(1/v)/2 and both factors overflow:
  // their logarithms are combined instead.
  if (v <= 0.1) return float(std::exp(logBesselI0(a) - b - 1 / v + kLn2 - std::log(2 * v)));
  return float(std::exp(-b) * besselI0(a) / (2 * v * std::sinh(1 / v)));
}

HairBsdf::HairBsdf(const MaterialParams& material, const Vec3f& fibreDirection, const Vec3f& normal,
                   const Vec3f& shadingNormal)
    : frame_(fibreFrame(fibreDirection, normal, shadingNormal)),
      sideNormal_(normal),
      eta_(clampOrLow(material.hairIor, 1, kInfinity)),
      absorption_(nonNegative(material.hairAbsorption)),
      tints_{nonNegative(material.hairTintR), nonNegative(material.hairTintTT),
             nonNegative(material.hairTintTRT)} {
  const float betaM = clampOrLow(material.hairLongitudinalRoughness, kMinRoughness, 1);
  const float betaN = clampOrLow(material.hairAzimuthalRoughness, kMinRoughness, 1);
  const float minVariance = hairLongitudinalVariance(kMinRoughness);
  const float variance = hairLongitudinalVariance(betaM);
  variance_[0] = variance;
  variance_[1] = std::max(variance * square(material.hairLongitudinalScaleTT), minVariance);
  variance_[2] = std::max(variance * square(material.hairLongitudinalScaleTRT), minVariance);
  if (!(variance_[1] < kInfinity)) variance_[1] = variance;  // NaN or infinite scale
  if (!(variance_[2] < kInfinity)) variance_[2] = variance;
  variance_[3] = variance_[2];
  const float minScale = hairAzimuthalScale(kMinRoughness);
  const float scale = hairAzimuthalScale(betaN);
  logisticScale_ = {scale, clampOrLow(scale * material.hairAzimuthalScaleTT, minScale, kInfinity),
                    clampOrLow(scale * material.hairAzimuthalScaleTRT, minScale, kInfinity)};
  for (float& s : logisticScale_)
    if (!(s < kInfinity)) s = scale;
  const float alpha =
      std::isfinite(material.hairCuticleAngle) ? material.hairCuticleAngle * (kPi / 180) : 0.0f;
  sin2kAlpha_[0] = std::sin(alpha);
  cos2kAlpha_[0] = std::cos(alpha);
  for (int k = 1; k < 3; ++k) {
    sin2kAlpha_[k] = 2 * cos2kAlpha_[k - 1] * sin2kAlpha_[k - 1];
    cos2kAlpha_[k] = square(cos2kAlpha_[k - 1]) - square(sin2kAlpha_[k - 1]);
  }
}

HairBsdf::Outgoing HairBsdf::outgoing(const Vec3f& wo) const {
  Outgoing o;
  o.sinThetaO = clampOrLow(wo.x, -1, 1);
  o.cosThetaO = std::sqrt(std::max(0.0f, 1 - square(o.sinThetaO)));
  o.phiO = std::atan2(wo.z, wo.y);
  // h = sin(φo − φn), φn being the azimuth of the normal turned towards wo (±π/2 here).
  const float across = std::sqrt(wo.y * wo.y + wo.z * wo.z);
  const float h = across > 0 ? clampOrLow(-std::copysign(1.0f, wo.z) * wo.y / across, -1, 1) : 0;
  o.gammaO = std::asin(h);
  const float cosGammaO = std::sqrt(std::max(0.0f, 1 - h * h));

  // The refracted ray's longitudinal angle and, in the azimuthal plane, Bravais' index η'.
  const float sinThetaT = o.sinThetaO / eta_;
  const float cosThetaT = std::sqrt(std::max(0.0f, 1 - square(sinThetaT)));
  const float etaPrime =
      std::sqrt(std::max(0.0f, eta_ * eta_ - square(o.sinThetaO))) / std::max(o.cosThetaO, 1e-7f);
  const float sinGammaT = clampOrLow(h / etaPrime, -1, 1);
  const float cosGammaT = std::sqrt(std::max(0.0f, 1 - square(sinGammaT)));
  o.gammaT = std::asin(sinGammaT);

  // One crossing of the interior, of length 2 cos γt / cos θt (radius 1).
  const float pathLength = 2 * cosGammaT / cosThetaT;
  const Vec3f transmittance{std::exp(-absorption_.x * pathLength),
                            std::exp(-absorption_.y * pathLength),
                            std::exp(-absorption_.z * pathLength)};
  const float f = fresnelDielectric(o.cosThetaO * cosGammaO, eta_);
  std::array<Vec3f, kLobes> a;
  a[0] = Vec3f(f);
  a[1] = transmittance * square(1 - f);
  a[2] = a[1] * transmittance * f;
  const Vec3f loss = Vec3f(1.0f) - transmittance * f;  // the residual's geometric series
  const auto remainder = [](float value, float denominator) {
    return denominator > 0 ? value / denominator : 0.0f;
  };
  const Vec3f tail = a[2] * transmittance * f;
  a[3] = {remainder(tail.x, loss.x), remainder(tail.y, loss.y), remainder(tail.z, loss.z)};

  float total = 0;
  for (int p = 0; p < kLobes; ++p) {
    o.attenuation[size_t(p)] = a[size_t(p)] * tints_[size_t(std::min(p, 2))];
    o.probability[size_t(p)] = average(o.attenuation[size_t(p)]);
    total += o.probability[size_t(p)];
  }
  for (float& probability : o.probability) probability = total > 0 ? probability / total : 0.0f;

  // The cuticle's tilt: R's lobe turns by −2α, TT's by α, TRT's by 4α (pbrt-v4).
  const float s = o.sinThetaO, c = o.cosThetaO;
  o.sinThetaTilted = {s * cos2kAlpha_[1] - c * sin2kAlpha_[1],
                      s * cos2kAlpha_[0] + c * sin2kAlpha_[0],
                      s * cos2kAlpha_[2] + c * sin2kAlpha_[2], s};
  o.cosThetaTilted = {std::fabs(c * cos2kAlpha_[1] + s * sin2kAlpha_[1]),
                      std::fabs(c * cos2kAlpha_[0] - s * sin2kAlpha_[0]),
                      std::fabs(c * cos2kAlpha_[2] - s * sin2kAlpha_[2]), c};
  return o;
}

float HairBsdf::azimuthal(int lobe, float phi, const Outgoing& o) const {
  if (lobe == kLobes - 1) return 1 / kTwoPi;
  float offset = phi - exitAzimuth(lobe, o.gammaO, o.gammaT);
  offset -= kTwoPi * std::round(offset / kTwoPi);
  return trimmedLogistic(offset, logisticScale_[size_t(lobe)]);
}

Vec3f HairBsdf::sum(const Outgoing& o, const Vec3f& wi, bool probabilities) const {
  const float sinThetaI = clampOrLow(wi.x, -1, 1);
  const float cosThetaI = std::sqrt(std::max(0.0f, 1 - square(sinThetaI)));
  const float phi = std::atan2(wi.z, wi.y) - o.phiO;
  Vec3f total{0.0f};
  for (int p = 0; p < kLobes; ++p) {
    const size_t i = size_t(p);
    const float weight = probabilities ? o.probability[i] : maxComponent(o.attenuation[i]);
    if (weight <= 0) continue;
    const float lobe = hairLongitudinalScattering(sinThetaI, cosThetaI, o.sinThetaTilted[i],
                                                  o.cosThetaTilted[i], variance_[i]) *
                       azimuthal(p, phi, o);
    total += probabilities ? Vec3f(o.probability[i] * lobe) : o.attenuation[i] * lobe;
  }
  return total;
}

Vec3f HairBsdf::evaluate(const Vec3f& wo, const Vec3f& wi, Vec3f* diffusePart) const {
  if (diffusePart) *diffusePart = Vec3f(0.0f);
  return sum(outgoing(frame_.toLocal(wo)), frame_.toLocal(wi), false);
}

float HairBsdf::pdf(const Vec3f& wo, const Vec3f& wi) const {
  return sum(outgoing(frame_.toLocal(wo)), frame_.toLocal(wi), true).x;
}

std::optional<BsdfSample> HairBsdf::sample(const Vec3f& wo, float uLobe, Vec2f u) const {
  const Outgoing o = outgoing(frame_.toLocal(wo));
  int p = 0;
  float below = 0;  // the probability of the lobes before p
  while (p < kLobes - 1 && uLobe >= below + o.probability[size_t(p)]) {
    below += o.probability[size_t(p)];
    ++p;
  }
  const size_t i = size_t(p);
  if (o.probability[i] <= 0) return std::nullopt;
  const float uAzimuth = clampOrLow((uLobe - below) / o.probability[i], 0, 0x1.fffffep-1f);

  // θi from M_p: cos of the angle to the lobe's axis (−θo tilted) by d'Eon et al.'s inversion,
  // then turned about that axis.
  const double v = variance_[i];
  const double uCone = std::max(double(u.x), 1e-5);
  const float cosCone = float(1 + v * std::log(uCone + (1 - uCone) * std::exp(-2 / v)));
  const float sinCone = std::sqrt(std::max(0.0f, 1 - square(cosCone)));
  const float sinThetaI = clampOrLow(
      -cosCone * o.sinThetaTilted[i] + sinCone * std::cos(kTwoPi * u.y) * o.cosThetaTilted[i], -1,
      1);
  const float cosThetaI = std::sqrt(std::max(0.0f, 1 - square(sinThetaI)));
  const float phi = p < kLobes - 1 ? exitAzimuth(p, o.gammaO, o.gammaT) +
                                         sampleTrimmedLogistic(uAzimuth, logisticScale_[i])
                                   : kTwoPi * uAzimuth;
  const float phiI = o.phiO + phi;
  const Vec3f wiLocal{sinThetaI, cosThetaI * std::cos(phiI), cosThetaI * std::sin(phiI)};

  BsdfSample result;
  result.pdf = sum(o, wiLocal, true).x;
  if (!(result.pdf > 0)) return std::nullopt;
  result.direction = normalize(frame_.toWorld(wiLocal));
  result.weight = sum(o, wiLocal, false) / result.pdf;
  result.lobe = p == 1 ? BsdfLobe::Transmission : BsdfLobe::Glossy;
  result.isDelta = false;
  result.transmitted = dot(result.direction, sideNormal_) * dot(wo, sideNormal_) < 0;
  return result;
}

}  // namespace penumbra
