// Deterministic low-discrepancy sampling: every value is a pure function of
// (seed, pixel, sample index, dimension), so images do not depend on threads or tile order.
//
// Each dimension of the stream (a 1D, 2D or 4D draw) takes the first one, two or four dimensions
// of the Sobol sequence at a shuffled sample index and Owen-scrambles each with a hash-derived
// seed (Burley 2020, "Practical Hash-based Owen Scrambling"). Within one pixel the first 2^k
// samples of every 2D draw form a (0,k,2)-net, and those of a 4D draw a (3,k,4)-net: decisions
// that act together (pixel position and lens position, lobe choice and direction) are drawn from
// one 4D draw so that they are stratified jointly. Draws of different dimensions are
// decorrelated by the per-dimension shuffle.
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
/// The first four dimensions of the Sobol sequence (Joe and Kuo's direction numbers), as 32-bit
/// fractions; the first two form a (0,2)-sequence.
uint32_t sobolDimension0(uint32_t index);
uint32_t sobolDimension1(uint32_t index);
uint32_t sobolDimension2(uint32_t index);
uint32_t sobolDimension3(uint32_t index);

/// Four numbers of one 4D draw.
struct Sample4D {
  float x, y, z, w;
};

/// The random numbers of one camera sample: draw them in a fixed order.
class SampleStream {
 public:
  SampleStream(uint32_t seed, uint32_t pixelX, uint32_t pixelY, uint32_t sampleIndex);

  float next1D() { return draw1D(dimension_++); }
  Vec2f next2D() { return draw2D(dimension_++); }
  Sample4D next4D() { return draw4D(dimension_++); }
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
  /// Its first two numbers are draw2D(dimension)'s.
  Sample4D draw4D(uint32_t dimension) const;
  uint32_t dimension() const { return dimension_; }
  /// The same pixel's stream of sample `sampleIndex`, at this stream's dimension: a path that
  /// branches (IntegratorSettings::indirectSamples) draws each branch's remaining dimensions
  /// from a sample index of its own.
  SampleStream atSample(uint32_t sampleIndex) const;

 private:
  uint32_t pixelSeed_;
  uint32_t reversedSampleIndex_;  // the index is only ever scrambled in base-2 reversed order
  uint32_t dimension_ = 0;
};

}  // namespace penumbra
