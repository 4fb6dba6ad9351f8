// Pseudo-random numbers for decisions whose number is not fixed in advance (free-flight
// sampling takes as many steps as the medium asks): a PCG32 generator (O'Neill 2014) seeded from
// a hash of the sample's identity, so that every value is still a pure function of (seed,
// pixel, sample index, purpose) and images stay independent of threads and tile order.
#pragma once

#include <cstdint>

#include "penumbra/math.h"
#include "penumbra/sampler.h"

namespace penumbra {

class RandomStream {
 public:
  /// A stream for one purpose (`purpose`: e.g. the path vertex it serves) of one camera sample.
  RandomStream(uint32_t seed, uint32_t pixelX, uint32_t pixelY, uint32_t sampleIndex,
               uint32_t purpose) {
    const uint32_t a = hashCombine(hashCombine(seed, pixelX), pixelY);
    const uint32_t b = hashCombine(hashCombine(a, sampleIndex), purpose);
    state_ = (uint64_t(hashUint32(b ^ 0x5bd1e995u)) << 32) | hashUint32(b);
    increment_ = (uint64_t(hashUint32(a)) << 1) | 1u;
    nextBits();
  }

  /// Uniform in [0, 1).
  float next() { return float(nextBits() >> 8) * 0x1p-24f; }
  Vec2f next2D() {
    const float x = next();
    return {x, next()};
  }

 private:
  uint32_t nextBits() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ull + increment_;
    const auto xorShifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    const auto rotation = uint32_t(old >> 59u);
    return (xorShifted >> rotation) | (xorShifted << ((32u - rotation) & 31u));
  }

  uint64_t state_ = 0;
  uint64_t increment_ = 1;
};

}  // namespace penumbra
