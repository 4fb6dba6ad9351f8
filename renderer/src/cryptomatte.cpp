#include "penumbra/cryptomatte.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#include "penumbra/state_io.h"

namespace penumbra {
namespace {

uint32_t rotateLeft(uint32_t x, int r) {
  return (x << r) | (x >> (32 - r));
}

constexpr char kCryptomatteTag[5] = "CRYP";
constexpr uint32_t kCryptomatteVersion = 2;  // 2: counts per face slot
// placement, face slot, samples
constexpr size_t kCountBytes = sizeof(uint64_t) + sizeof(uint32_t) + sizeof(uint32_t);

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

void CryptomatteCoverage::add(size_t pixel, PlacementKey placement, uint32_t faceSlot) {
  std::vector<Count>& counts = pixels_[pixel];
  for (Count& count : counts)
    if (count.placement == placement && count.faceSlot == faceSlot) {
      ++count.samples;
      return;
    }
  counts.push_back({placement, faceSlot, 1});
}

void CryptomatteCoverage::resolve(size_t pixel, uint32_t samples, const PlacementHashes& hashes,
                                  int depth, float* out, const SlotHashes* slots) const {
  std::fill(out, out + 2 * size_t(std::max(depth, 0)), 0.0f);
  if (samples == 0) return;
  std::vector<std::pair<uint32_t, uint32_t>> counts;
  for (const Count& count : pixels_[pixel]) {
    if (slots && count.faceSlot > 0) {
      const auto found = slots->find(objectOf(count.placement));
      if (found != slots->end() && count.faceSlot <= found->second.size())
        counts.emplace_back(found->second[count.faceSlot - 1], count.samples);
      continue;
    }
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
  StateWriter writer(out);
  const size_t block = writer.beginBlock(kCryptomatteTag, kCryptomatteVersion);
  writer.put(uint64_t(pixels_.size()));
  for (const std::vector<Count>& counts : pixels_) {
    writer.put(uint32_t(counts.size()));
    for (const Count& count : counts) {  // field by field: no padding bytes in the state
      writer.put(count.placement);
      writer.put(count.faceSlot);
      writer.put(count.samples);
    }
  }
  writer.endBlock(block);
}

void CryptomatteCoverage::loadState(const uint8_t*& cursor, const uint8_t* end) {
  StateReader reader(cursor, end, "the cryptomatte state");
  reader.beginBlock(kCryptomatteTag, kCryptomatteVersion);
  if (reader.get<uint64_t>() != pixels_.size()) reader.fail("is of another pixel count");
  std::vector<std::vector<Count>> loaded(pixels_.size());
  for (std::vector<Count>& counts : loaded) {
    const uint32_t size = reader.get<uint32_t>();
    // A bad size fails here rather than allocating gigabytes.
    if (uint64_t(end - cursor) < uint64_t(size) * kCountBytes) reader.fail("is truncated");
    counts.resize(size);
    for (Count& count : counts) {
      count.placement = reader.get<PlacementKey>();
      count.faceSlot = reader.get<uint32_t>();
      count.samples = reader.get<uint32_t>();
      if (count.samples == 0) reader.fail("has an empty count");
    }
  }
  reader.endBlock();
  pixels_ = std::move(loaded);
}

}  // namespace penumbra
