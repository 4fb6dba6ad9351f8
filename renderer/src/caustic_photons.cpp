#include "penumbra/caustic_photons.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace penumbra {

PhotonGrid::PhotonGrid(std::vector<Photon> photons, float cellSize)
    : cellSize_(cellSize > 0 && std::isfinite(cellSize) ? cellSize : 1.0f) {
  if (photons.empty()) return;
  // About two buckets a photon, a power of two.
  size_t buckets = 1;
  while (buckets < 2 * photons.size()) buckets *= 2;
  bucketEnds_.assign(buckets, 0);
  std::vector<size_t> bucketOfPhoton(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) {
    bucketOfPhoton[i] = bucketOf(cellOf(photons[i].position));
    ++bucketEnds_[bucketOfPhoton[i]];
  }
  for (size_t b = 1; b < buckets; ++b) bucketEnds_[b] += bucketEnds_[b - 1];
  // A stable counting sort: each bucket keeps the photons' order.
  std::vector<uint32_t> next(buckets);
  for (size_t b = 0; b < buckets; ++b) next[b] = b > 0 ? bucketEnds_[b - 1] : 0;
  photons_.resize(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) photons_[next[bucketOfPhoton[i]]++] = photons[i];
}

PhotonGrid::Cell PhotonGrid::cellOf(const Vec3f& position) const {
  const auto index = [this](float coordinate) {
    const float cell = std::floor(coordinate / cellSize_);
    constexpr float kLimit = float(1 << 30);
    return int(std::clamp(cell, -kLimit, kLimit));
  };
  return {index(position.x), index(position.y), index(position.z)};
}

size_t PhotonGrid::bucketOf(const Cell& cell) const {
  const uint64_t hash = uint64_t(uint32_t(cell.x)) * 73856093u ^
                        uint64_t(uint32_t(cell.y)) * 19349663u ^
                        uint64_t(uint32_t(cell.z)) * 83492791u;
  return size_t(hash & (bucketEnds_.size() - 1));
}

namespace {

/// r_i² / r_{i−1}² of sample index i ≥ 1.
double squaredRadiusStep(uint32_t index) {
  return (double(index) + CausticPhotons::kAlpha) / (double(index) + 1);
}

}  // namespace

void CausticPhotons::hold(uint32_t first, std::vector<Arrivals> arrivals) {
  first_ = first;
  held_.clear();
  for (size_t k = 0; k < arrivals.size(); ++k) {
    const float scale = float(std::sqrt(squaredRadiusScale(first + uint32_t(k))));
    // Cells about twice the radius of a lookup where the photons lie.
    const float cellSize = 2 * kFootprints * arrivals[k].footprint * scale;
    held_.push_back({PhotonGrid(std::move(arrivals[k].photons), cellSize), scale});
  }
}

const CausticPhotons::Held& CausticPhotons::held(uint32_t sampleIndex) const {
  if (sampleIndex < first_ || sampleIndex - first_ >= held_.size())
    throw std::out_of_range("no photons held for sample index " + std::to_string(sampleIndex));
  return held_[sampleIndex - first_];
}

double CausticPhotons::squaredRadiusScale(uint32_t index) {
  if (index < productIndex_) {
    productIndex_ = 0;
    product_ = 1;
  }
  for (; productIndex_ < index; ++productIndex_) product_ *= squaredRadiusStep(productIndex_ + 1);
  return product_;
}

}  // namespace penumbra
