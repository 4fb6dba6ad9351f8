#include "penumbra/spectrum.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "penumbra/color.h"

namespace penumbra {
namespace {

using Mat3d = std::array<Vec3d, 3>;  // row-major

constexpr double kRange = double(kLambdaMax) - double(kLambdaMin);

Vec3d multiply(const Mat3d& m, const Vec3d& v) {
  Vec3d r{};
  for (size_t i = 0; i < 3; ++i) r[i] = m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2];
  return r;
}

Mat3d multiply(const Mat3d& a, const Mat3d& b) {
  Mat3d r{};
  for (size_t i = 0; i < 3; ++i)
    for (size_t j = 0; j < 3; ++j)
      for (size_t k = 0; k < 3; ++k) r[i][j] += a[i][k] * b[k][j];
  return r;
}

double determinant(const Mat3d& m) {
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
         m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

Mat3d inverse(const Mat3d& m) {
  const double invDet = 1 / determinant(m);
  Mat3d r{};
  for (size_t i = 0; i < 3; ++i)
    for (size_t j = 0; j < 3; ++j) {
      // Cofactor of m[j][i] (transposed: the adjugate).
      const size_t r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
      r[i][j] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) * invDet;
    }
  return r;
}

/// ∫ f over [kLambdaMin, kLambdaMax] by composite Simpson on 0.05 nm steps (the CMF fit's kinks
/// at its lobe centres limit it to about 1e-8 relative).
template <typename F>
Vec3d integrateFine(const F& f) {
  constexpr int kIntervals = 9400;
  const double h = kRange / kIntervals;
  Vec3d sum{};
  for (int i = 0; i <= kIntervals; ++i) {
    const double weight = (i == 0 || i == kIntervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const Vec3f v = f(float(double(kLambdaMin) + i * h));
    sum[0] += weight * v.x;
    sum[1] += weight * v.y;
    sum[2] += weight * v.z;
  }
  for (double& s : sum) s *= h / 3;
  return sum;
}

/// XYZ → rendering space (see spectrum.h): Bradford adaptation from E's white to the white of
/// xyzToLinearRec709, the Rec.709 matrix, then rows rescaled so that E maps to exactly (1, 1, 1).
std::array<float, 9> computeXyzToRenderingSpace() {
  const Vec3d whiteE = integrateFine(cieColorMatching);  // XYZ of the constant spectrum 1
  // xyzToLinearRec709 is linear: its matrix from the images of the unit vectors.
  Mat3d rec709{};
  for (size_t j = 0; j < 3; ++j) {
    const Vec3f column =
        xyzToLinearRec709({j == 0 ? 1.0f : 0.0f, j == 1 ? 1.0f : 0.0f, j == 2 ? 1.0f : 0.0f});
    rec709[0][j] = column.x;
    rec709[1][j] = column.y;
    rec709[2][j] = column.z;
  }
  const Vec3d whiteD65 = multiply(inverse(rec709), Vec3d{1, 1, 1});
  const Mat3d bradford{
      {{0.8951, 0.2664, -0.1614}, {-0.7502, 1.7135, 0.0367}, {0.0389, -0.0685, 1.0296}}};
  const Vec3d coneE = multiply(bradford, whiteE), coneD65 = multiply(bradford, whiteD65);
  Mat3d gain{};
  for (size_t i = 0; i < 3; ++i) gain[i][i] = coneD65[i] / coneE[i];
  // Adaptation maps whiteE to whiteD65, so E lands on (1, 1, 1) up to rounding; fix that exactly.
  Mat3d m = multiply(rec709, multiply(inverse(bradford), multiply(gain, bradford)));
  const Vec3d white = multiply(m, whiteE);
  std::array<float, 9> out{};
  for (size_t i = 0; i < 3; ++i)
    for (size_t j = 0; j < 3; ++j) out[i * 3 + j] = float(m[i][j] / white[i]);
  return out;
}

const std::array<float, 9>& xyzToRenderingSpace() {
  static const std::array<float, 9> matrix = computeXyzToRenderingSpace();
  return matrix;
}

// Visible-wavelength density p(λ) = a / (N cosh²(a (λ − λc))), N = tanh(a(max − λc)) − tanh(a(min
// − λc)).
constexpr double kPdfA = 0.0072, kPdfCenter = 538.0;

struct WavelengthCdf {
  double tanhMin, tanhMax;
};

const WavelengthCdf& wavelengthCdf() {
  static const WavelengthCdf cdf{std::tanh(kPdfA * (double(kLambdaMin) - kPdfCenter)),
                                 std::tanh(kPdfA * (double(kLambdaMax) - kPdfCenter))};
  return cdf;
}

// The sigmoid σ(x) = ½ + x/(2√(1+x²)) in a form without cancellation: for x < 0 it is
// h(x) = 1/(2 q (q + |x|)), q = √(1 + x²); for x ≥ 0 it is 1 − h(x). Exact 0 and 1 at ∓∞.
template <typename T>
T sigmoid(T x) {
  const T q = std::sqrt(1 + x * x);
  const T h = T(0.5) / (q * (q + std::fabs(x)));
  return x < 0 ? h : 1 - h;
}

/// σ⁻¹(s) for s in [0, 1]: ∓∞ at the ends.
double inverseSigmoid(double s) {
  if (s <= 0) return -INFINITY;
  if (s >= 1) return INFINITY;
  return (2 * s - 1) / (2 * std::sqrt(s * (1 - s)));
}

float sigmoidInverseF(float s) {
  return (2 * s - 1) / (2 * std::sqrt(s * (1 - s)));
}

// ---------------------------------------------------------------------------------------------
// Fitting.

/// The quadrature the fit integrates with: nodes t_j (normalised wavelength) and the weighted
/// rendering-space matching functions k_j, so that rgb(s) ≈ Σ_j s(t_j) k_j. Composite Simpson on
/// 2.5 nm steps (the round trip against the fine integral is checked by the tests).
struct FitQuadrature {
  static constexpr int kIntervals = 94;
  std::array<double, kIntervals + 1> t{};
  std::array<Vec3d, kIntervals + 1> k{};
};

FitQuadrature computeFitQuadrature() {
  FitQuadrature q;
  const double h = kRange / FitQuadrature::kIntervals;
  for (int i = 0; i <= FitQuadrature::kIntervals; ++i) {
    const double weight = (i == 0 || i == FitQuadrature::kIntervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const Vec3f m = renderingSpaceMatching(float(double(kLambdaMin) + i * h));
    q.t[size_t(i)] = double(i) / FitQuadrature::kIntervals;
    q.k[size_t(i)] = {m.x * weight * h / 3, m.y * weight * h / 3, m.z * weight * h / 3};
  }
  return q;
}

const FitQuadrature& fitQuadrature() {
  static const FitQuadrature quadrature = computeFitQuadrature();
  return quadrature;
}

/// rgb(c) − target into `residual`, and optionally the Jacobian ∂rgb/∂c. Returns max |residual|.
double fitResidual(const FitQuadrature& q, const Vec3d& c, const Vec3d& target, Vec3d& residual,
                   Mat3d* jacobian) {
  Vec3d rgb{};
  Mat3d j{};
  for (size_t i = 0; i < q.t.size(); ++i) {
    const double t = q.t[i];
    const double x = (c[0] * t + c[1]) * t + c[2];
    const double s = sigmoid(x);
    for (size_t a = 0; a < 3; ++a) rgb[a] += s * q.k[i][a];
    if (jacobian) {
      const double onePlus = 1 + x * x;
      const double ds = 0.5 / (onePlus * std::sqrt(onePlus));  // σ'(x)
      const Vec3d basis{ds * t * t, ds * t, ds};
      for (size_t a = 0; a < 3; ++a)
        for (size_t b = 0; b < 3; ++b) j[a][b] += basis[b] * q.k[i][a];
    }
  }
  double worst = 0;
  for (size_t a = 0; a < 3; ++a) {
    residual[a] = rgb[a] - target[a];
    worst = std::max(worst, std::fabs(residual[a]));
  }
  if (jacobian) *jacobian = j;
  return std::isfinite(worst) ? worst : INFINITY;
}

/// Newton's method on rgb(c) = target from `c`, with step halving when a step does not reduce the
/// residual. Returns the final max |residual|; `c` holds the best coefficients found.
double fitCoefficients(const Vec3d& target, Vec3d& c, int maxIterations) {
  // Relative to the colour, so that the dark end of the table is fitted as well as the rest.
  const double kTolerance = 1e-7 * std::max({target[0], target[1], target[2], 1e-3});
  const FitQuadrature& q = fitQuadrature();
  Vec3d residual{};
  Mat3d jacobian{};
  double error = fitResidual(q, c, target, residual, &jacobian);
  for (int iteration = 0; iteration < maxIterations && error > kTolerance; ++iteration) {
    const double det = determinant(jacobian);
    if (!(std::fabs(det) > 1e-300)) break;
    const Vec3d step = multiply(inverse(jacobian), residual);
    double length = 1;
    bool improved = false;
    for (int halving = 0; halving < 12; ++halving, length *= 0.5) {
      const Vec3d trial{c[0] - length * step[0], c[1] - length * step[1], c[2] - length * step[2]};
      Vec3d trialResidual{};
      Mat3d trialJacobian{};
      const double trialError = fitResidual(q, trial, target, trialResidual, &trialJacobian);
      if (trialError < error) {
        c = trial;
        residual = trialResidual;
        jacobian = trialJacobian;
        error = trialError;
        improved = true;
        break;
      }
    }
    if (!improved) break;
  }
  return error;
}

// ---------------------------------------------------------------------------------------------
// The coefficient table.

constexpr int kRes = 32;
/// Darkest colour (largest component) the table holds; darker ones are scaled copies of it.
constexpr double kZMin = 0.1;

struct UpsamplingTable {
  /// Values of the largest component at the z nodes: 1 − (1 − kZMin)(1 − i/kRes)³, from kZMin to
  /// 1 − 2.7e-5, clustered towards 1 where the coefficients grow without bound. Colours darker than
  /// kZMin are scaled copies: the model's dark spectra (σ ≈ 1/(4x²) far below ½) are too broad to
  /// reach saturated dark colours (a dark pure red or magenta stalls at errors ≈ z/2).
  std::array<float, kRes> z{};
  std::array<float, kRes> g{};  // σ⁻¹(z)
  /// Coefficients, indexed [largest component 0..2][z][y][x][c0, c1, c2].
  std::vector<float> coefficients;

  static size_t index(int component, int zi, int yi, int xi) {
    return 3 * (((size_t(component) * kRes + size_t(zi)) * kRes + size_t(yi)) * kRes + size_t(xi));
  }
};

/// The RGB a table node stands for: component `largest` is z, the next ones (cyclically) x·z, y·z.
Vec3d nodeColor(int largest, double z, double x, double y) {
  Vec3d rgb{};
  rgb[size_t(largest)] = z;
  rgb[size_t((largest + 1) % 3)] = x * z;
  rgb[size_t((largest + 2) % 3)] = y * z;
  return rgb;
}

UpsamplingTable buildUpsamplingTable() {
  UpsamplingTable table;
  for (size_t i = 0; i < kRes; ++i) {
    const double u = 1 - double(i) / kRes;
    table.z[i] = float(1 - (1 - kZMin) * u * u * u);
    table.g[i] = float(inverseSigmoid(table.z[i]));
  }
  table.coefficients.resize(UpsamplingTable::index(3, 0, 0, 0));
  fitQuadrature();  // built once, before the threads need it
  // Each task fits one row (one table, one y) for every x and z. It starts at x = 1 on the slice
  // nearest z = 0.5 from the exact grey, walks along x there warm-starting each node from its
  // neighbour, and from each node of that slice walks up and down in z, again warm-starting from
  // the neighbour: the coefficients change little between neighbours, Newton needs a few steps,
  // and the ill-conditioned slices near z = 1 are reached by continuation.
  const int startSlice =
      int(std::lower_bound(table.z.begin(), table.z.end(), 0.5f) - table.z.begin());
  tbb::parallel_for(0, 3 * kRes, [&table, startSlice](int task) {
    const int largest = task / kRes, yi = task % kRes;
    const double step = 1.0 / (kRes - 1);
    const auto store = [&table, largest, yi](int zi, int xi, const Vec3d& c) {
      float* out = &table.coefficients[UpsamplingTable::index(largest, zi, yi, xi)];
      for (size_t k = 0; k < 3; ++k) out[k] = float(std::clamp(c[k], -1e6, 1e6));
    };
    const auto fit = [&table, largest, yi, step](int zi, int xi, Vec3d& c) {
      const double z = table.z[size_t(zi)];
      fitCoefficients(nodeColor(largest, z, xi * step, yi * step), c, 30);
    };
    Vec3d start{0, 0, inverseSigmoid(table.z[size_t(startSlice)])};
    for (int xi = kRes - 1; xi >= 0; --xi) {
      fit(startSlice, xi, start);
      store(startSlice, xi, start);
      Vec3d c = start;
      for (int zi = startSlice + 1; zi < kRes; ++zi) {
        fit(zi, xi, c);
        store(zi, xi, c);
      }
      c = start;
      for (int zi = startSlice - 1; zi >= 0; --zi) {
        fit(zi, xi, c);
        store(zi, xi, c);
      }
    }
  });
  return table;
}

const UpsamplingTable& upsamplingTable() {
  static const UpsamplingTable table = buildUpsamplingTable();
  return table;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

Vec3f renderingSpaceMatching(float lambdaNm) {
  const std::array<float, 9>& m = xyzToRenderingSpace();
  const Vec3f xyz = cieColorMatching(lambdaNm);
  return {m[0] * xyz.x + m[1] * xyz.y + m[2] * xyz.z, m[3] * xyz.x + m[4] * xyz.y + m[5] * xyz.z,
          m[6] * xyz.x + m[7] * xyz.y + m[8] * xyz.z};
}

float visibleWavelengthPdf(float lambdaNm) {
  if (!(lambdaNm >= kLambdaMin && lambdaNm <= kLambdaMax)) return 0;
  const WavelengthCdf& cdf = wavelengthCdf();
  const double c = std::cosh(kPdfA * (double(lambdaNm) - kPdfCenter));
  return float(kPdfA / ((cdf.tanhMax - cdf.tanhMin) * c * c));
}

float sampleVisibleWavelength(float u) {
  const WavelengthCdf& cdf = wavelengthCdf();
  const double v = cdf.tanhMin + double(u) * (cdf.tanhMax - cdf.tanhMin);
  const double lambda = kPdfCenter + std::atanh(v) / kPdfA;
  return std::clamp(float(lambda), kLambdaMin, kLambdaMax);
}

SampledWavelengths sampleWavelengths(float u) {
  SampledWavelengths result;
  float lambda[3], pdf[3];
  for (int i = 0; i < 3; ++i) {
    float ui = u + float(i) / 3.0f;
    if (ui >= 1) ui -= 1;
    lambda[i] = sampleVisibleWavelength(ui);
    pdf[i] = visibleWavelengthPdf(lambda[i]);
  }
  result.lambda = {lambda[0], lambda[1], lambda[2]};
  result.pdf = {pdf[0], pdf[1], pdf[2]};
  return result;
}

Vec3f spectralToRgb(const Vec3f& radiance, const SampledWavelengths& wavelengths) {
  Vec3f sum(0.0f);
  int live = 0;
  for (int i = 0; i < 3; ++i) {
    const float pdf = wavelengths.pdf[i];
    if (!(pdf > 0)) continue;
    ++live;
    if (radiance[i] != 0)
      sum += renderingSpaceMatching(wavelengths.lambda[i]) * (radiance[i] / pdf);
  }
  return live > 0 ? sum / float(live) : Vec3f(0.0f);
}

float RgbSpectrum::at(float lambdaNm) const {
  if (scale_ == 0) return 0;
  const float t = (lambdaNm - kLambdaMin) * (1.0f / float(kRange));
  return scale_ * sigmoid((c0_ * t + c1_) * t + c2_);
}

RgbSpectrum RgbSpectrum::reflectance(const Vec3f& rgbIn) {
  const Vec3f rgb{std::max(rgbIn.x, 0.0f), std::max(rgbIn.y, 0.0f), std::max(rgbIn.z, 0.0f)};
  const float largestValue = maxComponent(rgb);
  if (!(largestValue > 0)) return {};  // black (or NaN input)
  if (largestValue > 1) return unbounded(rgb);
  if (rgb.x == rgb.y && rgb.y == rgb.z) return {0, 0, float(inverseSigmoid(rgb.x)), 1};

  const UpsamplingTable& table = upsamplingTable();
  const int largest = rgb.x == largestValue ? 0 : (rgb.y == largestValue ? 1 : 2);
  float z = largestValue;
  const float x = rgb[(largest + 1) % 3] / z, y = rgb[(largest + 2) % 3] / z;
  // Darker than the first node: the spectrum of the same chromaticity at the first node, scaled
  // (exact, the colour being linear in the spectrum).
  float scale = 1;
  if (z < table.z[0]) {
    scale = z / table.z[0];
    z = table.z[0];
  }
  z = std::min(z, table.z[kRes - 1]);  // brighter than the last node (1 − 2.5e-5): clamped
  const int zi = int(std::upper_bound(table.z.begin(), table.z.end() - 1, z) - table.z.begin()) - 1;
  const int z0 = std::clamp(zi, 0, kRes - 2);
  // Weights linear in σ⁻¹(z), in which the coefficients of a grey are linear (c2 = σ⁻¹(z)).
  const float tz =
      (sigmoidInverseF(z) - table.g[size_t(z0)]) / (table.g[size_t(z0) + 1] - table.g[size_t(z0)]);
  const float fx = x * (kRes - 1), fy = y * (kRes - 1);
  const int x0 = std::min(int(fx), kRes - 2), y0 = std::min(int(fy), kRes - 2);
  const float tx = fx - float(x0), ty = fy - float(y0);
  float c[3] = {0, 0, 0};
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = corner >> 2;
    const float weight = (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz);
    const float* node =
        &table.coefficients[UpsamplingTable::index(largest, z0 + dz, y0 + dy, x0 + dx)];
    for (int k = 0; k < 3; ++k) c[k] += weight * node[k];
  }
  return {c[0], c[1], c[2], scale};
}

RgbSpectrum RgbSpectrum::unbounded(const Vec3f& rgbIn) {
  const Vec3f rgb{std::max(rgbIn.x, 0.0f), std::max(rgbIn.y, 0.0f), std::max(rgbIn.z, 0.0f)};
  const float largestValue = maxComponent(rgb);
  if (!(largestValue > 0) || !std::isfinite(largestValue)) return {};
  const float scale = 2 * largestValue;
  RgbSpectrum spectrum = reflectance(rgb / scale);
  spectrum.scale_ *= scale;
  return spectrum;
}

RgbSpectrum RgbSpectrum::reflectanceExact(const Vec3f& rgb) {
  RgbSpectrum spectrum = reflectance(rgb);
  if (spectrum.scale_ == 0 || (spectrum.c0_ == 0 && spectrum.c1_ == 0)) return spectrum;  // grey
  const Vec3d target{std::max(rgb.x, 0.0f) / double(spectrum.scale_),
                     std::max(rgb.y, 0.0f) / double(spectrum.scale_),
                     std::max(rgb.z, 0.0f) / double(spectrum.scale_)};
  Vec3d c{spectrum.c0_, spectrum.c1_, spectrum.c2_};
  fitCoefficients(target, c, 30);
  return {float(c[0]), float(c[1]), float(c[2]), spectrum.scale_};
}

void prepareSpectralTables() {
  upsamplingTable();
}

}  // namespace penumbra
