#include "penumbra/volume.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "penumbra/spectrum.h"

namespace penumbra {
namespace {

bool finiteNonNegative(const Vec3f& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && v.x >= 0 && v.y >= 0 &&
         v.z >= 0;
}

bool finiteNonNegative(float v) {
  return std::isfinite(v) && v >= 0;
}

/// The colour of a blackbody at `kelvin`, with a luminance of 1 (a table over 0–20,000 K built
/// once from Planck's law and the rendering space's colour-matching functions).
Vec3f blackbodyColor(float kelvin) {
  constexpr int kSteps = 400;
  constexpr float kMaxKelvin = 20000, kStepKelvin = kMaxKelvin / kSteps;
  static const std::array<Vec3f, kSteps + 1> table = [] {
    std::array<Vec3f, kSteps + 1> colors{};
    for (int i = 0; i <= kSteps; ++i) {
      // Below 400 K a blackbody is invisible in float precision: keep 400 K's hue.
      const double t = std::max(400.0, double(i) * kStepKelvin);
      Vec3f sum{0.0f};
      for (float lambda = kLambdaMin; lambda <= kLambdaMax; lambda += 1) {
        const double metres = double(lambda) * 1e-9;
        // Planck's law up to a constant factor, which the normalisation removes.
        const double radiance =
            1 / (std::pow(metres, 5) * (std::exp(0.0143877687750393 / (metres * t)) - 1));
        sum += renderingSpaceMatching(lambda) * float(radiance * 1e-30);
      }
      const float y = luminance(sum);
      colors[size_t(i)] = y > 0 ? sum / y : Vec3f(1.0f);
    }
    return colors;
  }();
  const float position = std::clamp(kelvin / kStepKelvin, 0.0f, float(kSteps));
  const int below = std::min(int(position), kSteps - 1);
  const float f = position - float(below);
  return table[size_t(below)] * (1 - f) + table[size_t(below + 1)] * f;
}

/// Hottest temperature emission follows (kelvin): T⁴ beyond it would overflow a float.
constexpr float kMaxKelvin = 1e6f;

/// Radiance per unit length that a blackbody at `kelvin` (at most kMaxKelvin) adds at intensity
/// 1 (Cycles' convention: σ_SB T⁴ · 10⁻⁶ / π).
float blackbodyStrength(float kelvin) {
  constexpr float kStefanBoltzmann = 5.670373e-8f;
  const float t2 = std::min(kelvin, kMaxKelvin) * std::min(kelvin, kMaxKelvin);
  return kStefanBoltzmann * 1e-6f * kInvPi * t2 * t2;
}

float scalarAt(const std::shared_ptr<const VolumeField>& field, const Vec3f& p) {
  if (!field) return 1;
  float value = 0;
  field->sample(p, &value);
  return value;
}

Vec3f colorAt(const std::shared_ptr<const VolumeField>& field, const Vec3f& p) {
  if (!field) return Vec3f(1.0f);
  float value[3] = {0, 0, 0};
  field->sample(p, value);
  return field->components() == 1 ? Vec3f(value[0]) : Vec3f(value[0], value[1], value[2]);
}

float maxOver(const std::shared_ptr<const VolumeField>& field, const Bounds3f& box) {
  return field ? field->maxIn(box) : 1.0f;
}

/// The largest σs + σa component over colour-field values in [0, colorMax] per unit density:
/// s·c + a + p·max(1 − s·c, 0) is convex in c, so its largest value is at an end.
float extinctionPerDensity(const VolumeMaterial& m, float colorMax) {
  float largest = 0;
  for (int ch = 0; ch < 3; ++ch)
    for (const float c : {0.0f, colorMax}) {
      const float scattered = m.scattering[ch] * c;
      largest = std::max(largest, scattered + m.absorption[ch] +
                                      m.principledAbsorption[ch] * std::max(1 - scattered, 0.0f));
    }
  return largest;
}

/// Cells of the majorant grid along each axis: one for media without grids, else up to 32
/// along the longest side of the bounds, as square as the bounds allow.
std::array<int, 3> majorantResolution(const VolumeData& data, const Vec3f& extent) {
  bool gridded = false;
  for (const auto* field : {&data.density, &data.color, &data.temperature, &data.emission})
    gridded |= *field && (*field)->activeVoxels() > 0;
  if (!gridded) return {1, 1, 1};
  constexpr int kLongestSide = 32;
  const float longest = maxComponent(extent);
  std::array<int, 3> cells{};
  for (int axis = 0; axis < 3; ++axis)
    cells[size_t(axis)] =
        std::clamp(int(std::ceil(kLongestSide * extent[axis] / longest)), 1, kLongestSide);
  return cells;
}

}  // namespace

void validateVolume(const VolumeData& data) {
  const VolumeMaterial& m = data.material;
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
  };
  require(finiteNonNegative(m.density), "density must be finite and not negative");
  require(finiteNonNegative(m.scattering), "scattering must be finite and not negative");
  require(finiteNonNegative(m.absorption), "absorption must be finite and not negative");
  require(finiteNonNegative(m.principledAbsorption),
          "principled absorption must be finite and not negative");
  require(std::isfinite(m.anisotropy) && m.anisotropy > -1 && m.anisotropy < 1,
          "anisotropy must lie in (-1, 1)");
  require(finiteNonNegative(m.emission), "emission must be finite and not negative");
  require(finiteNonNegative(m.blackbodyIntensity),
          "blackbody intensity must be finite and not negative");
  require(finiteNonNegative(m.blackbodyTint), "blackbody tint must be finite and not negative");
  require(finiteNonNegative(m.temperature), "temperature must be finite and not negative");
  require(!data.density || data.density->components() == 1, "the density field must be scalar");
  require(!data.temperature || data.temperature->components() == 1,
          "the temperature field must be scalar");
  Bounds3f bounds = data.objectBounds;
  if (bounds.empty())
    for (const auto* field : {&data.density, &data.color, &data.temperature, &data.emission})
      if (*field) bounds.extend((*field)->objectBounds());
  require(!bounds.empty(), "the volume has no bounds (no fields and no box)");
  require(std::isfinite(bounds.lower.x) && std::isfinite(bounds.lower.y) &&
              std::isfinite(bounds.lower.z) && std::isfinite(bounds.upper.x) &&
              std::isfinite(bounds.upper.y) && std::isfinite(bounds.upper.z),
          "the volume's bounds are not finite (only constant fields and no box)");
}

