#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "penumbra/filter.h"
#include "penumbra/sampler.h"

using namespace penumbra;

TEST(Sampler, IsAPureFunctionOfItsInputs) {
  SampleStream a(7, 10, 20, 33), b(7, 10, 20, 33);
  for (int d = 0; d < 16; ++d) {
    const Vec2f x = a.next2D(), y = b.next2D();
    EXPECT_EQ(x.x, y.x);
    EXPECT_EQ(x.y, y.y);
  }
}

TEST(Sampler, DiffersBetweenSeedsPixelsAndSamples) {
  const auto first = [](uint32_t seed, uint32_t x, uint32_t y, uint32_t s) {
    return SampleStream(seed, x, y, s).next2D().x;
  };
  const float base = first(0, 1, 2, 3);
  EXPECT_NE(base, first(1, 1, 2, 3));
  EXPECT_NE(base, first(0, 2, 2, 3));
  EXPECT_NE(base, first(0, 1, 3, 3));
  EXPECT_NE(base, first(0, 1, 2, 4));
}

// The first 2^k samples of every 2D draw form a (0,k,2)-net: each elementary interval of area
// 2^-k (all 2^a x 2^(k-a) grids) holds exactly one point.
TEST(Sampler, PowerOfTwoPrefixesAreZeroTwoNets) {
  for (uint32_t k : {4u, 6u, 8u}) {
    const uint32_t n = 1u << k;
    for (uint32_t dimension = 0; dimension < 6; ++dimension) {
      std::vector<Vec2f> points;
      for (uint32_t s = 0; s < n; ++s) {
        SampleStream stream(3, 5, 9, s);
        Vec2f p{};
        for (uint32_t d = 0; d <= dimension; ++d) p = stream.next2D();
        points.push_back(p);
      }
      for (uint32_t a = 0; a <= k; ++a) {
        const uint32_t columns = 1u << a, rows = 1u << (k - a);
        std::set<uint32_t> cells;
        for (const Vec2f& p : points) {
          ASSERT_GE(p.x, 0.0f);
          ASSERT_LT(p.x, 1.0f);
          cells.insert(uint32_t(p.x * columns) * rows + uint32_t(p.y * rows));
        }
        EXPECT_EQ(cells.size(), n) << "k=" << k << " dimension=" << dimension << " a=" << a;
      }
    }
  }
}

TEST(Sampler, OneDimensionalDrawsAreStratified) {
  const uint32_t n = 64;
  std::set<uint32_t> strata;
  for (uint32_t s = 0; s < n; ++s) strata.insert(uint32_t(SampleStream(0, 4, 4, s).next1D() * n));
  EXPECT_EQ(strata.size(), n);
}

TEST(Sampler, MeanIsUnbiased) {
  double sum = 0;
  const int n = 4096;
  for (int s = 0; s < n; ++s) {
    SampleStream stream(11, 0, 0, uint32_t(s));
    stream.next2D();
    sum += stream.next2D().y;
  }
  EXPECT_NEAR(sum / n, 0.5, 1e-3);
}

namespace {

/// The construction the header documents, written out: the bits of number `k` (0 to 3) of
/// dimension `dimension`'s point for sample `sample` of pixel (x, y) under `seed`.
uint32_t referenceBits(uint32_t seed, uint32_t x, uint32_t y, uint32_t sample, uint32_t dimension,
                       uint32_t k) {
  const uint32_t dimensionSeed =
      hashCombine(hashCombine(hashCombine(hashUint32(seed), x), y), dimension);
  const uint32_t index = owenScramble(sample, dimensionSeed);
  uint32_t (*const sobol[4])(uint32_t) = {sobolDimension0, sobolDimension1, sobolDimension2,
                                          sobolDimension3};
  return owenScramble(sobol[k](index), hashCombine(dimensionSeed, k + 1));
}

/// Those bits as the number drawn: a fraction of 2^32, clamped below 1.
float referenceUnit(uint32_t bits) {
  return std::min(float(bits) * 0x1p-32f, 0x1.fffffep-1f);
}

}  // namespace

// The stream is the construction the header documents; the implementation's shortcuts (points
// produced bit-reversed, byte tables) must not change a single value.
TEST(Sampler, MatchesTheReferenceConstruction) {
  for (uint32_t sample : {0u, 1u, 7u, 1000u, 65535u, 4000000000u}) {
    SampleStream stream(42, 3, 9, sample);
    for (uint32_t dimension = 0; dimension < 8; ++dimension) {
      const float x = referenceUnit(referenceBits(42, 3, 9, sample, dimension, 0));
      if (dimension % 2 == 0) {
        const Vec2f p = stream.next2D();
        EXPECT_EQ(p.x, x);
        EXPECT_EQ(p.y, referenceUnit(referenceBits(42, 3, 9, sample, dimension, 1)));
      } else {
        EXPECT_EQ(stream.next1D(), x);
      }
    }
  }
}

