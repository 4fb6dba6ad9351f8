#include "penumbra/sampler.h"

#include <array>

namespace penumbra {
namespace {

constexpr uint32_t reverseBits(uint32_t x) {
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

/// A Sobol dimension from its primitive polynomial of degree `degree` (inner coefficients
/// `coefficients`, highest first) and initial direction integers m_1..m_degree (Joe and Kuo).
constexpr uint32_t sobolFromPolynomial(uint32_t index, int degree, uint32_t coefficients,
                                       const std::array<uint32_t, 3>& initial) {
  std::array<uint32_t, 32> m{};  // direction integers m_k, k = 1..32 at m[k - 1]
  for (int k = 0; k < 32; ++k) {
    if (k < degree) {
      m[size_t(k)] = initial[size_t(k)];
      continue;
    }
    // m_k = 2 a_1 m_{k-1} ^ 4 a_2 m_{k-2} ^ ... ^ 2^s m_{k-s} ^ m_{k-s}
    uint32_t value = m[size_t(k - degree)] ^ (m[size_t(k - degree)] << degree);
    for (int j = 1; j < degree; ++j)
      if ((coefficients >> (degree - 1 - j)) & 1u) value ^= m[size_t(k - j)] << j;
    m[size_t(k)] = value;
  }
  uint32_t result = 0;
  for (int k = 0; index != 0; ++k, index >>= 1)
    if (index & 1u) result ^= m[size_t(k)] << (31 - k);
  return result;
}

// Sobol dimensions 1 to 3 (the polynomials x + 1, x² + x + 1 and x³ + x + 1).
constexpr uint32_t sobol1(uint32_t index) {
  return sobolFromPolynomial(index, 1, 0, {1, 0, 0});
}
constexpr uint32_t sobol2(uint32_t index) {
  return sobolFromPolynomial(index, 2, 1, {1, 3, 0});
}
constexpr uint32_t sobol3(uint32_t index) {
  return sobolFromPolynomial(index, 3, 1, {1, 3, 1});
}

/// Sobol dimensions 1 to 3 of one index, each with its bits reversed.
struct SobolReversed {
  uint32_t dimension1, dimension2, dimension3;
};

/// Byte tables of SobolReversed: the generator matrices are linear over GF(2), so each byte of
/// the index contributes independently (an entry is the XOR of the columns of its set bits).
/// Built at compile time, so that the draws, which look them up several times per path vertex,
/// neither build them nor check that they are built.
using SobolByteTables = std::array<std::array<SobolReversed, 256>, 4>;
constexpr SobolByteTables kSobolByteTables = [] {
  SobolByteTables tables{};
  for (uint32_t byte = 0; byte < 4; ++byte)
    for (uint32_t bit = 0; bit < 8; ++bit) {
      const uint32_t at = 1u << (8 * byte + bit);
      const SobolReversed column{reverseBits(sobol1(at)), reverseBits(sobol2(at)),
                                 reverseBits(sobol3(at))};
      // The values whose highest set bit is `bit`: those below it, plus its column.
      for (uint32_t below = 0; below < (1u << bit); ++below) {
        const SobolReversed& low = tables[byte][below];
        tables[byte][below | (1u << bit)] = {low.dimension1 ^ column.dimension1,
                                             low.dimension2 ^ column.dimension2,
                                             low.dimension3 ^ column.dimension3};
      }
    }
  return tables;
}();

/// Inlined: a 2D draw takes only dimension 1, and the lookups of the others then go.
[[gnu::always_inline]] inline SobolReversed sobolReversed(uint32_t index) {
  const SobolReversed& a = kSobolByteTables[0][index & 0xffu];
  const SobolReversed& b = kSobolByteTables[1][(index >> 8) & 0xffu];
  const SobolReversed& c = kSobolByteTables[2][(index >> 16) & 0xffu];
  const SobolReversed& d = kSobolByteTables[3][index >> 24];
  return {a.dimension1 ^ b.dimension1 ^ c.dimension1 ^ d.dimension1,
          a.dimension2 ^ b.dimension2 ^ c.dimension2 ^ d.dimension2,
          a.dimension3 ^ b.dimension3 ^ c.dimension3 ^ d.dimension3};
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
  return sobol1(index);
}

uint32_t sobolDimension2(uint32_t index) {
  return sobol2(index);
}

uint32_t sobolDimension3(uint32_t index) {
  return sobol3(index);
}

SampleStream::SampleStream(uint32_t seed, uint32_t pixelX, uint32_t pixelY, uint32_t sampleIndex)
    : pixelSeed_(hashCombine(hashCombine(hashUint32(seed), pixelX), pixelY)),
      reversedSampleIndex_(reverseBits(sampleIndex)) {}

SampleStream SampleStream::atSample(uint32_t sampleIndex) const {
  SampleStream stream = *this;
  stream.reversedSampleIndex_ = reverseBits(sampleIndex);
  return stream;
}

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
      lowToHighPermutation(sobolReversed(index).dimension1, hashCombine(dimensionSeed, 2)));
  return {toUnitFloat(x), toUnitFloat(y)};
}

Sample4D SampleStream::draw4D(uint32_t dimension) const {
  const uint32_t dimensionSeed = hashCombine(pixelSeed_, dimension);
  const uint32_t index = reverseBits(lowToHighPermutation(reversedSampleIndex_, dimensionSeed));
  const auto scrambled = [&](uint32_t reversedSobol, uint32_t component) {
    return toUnitFloat(
        reverseBits(lowToHighPermutation(reversedSobol, hashCombine(dimensionSeed, component))));
  };
  const SobolReversed sobol = sobolReversed(index);
  return {scrambled(index, 1), scrambled(sobol.dimension1, 2), scrambled(sobol.dimension2, 3),
          scrambled(sobol.dimension3, 4)};
}

float SampleStream::draw1D(uint32_t dimension) const {
  const uint32_t dimensionSeed = hashCombine(pixelSeed_, dimension);
  const uint32_t index = reverseBits(lowToHighPermutation(reversedSampleIndex_, dimensionSeed));
  return toUnitFloat(reverseBits(lowToHighPermutation(index, hashCombine(dimensionSeed, 1))));
}

}  // namespace penumbra