Volume::Volume(VolumeData data) : data_(std::move(data)) {
  validateVolume(data_);
  bounds_ = data_.objectBounds;
  if (bounds_.empty())
    for (const auto* field : {&data_.density, &data_.color, &data_.temperature, &data_.emission})
      if (*field) bounds_.extend((*field)->objectBounds());
  const VolumeMaterial& m = data_.material;
  const Vec3f extent = componentMax(bounds_.upper - bounds_.lower, Vec3f(1e-6f));
  const std::array<int, 3> cells = majorantResolution(data_, extent);
  for (int axis = 0; axis < 3; ++axis) cells_[axis] = cells[size_t(axis)];
  cellSize_ = {extent.x / float(cells_[0]), extent.y / float(cells_[1]),
               extent.z / float(cells_[2])};
  // Emitting cells get at least this majorant, a few tentative collisions per cell, so that
  // emission where nothing absorbs is still collected.
  const float emissionMajorant = 2 / std::min({cellSize_.x, cellSize_.y, cellSize_.z});
  majorants_.resize(size_t(cells_[0]) * size_t(cells_[1]) * size_t(cells_[2]));
  for (int z = 0; z < cells_[2]; ++z)
    for (int y = 0; y < cells_[1]; ++y)
      for (int x = 0; x < cells_[0]; ++x) {
        Bounds3f cell;
        cell.lower = bounds_.lower +
                     Vec3f(float(x) * cellSize_.x, float(y) * cellSize_.y, float(z) * cellSize_.z);
        cell.upper = cell.lower + cellSize_;
        const float densityMax = m.density * maxOver(data_.density, cell);
        float majorant = densityMax * extinctionPerDensity(m, maxOver(data_.color, cell));
        const float temperatureMax = m.temperature * maxOver(data_.temperature, cell);
        const bool emitting =
            (maxComponent(m.emission) > 0 && maxOver(data_.emission, cell) > 0) ||
            (m.blackbodyIntensity > 0 && maxComponent(m.blackbodyTint) > 0 && temperatureMax > 0);
        if (emitting) {
          emits_ = true;
          majorant = std::max(majorant, emissionMajorant);
        }
        // A margin over float rounding of the coefficients' arithmetic.
        majorant *= 1.0001f;
        // Free flights subtract majorants: an infinite one would make NaN of every pixel.
        if (!std::isfinite(majorant))
          throw std::invalid_argument(
              "its density times its extinction is beyond single precision (" +
              std::to_string(m.density) + " × a density of up to " +
              std::to_string(maxOver(data_.density, cell)) + ")");
        majorants_[size_t((z * cells_[1] + y) * cells_[0] + x)] = majorant;
      }
}

