#include "penumbra/sampler.h"

#include <array>

namespace penumbra {
namespace {

uint32_t reverseBits(uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
  return (x >> 16) | (x << 16);
}

/// A hash-based permutation in which each bit depends only on itself and the bits below it
/// (Laine & Karras 2011, with the constants of Vegdahl's improved variant).
uint32_t lowToHighPermutation(uint32_t x, uint32_t seed) {
  x ^= x * 0x3d20adeau;
  x += seed;
  x *= (seed >> 16) | 1u;
  x ^= x * 0x05526c56u;
  x ^= x * 0x53a22864u;
  return x;
}

/// The second Sobol dimension with its bits reversed, through byte tables (the generator matrix
/// is linear over GF(2), so each byte of the index contributes independently).
uint32_t sobolDimension1Reversed(uint32_t index) {
  static const auto tables = [] {
    std::array<std::array<uint32_t, 256>, 4> result{};
    for (uint32_t byte = 0; byte < 4; ++byte)
      for (uint32_t value = 0; value < 256; ++value)
        result[byte][value] = reverseBits(sobolDimension1(value << (8 * byte)));
    return result;
  }();
  return tables[0][index & 0xffu] ^ tables[1][(index >> 8) & 0xffu] ^
         tables[2][(index >> 16) & 0xffu] ^ tables[3][index >> 24];
}

/// Maps a 32-bit fraction to [0, 1) without ever rounding up to 1.
float toUnitFloat(uint32_t bits) {
  return std::min(float(bits) * 0x1p-32f, 0x1.fffffep-1f);
}

}  // namespace

uint32_t owenScramble(uint32_t bits, uint32_t seed) {
  return reverseBits(lowToHighPermutation(reverseBits(bits), seed));
}

uint32_t sobolDimension0(uint32_t index) {
  return reverseBits(index);
}

uint32_t sobolDimension1(uint32_t index) {
  // Direction numbers of the second Sobol dimension (primitive polynomial x + 1).
  uint32_t result = 0;
  for (uint32_t direction = 1u << 31; index != 0; index >>= 1, direction ^= direction >> 1)
    if (index & 1u) result ^= direction;
  return result;
}

SampleStream::SampleStream(uint32_t seed, uint32_t pixelX, uint32_t pixelY, uint32_t sampleIndex)
    : pixelSeed_(hashCombine(hashCombine(hashUint32(seed), pixelX), pixelY)),
      reversedSampleIndex_(reverseBits(sampleIndex)) {}

Vec2f SampleStream::draw2D(uint32_t dimension) const {
  const uint32_t dimensionSeed = hashCombine(pixelSeed_, dimension);
  // Scrambling the index in base-2 reversed order permutes aligned blocks of 2^k indices among
  // themselves, so every power-of-two prefix remains a (0,k,2)-net (Burley 2020, §4). This is
  // owenScramble(sampleIndex, dimensionSeed), its first reversal done once per stream.
  const uint32_t index = reverseBits(lowToHighPermutation(reversedSampleIndex_, dimensionSeed));
  // owenScramble(p, s) = reverse(permute(reverse(p), s)): the Sobol points are produced already
  // reversed, which saves two reversals each (same values as owenScramble(sobolDimensionN(i))).
  const uint32_t x = reverseBits(lowToHighPermutation(index, hashCombine(dimensionSeed, 1)));
  const uint32_t y = reverseBits(
      lowToHighPermutation(sobolDimension1Reversed(index), hashCombine(dimensionSeed, 2)));
  return {toUnitFloat(x), toUnitFloat(y)};
}

float SampleStream::draw1D(uint32_t dimension) const {
  const uint32_t dimensionSeed = hashCombine(pixelSeed_, dimension);
  const uint32_t index = reverseBits(lowToHighPermutation(reversedSampleIndex_, dimensionSeed));
  return toUnitFloat(reverseBits(lowToHighPermutation(index, hashCombine(dimensionSeed, 1))));
}

}  // namespace penumbra
