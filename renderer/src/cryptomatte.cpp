#include "penumbra/cryptomatte.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <stdexcept>

namespace penumbra {
namespace {

uint32_t rotateLeft(uint32_t x, int r) { return (x << r) | (x >> (32 - r)); }

template <typename T>
void append(std::vector<uint8_t>& out, T value) {
  const size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &value, sizeof(T));
}

template <typename T>
T take(const uint8_t*& cursor, const uint8_t* end) {
  if (end - cursor < std::ptrdiff_t(sizeof(T)))
    throw std::invalid_argument("cryptomatte state: data ends early");
  T value;
  std::memcpy(&value, cursor, sizeof(T));
  cursor += sizeof(T);
  return value;
}

}  // namespace

uint32_t murmurHash3(std::string_view bytes, uint32_t seed) {
  constexpr uint32_t c1 = 0xcc9e2d51, c2 = 0x1b873593;
  const size_t blocks = bytes.size() / 4;
  const auto byte = [&](size_t i) { return uint32_t(uint8_t(bytes[i])); };
  uint32_t h = seed;
  for (size_t b = 0; b < blocks; ++b) {
    // Little-endian blocks, whatever the machine's byte order.
    uint32_t k = byte(4 * b) | byte(4 * b + 1) << 8 | byte(4 * b + 2) << 16 | byte(4 * b + 3) << 24;
    k = rotateLeft(k * c1, 15) * c2;
    h = rotateLeft(h ^ k, 13) * 5 + 0xe6546b64;
  }
  uint32_t k = 0;
  const size_t tail = 4 * blocks;
  switch (bytes.size() & 3) {
    case 3:
      k ^= byte(tail + 2) << 16;
      [[fallthrough]];
    case 2:
      k ^= byte(tail + 1) << 8;
      [[fallthrough]];
    case 1:
      k ^= byte(tail);
      h ^= rotateLeft(k * c1, 15) * c2;
  }
  h ^= uint32_t(bytes.size());
  h ^= h >> 16;
  h *= 0x85ebca6b;
  h ^= h >> 13;
  h *= 0xc2b2ae35;
  h ^= h >> 16;
  return h;
}

uint32_t cryptomatteBits(uint32_t hash) {
  const uint32_t exponent = (hash >> 23) & 0xffu;
  return exponent == 0 || exponent == 0xffu ? hash ^ (1u << 23) : hash;
}

float cryptomatteFloat(uint32_t hash) {
  const uint32_t bits = cryptomatteBits(hash);
  float id;
  std::memcpy(&id, &bits, sizeof id);
  return id;
}

std::vector<CryptomatteRank> rankCoverage(std::vector<std::pair<uint32_t, uint32_t>> counts,
                                          uint32_t samples) {
  std::sort(counts.begin(), counts.end());
  std::vector<std::pair<uint32_t, uint32_t>> merged;  // (hash, count), one per hash
  for (const auto& [hash, count] : counts) {
    if (!merged.empty() && merged.back().first == hash)
      merged.back().second += count;
    else
      merged.emplace_back(hash, count);
  }
  std::stable_sort(merged.begin(), merged.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  std::vector<CryptomatteRank> ranks;
  ranks.reserve(merged.size());
  for (const auto& [hash, count] : merged)
    ranks.push_back({cryptomatteFloat(hash), float(double(count) / double(samples))});
  return ranks;
}

void CryptomatteCoverage::reset(size_t pixels) {
  pixels_.assign(pixels, {});
}

void CryptomatteCoverage::add(size_t pixel, PlacementKey placement) {
  std::vector<Count>& counts = pixels_[pixel];
  for (Count& count : counts)
    if (count.placement == placement) {
      ++count.samples;
      return;
    }
  counts.push_back({placement, 1});
}

void CryptomatteCoverage::resolve(size_t pixel, uint32_t samples, const PlacementHashes& hashes,
                                  int depth, float* out) const {
  std::fill(out, out + 2 * size_t(std::max(depth, 0)), 0.0f);
  if (samples == 0) return;
  std::vector<std::pair<uint32_t, uint32_t>> counts;
  for (const Count& count : pixels_[pixel]) {
    const auto found = hashes.find(count.placement);
    if (found != hashes.end()) counts.emplace_back(found->second, count.samples);
  }
  const std::vector<CryptomatteRank> ranks = rankCoverage(std::move(counts), samples);
  for (size_t rank = 0; rank < ranks.size() && rank < size_t(std::max(depth, 0)); ++rank) {
    out[2 * rank] = ranks[rank].id;
    out[2 * rank + 1] = ranks[rank].coverage;
  }
}

void CryptomatteCoverage::saveState(std::vector<uint8_t>& out) const {
  append<uint64_t>(out, pixels_.size());
  for (const std::vector<Count>& counts : pixels_) {
    append<uint32_t>(out, uint32_t(counts.size()));
    for (const Count& count : counts) {
      append<uint64_t>(out, count.placement);
      append<uint32_t>(out, count.samples);
    }
  }
}

void CryptomatteCoverage::loadState(const uint8_t*& cursor, const uint8_t* end) {
  const uint64_t pixels = take<uint64_t>(cursor, end);
  if (pixels != pixels_.size())
    throw std::invalid_argument("cryptomatte state: " + std::to_string(pixels) +
                                " pixels, the film has " + std::to_string(pixels_.size()));
  std::vector<std::vector<Count>> loaded(pixels_.size());
  for (std::vector<Count>& counts : loaded) {
    const uint32_t size = take<uint32_t>(cursor, end);
    // Each count takes 12 bytes: a bad size fails here rather than allocating gigabytes.
    if (uint64_t(end - cursor) < uint64_t(size) * 12)
      throw std::invalid_argument("cryptomatte state: data ends early");
    counts.resize(size);
    for (Count& count : counts) {
      count.placement = take<uint64_t>(cursor, end);
      count.samples = take<uint32_t>(cursor, end);
      if (count.samples == 0) throw std::invalid_argument("cryptomatte state: empty count");
    }
  }
  pixels_ = std::move(loaded);
}

}  // namespace penumbra