MediumCoefficients Volume::at(const Vec3f& p) const {
  const VolumeMaterial& m = data_.material;
  MediumCoefficients result;
  const float density = m.density * scalarAt(data_.density, p);
  if (density > 0) {
    const Vec3f scattering = m.scattering * colorAt(data_.color, p);
    result.scattering = scattering * density;
    const Vec3f remainder{std::max(1 - scattering.x, 0.0f), std::max(1 - scattering.y, 0.0f),
                          std::max(1 - scattering.z, 0.0f)};
    result.absorption = (m.absorption + m.principledAbsorption * remainder) * density;
  }
  if (!emits_) return result;
  if (maxComponent(m.emission) > 0) result.emission = m.emission * colorAt(data_.emission, p);
  if (m.blackbodyIntensity > 0) {
    const float kelvin = m.temperature * scalarAt(data_.temperature, p);
    if (kelvin > 0)
      result.emission += blackbodyColor(kelvin) * m.blackbodyTint *
                         (blackbodyStrength(kelvin) * m.blackbodyIntensity);
  }
  return result;
}

size_t Volume::memoryBytes() const {
  size_t bytes = sizeof(*this) + majorants_.size() * sizeof(float);
  for (const auto* field : {&data_.density, &data_.color, &data_.temperature, &data_.emission})
    if (*field) bytes += (*field)->memoryBytes();
  return bytes;
}

uint64_t Volume::activeVoxels() const {
  uint64_t voxels = 0;
  for (const auto* field : {&data_.density, &data_.color, &data_.temperature, &data_.emission})
    if (*field) voxels += (*field)->activeVoxels();
  return voxels;
}

MajorantWalk::MajorantWalk(const Volume& volume, const Vec3f& origin, const Vec3f& direction,
                           float tMin, float tMax)
    : volume_(&volume) {
  const Bounds3f& bounds = volume.objectBounds();
  float t0 = tMin, t1 = tMax;
  for (int axis = 0; axis < 3; ++axis) {
    const float inverse = 1 / direction[axis];
    float near = (bounds.lower[axis] - origin[axis]) * inverse;
    float far = (bounds.upper[axis] - origin[axis]) * inverse;
    if (std::isnan(near) || std::isnan(far)) {
      // Parallel to this slab's planes and on one of them: inside iff within.
      if (origin[axis] < bounds.lower[axis] || origin[axis] > bounds.upper[axis]) return;
      continue;
    }
    if (near > far) std::swap(near, far);
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
  }
  if (!(t0 < t1)) return;
  t_ = t0;
  tEnd_ = t1;
  const int* cells = volume.majorantCells();
  const Vec3f& size = volume.majorantCellSize();
  const Vec3f start = origin + direction * t0;
  for (int axis = 0; axis < 3; ++axis) {
    const float offset = (start[axis] - bounds.lower[axis]) / size[axis];
    cell_[axis] = std::clamp(int(std::floor(offset)), 0, cells[axis] - 1);
    if (direction[axis] > 0) {
      step_[axis] = 1;
      const float boundary = bounds.lower[axis] + float(cell_[axis] + 1) * size[axis];
      tNext_[axis] = t0 + (boundary - start[axis]) / direction[axis];
      tDelta_[axis] = size[axis] / direction[axis];
    } else if (direction[axis] < 0) {
      step_[axis] = -1;
      const float boundary = bounds.lower[axis] + float(cell_[axis]) * size[axis];
      tNext_[axis] = t0 + (boundary - start[axis]) / direction[axis];
      tDelta_[axis] = -size[axis] / direction[axis];
    } else {
      step_[axis] = 0;
      tNext_[axis] = kInfinity;
      tDelta_[axis] = kInfinity;
    }
  }
  done_ = false;
}

bool MajorantWalk::next(MajorantSegment* segment) {
  if (done_) return false;
  const int axis =
      tNext_[0] < tNext_[1] ? (tNext_[0] < tNext_[2] ? 0 : 2) : (tNext_[1] < tNext_[2] ? 1 : 2);
  const float end = std::min(tNext_[axis], tEnd_);
  segment->tStart = t_;
  segment->tEnd = std::max(end, t_);
  segment->majorant = volume_->majorantOfCell(cell_[0], cell_[1], cell_[2]);
  t_ = segment->tEnd;
  const int* cells = volume_->majorantCells();
  cell_[axis] += step_[axis];
  tNext_[axis] += tDelta_[axis];
  if (end >= tEnd_ || cell_[axis] < 0 || cell_[axis] >= cells[axis]) done_ = true;
  return true;
}

}  // namespace penumbra