// The same for all four numbers of 4D draws (the byte tables of Sobol's dimensions 2 and 3
// included): over many streams and dimensions, and at the largest fractions, which round up to
// 1 as floats and must be clamped below it.
TEST(Sampler, FourDimensionalDrawsMatchTheReferenceConstruction) {
  EXPECT_EQ(referenceUnit(0xffffffffu), 0x1.fffffep-1f);
  // Samples of pixel (1, 2), seed 7, whose dimension-0 draw has a fraction ≥ 0xffffff80 in
  // component 3, 1, 4 and 2 (found by search): the draws that round up to 1.
  const uint32_t roundingUp[4] = {5618006, 15105636, 19695468, 20900654};
  int checked = 0, clamped = 0;
  for (uint32_t stream = 0; stream < 4004; ++stream) {
    const bool edge = stream >= 4000;
    const uint32_t seed = edge ? 7 : hashUint32(stream), x = edge ? 1 : stream % 61,
                   y = edge ? 2 : stream / 61;
    const uint32_t sample = edge            ? roundingUp[stream - 4000]
                            : stream < 2000 ? stream
                                            : hashUint32(stream + 17);
    const SampleStream drawn(seed, x, y, sample);
    for (uint32_t dimension = 0; dimension < 24; ++dimension) {
      const Sample4D p = drawn.draw4D(dimension);
      const float values[4] = {p.x, p.y, p.z, p.w};
      for (uint32_t k = 0; k < 4; ++k) {
        const uint32_t bits = referenceBits(seed, x, y, sample, dimension, k);
        ASSERT_EQ(values[k], referenceUnit(bits)) << stream << " " << dimension << " " << k;
        clamped += bits >= 0xffffff80u;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 4004 * 24 * 4);
  EXPECT_GE(clamped, 4);  // the rounding edge was met
}

// Sobol's third and fourth dimensions, from Joe and Kuo's direction numbers (x² + x + 1 with
// m = 1, 3; x³ + x + 1 with m = 1, 3, 1), in natural (not Gray-code) order.
TEST(Sampler, SobolDimensionsTwoAndThree) {
  const float third[8] = {0, 0.5f, 0.75f, 0.25f, 0.375f, 0.875f, 0.625f, 0.125f};
  const float fourth[8] = {0, 0.5f, 0.75f, 0.25f, 0.125f, 0.625f, 0.875f, 0.375f};
  for (uint32_t i = 0; i < 8; ++i) {
    EXPECT_EQ(float(sobolDimension2(i)) * 0x1p-32f, third[i]) << i;
    EXPECT_EQ(float(sobolDimension3(i)) * 0x1p-32f, fourth[i]) << i;
  }
  EXPECT_EQ(sobolDimension2(16), 29u << 27);  // m_5 = 2 m_4 ^ 4 m_3 ^ m_3 = 18 ^ 12 ^ 3
}

// A 4D draw stratifies its four numbers jointly: the first 256 samples of a pixel put 16 in
// each of the 16 orthants of the unit hypercube (the scrambled Sobol points form a
// (3,8,4)-net), and its first two numbers are the 2D draw's.
TEST(Sampler, FourDimensionalDrawsAreJointlyStratified) {
  std::vector<int> cells(16);
  for (uint32_t s = 0; s < 256; ++s) {
    const SampleStream stream(3, 7, 11, s);
    const Sample4D p = stream.draw4D(5);
    const Vec2f pair = stream.draw2D(5);
    EXPECT_EQ(p.x, pair.x);
    EXPECT_EQ(p.y, pair.y);
    ++cells[size_t((p.x >= 0.5f) + 2 * (p.y >= 0.5f) + 4 * (p.z >= 0.5f) + 8 * (p.w >= 0.5f))];
  }
  for (const int count : cells) EXPECT_EQ(count, 16);
}

// Reserved dimensions are the ones next1D/next2D would have drawn, and the draws after a
// reservation do not depend on how many of the reserved ones were used.
TEST(Sampler, ReservedDimensionsAreDrawnOnDemand) {
  SampleStream sequential(5, 1, 2, 9), reserving(5, 1, 2, 9);
  const Vec2f first = sequential.next2D();
  const float second = sequential.next1D();
  const Vec2f third = sequential.next2D();
  const Vec2f after = sequential.next2D();
  const uint32_t block = reserving.reserve(3);
  EXPECT_EQ(block, 0u);
  EXPECT_EQ(reserving.draw2D(block + 2).x, third.x);
  EXPECT_EQ(reserving.draw2D(block).y, first.y);
  EXPECT_EQ(reserving.draw1D(block + 1), second);
  const Vec2f next = reserving.next2D();
  EXPECT_EQ(next.x, after.x);
  EXPECT_EQ(next.y, after.y);
}

TEST(PixelFilter, OffsetsFollowTheFilterProfile) {
  // Importance-sampled offsets must be distributed as the filter: compare their moments and
  // histogram with the profile's, integrated numerically.
  const PixelFilter filter;
  const int n = 1 << 16, bins = 30;
  std::vector<double> histogram(bins, 0.0);
  double sum = 0, sum2 = 0;
  for (int i = 0; i < n; ++i) {
    const float x = filter.sampleOffset({(float(i) + 0.5f) / float(n), 0.5f}).x;
    ASSERT_LE(std::fabs(x), filter.radius());
    sum += x;
    sum2 += double(x) * x;
    histogram[size_t(
        std::min(bins - 1, int((x + filter.radius()) / (2 * filter.radius()) * bins)))] += 1.0 / n;
  }
  double mass = 0, variance = 0;
  std::vector<double> expected(bins, 0.0);
  const int steps = 30000;
  for (int i = 0; i < steps; ++i) {
    const double x = -filter.radius() + (i + 0.5) * 2 * filter.radius() / steps;
    const double weight = filter.evaluate1D(float(x));
    mass += weight;
    variance += weight * x * x;
    expected[size_t(
        std::min(bins - 1, int((x + filter.radius()) / (2 * filter.radius()) * bins)))] += weight;
  }
  EXPECT_NEAR(sum / n, 0.0, 1e-3);
  EXPECT_NEAR(sum2 / n / (variance / mass), 1.0, 0.01);
  for (int b = 0; b < bins; ++b)
    EXPECT_NEAR(histogram[size_t(b)], expected[size_t(b)] / mass, 2e-3) << "bin " << b;
}

TEST(PixelFilter, OffsetsWithinABoxAreTheFiltersThereAndCarryItsShare) {
  // Restricted to a box, offsets are drawn as sampleOffset draws them, conditioned on landing
  // in the box; the share is the probability that sampleOffset lands there.
  const PixelFilter filter;
  const PixelFilter::OffsetWithin whole = filter.sampleOffsetWithin({-2, -2}, {2, 2}, {0.3f, 0.7f});
  EXPECT_FLOAT_EQ(whole.share, 1);
  const Vec2f wholeOffset = filter.sampleOffset({0.3f, 0.7f});
  EXPECT_NEAR(whole.offset.x, wholeOffset.x, 1e-6f);
  EXPECT_NEAR(whole.offset.y, wholeOffset.y, 1e-6f);
  EXPECT_EQ(filter.sampleOffsetWithin({2, -1}, {3, 1}, {0.5f, 0.5f}).share, 0);

  const Vec2f lower{-0.9f, 0.2f}, upper{0.1f, 1.3f};
  const int n = 512;  // an n × n grid of draws of the whole filter
  int inside = 0;
  double insideX = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Vec2f offset = filter.sampleOffset({(float(i) + 0.5f) / n, (float(j) + 0.5f) / n});
      if (offset.x >= lower.x && offset.x < upper.x && offset.y >= lower.y && offset.y < upper.y) {
        ++inside;
        insideX += offset.x;
      }
    }
  double restrictedX = 0;
  float share = 0;
  for (int i = 0; i < n; ++i) {
    const PixelFilter::OffsetWithin drawn =
        filter.sampleOffsetWithin(lower, upper, {(float(i) + 0.5f) / n, 0.5f});
    ASSERT_GE(drawn.offset.x, lower.x);
    ASSERT_LE(drawn.offset.x, upper.x);
    ASSERT_GE(drawn.offset.y, lower.y);
    ASSERT_LE(drawn.offset.y, upper.y);
    restrictedX += drawn.offset.x;
    share = drawn.share;
  }
  EXPECT_NEAR(share, double(inside) / (double(n) * n), 2e-3);
  EXPECT_NEAR(restrictedX / n, insideX / inside, 2e-3);
}
