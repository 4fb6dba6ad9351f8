// Deterministic low-discrepancy sampling: every value is a pure function of
// (seed, pixel, sample index, dimension), so images do not depend on threads or tile order.
//
// Each dimension (a 1D or 2D draw) takes the first two dimensions of the Sobol sequence at a
// shuffled sample index and Owen-scrambles them with hash-derived seeds (Burley 2020, "Practical
// Hash-based Owen Scrambling"). Within one pixel the first 2^k samples of every 2D draw form a
// (0,k,2)-net; draws of different dimensions are decorrelated by the per-dimension shuffle.
#pragma once

#include <cstdint>

#include "penumbra/math.h"

namespace penumbra {

/// A 32-bit integer hash with good avalanche (the "lowbias32" finaliser of Chris Wellons).
/// Inline: every sample draw hashes several times.
inline uint32_t hashUint32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}
/// Hash of two values, order-dependent.
inline uint32_t hashCombine(uint32_t seed, uint32_t value) {
  return hashUint32(seed ^ (value + 0x9e3779b9u + (seed << 6) + (seed >> 2)));
}

/// Owen scrambling of a 32-bit binary fraction: each bit is flipped by a hash of the bits above it.
uint32_t owenScramble(uint32_t bits, uint32_t seed);
/// The first two dimensions of the Sobol (0,2)-sequence, as 32-bit fractions.
uint32_t sobolDimension0(uint32_t index);
uint32_t sobolDimension1(uint32_t index);

/// The random numbers of one camera sample: draw them in a fixed order.
class SampleStream {
 public:
  SampleStream(uint32_t seed, uint32_t pixelX, uint32_t pixelY, uint32_t sampleIndex);

  float next1D() { return draw1D(dimension_++); }
  Vec2f next2D() { return draw2D(dimension_++); }
  /// Sets aside `count` dimensions for draws that may or may not be made (as many as a decision
  /// might need at most), so that the dimensions after them do not depend on how many were
  /// made; returns the first. Draw them with draw1D/draw2D(first + k).
  uint32_t reserve(uint32_t count) {
    const uint32_t first = dimension_;
    dimension_ += count;
    return first;
  }
  float draw1D(uint32_t dimension) const;
  Vec2f draw2D(uint32_t dimension) const;
  uint32_t dimension() const { return dimension_; }

 private:
  uint32_t pixelSeed_;
  uint32_t reversedSampleIndex_;  // the index is only ever scrambled in base-2 reversed order
  uint32_t dimension_ = 0;
};

}  // namespace penumbra
