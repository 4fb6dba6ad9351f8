// Path guiding: where indirect light comes from, learnt from the first samples of a render and
// then sampled beside the BSDF (docs/path-guiding.md).
//
// Training records, at every opaque rough surface vertex of the first samples' paths, the
// direction the path left in and the light it brought back (radiance over the direction's
// density: a Monte Carlo estimate of incident flux). GuidingField::build divides space by a
// k-d tree until each cell holds few enough records, and gives every cell a distribution over
// the sphere of directions (for each of six surface orientations apart): a quadtree over the
// cylindrical map (cos θ, φ), which preserves area, refined where the cell's flux is concentrated
// (Müller et al. 2017, "Practical Path Guiding", with one training pass and no product with the
// BSDF). The integrator then draws directions from the cell's distribution or the BSDF by
// one-sample MIS (their densities mixed), with a probability learnt per cell: the one that
// would have given the cell's training records the least variance (0 where the guide would
// not help, and then the cell has no distribution at all).
//
// Determinism: build sorts the records by their key (pixel, sample, vertex) before anything
// else, so the field is the same whatever order threads recorded them in, for the whole image
// or any crop of it trained over the whole image.
#pragma once

#include <tbb/enumerable_thread_specific.h>

#include <cstdint>
#include <vector>

#include "penumbra/math.h"

namespace penumbra {

/// One vertex of a training path: where it was, the direction the path left in (the
/// cylindrical map's coordinates) and the flux estimate it brought back.
struct GuidingRecord {
  Vec3f position;
  Vec2f direction;  // [0, 1)²: ((cos θ + 1) / 2, φ / 2π) in world space
  float flux = 0;   // luminance of the incident radiance found, over the direction's density
  /// The density the direction was drawn with (the BSDF's), and the luminance of the vertex's
  /// estimate of its reflected light (f·|cos θ|·radiance over that density): what choosing
  /// the guide's probability weighs (GuidingField::Settings::minSecondMomentGain).
  float sampledPdf = 0;
  float estimate = 0;
  uint32_t orientation = 0;  // orientationOf the surface's normal
  uint64_t key = 0;          // GuidingRecord::makeKey: a total order independent of threads

  /// Unique per record of a render: the image pixel, the sample index (below 2^16) and the
  /// vertex's place along the path (below 2^8).
  static uint64_t makeKey(uint32_t x, uint32_t y, uint32_t sample, uint32_t vertex) {
    return (uint64_t(y) << 44) | (uint64_t(x) << 24) | (uint64_t(sample & 0xffffu) << 8) |
           uint64_t(vertex & 0xffu);
  }
};

/// Which of six classes a surface normal belongs to (its largest component's axis and sign):
/// the field learns each apart, so that a cell holding surfaces that face different ways (a
/// floor and a wall) does not send one's paths where only the other's light comes from.
uint32_t orientationOf(const Vec3f& normal);
constexpr uint32_t kOrientations = 6;

/// The cylindrical map of a unit direction to [0, 1)² (area-preserving: density on the square
/// is 4π times density in solid angle) and back.
Vec2f directionToSquare(const Vec3f& direction);
Vec3f squareToDirection(const Vec2f& square);

/// Collects records from many threads.
class GuidingRecorder {
 public:
  void add(const GuidingRecord* records, size_t count);
  /// Every record so far, in no particular order; the recorder is left empty.
  std::vector<GuidingRecord> take();
  void clear() { perThread_.clear(); }

 private:
  tbb::enumerable_thread_specific<std::vector<GuidingRecord>> perThread_;
};

/// A distribution over directions: a quadtree over the cylindrical square, and how often a
/// guided vertex draws from it rather than from its BSDF.
class DirectionalDistribution {
 public:
  /// Draws a direction: `uChoice` descends the tree, `u` places the direction in its leaf;
  /// `*pdf`: its solid-angle density (the leaf's, without mapping the direction back).
  Vec3f sample(float uChoice, Vec2f u, float* pdf) const;
  /// Solid-angle density of sample() at `direction`.
  float pdf(const Vec3f& direction) const;
  /// The share of a guided vertex's directions drawn from this distribution, in (0, 1).
  float guideProbability() const { return guideProbability_; }

 private:
  friend class GuidingField;
  /// Node i's children are nodes children[i] .. children[i] + 3 (quadrants in the order
  /// (low, low), (high, low), (low, high), (high, high) of (u, v)); 0: a leaf.
  std::vector<uint32_t> children_;
  std::vector<float> share_;    // of the root's flux
  std::vector<float> density_;  // leaves: the solid-angle density sample() gives them
  float guideProbability_ = 0;
};

class GuidingField {
 public:
  struct Settings {
    /// A spatial cell is split while it holds more records than this.
    uint32_t maxRecordsPerCell = 4000;
    /// Cells with fewer records do not guide (their distribution would be noise).
    uint32_t minRecordsPerCell = 64;
    /// A directional node is split while it holds more than this share of its cell's flux.
    float splitShare = 0.02f;
    /// ... and holds at least this many records.
    uint32_t minRecordsToSplit = 64;
    int maxDirectionalDepth = 7;  // 128 x 128 directions at the finest
    /// A cell guides only where the best guide probability would have cut the second moment
    /// of its training records' estimates by at least this share (which also pays for the
    /// guide's lookups); elsewhere it has no distribution and its vertices sample the BSDF.
    float minSecondMomentGain = 0.1f;
  };

  GuidingField() = default;
  /// Builds the field from every record of the training samples.
  static GuidingField build(std::vector<GuidingRecord> records, const Settings& settings);
  static GuidingField build(std::vector<GuidingRecord> records) {
    return build(std::move(records), Settings());
  }

  /// The distribution of the cell holding `position` on a surface facing `normal`, or nullptr
  /// where the field does not guide.
  const DirectionalDistribution* at(const Vec3f& position, const Vec3f& normal) const;
  /// Whether any cell guides (where none does, at() answers without descending the cells).
  bool guides() const { return !distributions_.empty(); }

 private:
  struct Node {
    float split = 0;    // inner nodes: the plane's coordinate along `axis`
    uint32_t axis = 0;  // 0..2: an inner node; 3: a leaf
    /// Inner nodes: the child below the plane (the one above follows it); leaves: the index
    /// of the cell's distribution, or kNoDistribution.
    uint32_t index = 0;
  };
  static constexpr uint32_t kLeaf = 3;
  static constexpr uint32_t kNoDistribution = ~0u;

  std::vector<Node> nodes_;
  std::vector<DirectionalDistribution> distributions_;
};

}  // namespace penumbra
