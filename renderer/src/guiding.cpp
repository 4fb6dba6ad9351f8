#include "penumbra/guiding.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace penumbra {
namespace {

constexpr float kSquareToSolidAngle = 1 / (4 * kPi);  // density on the square → per steradian
constexpr int kMaxSpatialDepth = 48;                  // coincident records cannot be split apart
/// The guide probabilities a cell chooses from (GuidingField::build).
constexpr std::array<float, 6> kGuideProbabilities{0.125f, 0.25f, 0.375f, 0.5f, 0.625f, 0.75f};

float coordinate(const Vec3f& v, uint32_t axis) {
  return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
}

/// The child (0..3) of a quadtree node whose square holds `point`, and `point` in the
/// child's square.
int quadrant(Vec2f* point) {
  const int high_u = point->x >= 0.5f, high_v = point->y >= 0.5f;
  point->x = std::min(2 * point->x - float(high_u), 1.0f);
  point->y = std::min(2 * point->y - float(high_v), 1.0f);
  return high_u + 2 * high_v;
}

/// Flux and record counts summed over a square grid at every resolution from 1 x 1 to
/// 2^depth x 2^depth.
class FluxPyramid {
 public:
  explicit FluxPyramid(int depth) : flux_(size_t(depth) + 1), counts_(size_t(depth) + 1) {
    for (int level = 0; level <= depth; ++level) {
      flux_[size_t(level)].assign(size_t(1) << (2 * level), 0.0f);
      counts_[size_t(level)].assign(size_t(1) << (2 * level), 0);
    }
  }
  int depth() const { return int(flux_.size()) - 1; }
  /// The finest level's column and row holding `square`.
  std::array<size_t, 2> finest(const Vec2f& square) const {
    const int resolution = 1 << depth();
    return {size_t(std::min(int(square.x * float(resolution)), resolution - 1)),
            size_t(std::min(int(square.y * float(resolution)), resolution - 1))};
  }
  void add(const Vec2f& square, float flux) {
    const auto [u, v] = finest(square);
    const size_t cell = index(depth(), u, v);
    flux_.back()[cell] += flux;
    ++counts_.back()[cell];
  }
  /// Fills the coarser levels from the finest.
  void sumUp() {
    for (int level = depth() - 1; level >= 0; --level) {
      sumLevel(flux_, level);
      sumLevel(counts_, level);
    }
  }
  float flux(int level, size_t u, size_t v) const {
    return flux_[size_t(level)][index(level, u, v)];
  }
  uint32_t count(int level, size_t u, size_t v) const {
    return counts_[size_t(level)][index(level, u, v)];
  }

 private:
  static size_t index(int level, size_t u, size_t v) { return v * (size_t(1) << level) + u; }
  template <class T>
  static void sumLevel(std::vector<std::vector<T>>& levels, int level) {
    const size_t resolution = size_t(1) << level, fine = 2 * resolution;
    const std::vector<T>& finer = levels[size_t(level) + 1];
    for (size_t v = 0; v < resolution; ++v)
      for (size_t u = 0; u < resolution; ++u) {
        const size_t corner = 2 * v * fine + 2 * u;
        levels[size_t(level)][v * resolution + u] =
            finer[corner] + finer[corner + 1] + finer[corner + fine] + finer[corner + fine + 1];
      }
  }

  std::vector<std::vector<float>> flux_;
  std::vector<std::vector<uint32_t>> counts_;
};

}  // namespace

uint32_t orientationOf(const Vec3f& normal) {
  const Vec3f a{std::abs(normal.x), std::abs(normal.y), std::abs(normal.z)};
  const uint32_t axis = a.x >= a.y && a.x >= a.z ? 0 : a.y >= a.z ? 1 : 2;
  return 2 * axis + (coordinate(normal, axis) < 0 ? 1 : 0);
}

Vec2f directionToSquare(const Vec3f& direction) {
  const float cosTheta = std::clamp(direction.z, -1.0f, 1.0f);
  float phi = std::atan2(direction.y, direction.x);
  if (phi < 0) phi += 2 * kPi;
  return {std::clamp((cosTheta + 1) * 0.5f, 0.0f, 1.0f), std::clamp(phi / (2 * kPi), 0.0f, 1.0f)};
}

Vec3f squareToDirection(const Vec2f& square) {
  const float cosTheta = 2 * square.x - 1;
  const float sinTheta = std::sqrt(std::max(0.0f, 1 - cosTheta * cosTheta));
  const float phi = 2 * kPi * square.y;
  return {sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta};
}

void GuidingRecorder::add(const GuidingRecord* records, size_t count) {
  std::vector<GuidingRecord>& mine = perThread_.local();
  mine.insert(mine.end(), records, records + count);
}

std::vector<GuidingRecord> GuidingRecorder::take() {
  size_t total = 0;
  for (const std::vector<GuidingRecord>& records : perThread_) total += records.size();
  std::vector<GuidingRecord> all;
  all.reserve(total);
  for (const std::vector<GuidingRecord>& records : perThread_)
    all.insert(all.end(), records.begin(), records.end());
  perThread_.clear();
  return all;
}

Vec3f DirectionalDistribution::sample(float uChoice, Vec2f u, float* pdf) const {
  uint32_t node = 0;
  Vec2f origin{0, 0};
  float size = 1;
  while (children_[node] != 0) {
    const uint32_t first = children_[node];
    std::array<float, 4> shares{};
    float total = 0;
    for (int k = 0; k < 4; ++k) total += shares[size_t(k)] = share_[first + uint32_t(k)];
    // The last child with any flux takes what rounding leaves of the choice.
    int chosen = 3;
    while (chosen > 0 && shares[size_t(chosen)] <= 0) --chosen;
    float below = 0;
    const float target = uChoice * total;
    for (int k = 0; k < chosen; ++k) {
      if (target < below + shares[size_t(k)] && shares[size_t(k)] > 0) {
        chosen = k;
        break;
      }
      below += shares[size_t(k)];
    }
    uChoice = std::clamp((target - below) / shares[size_t(chosen)], 0.0f, 0x1.fffffep-1f);
    size *= 0.5f;
    origin.x += size * float(chosen & 1);
    origin.y += size * float(chosen >> 1);
    node = first + uint32_t(chosen);
  }
  *pdf = density_[node];
  return squareToDirection(
      {std::min(origin.x + size * u.x, 1.0f), std::min(origin.y + size * u.y, 1.0f)});
}

float DirectionalDistribution::pdf(const Vec3f& direction) const {
  Vec2f point = directionToSquare(direction);
  uint32_t node = 0;
  while (children_[node] != 0) node = children_[node] + uint32_t(quadrant(&point));
  return density_[node];
}

GuidingField GuidingField::build(std::vector<GuidingRecord> records, const Settings& settings) {
  GuidingField field;
  if (records.empty()) return field;
  tbb::parallel_sort(records.begin(), records.end(),
                     [](const GuidingRecord& a, const GuidingRecord& b) { return a.key < b.key; });
  Vec3f lower = records.front().position, upper = lower;
  for (const GuidingRecord& record : records) {
    lower = componentMin(lower, record.position);
    upper = componentMax(upper, record.position);
  }

  // The k-d tree: each cell is split at the middle of its longest side until it holds few
  // enough records; both children of a node are allocated together.
  struct Job {
    uint32_t node;
    size_t begin, end;
    Vec3f lower, upper;
    int depth;
  };
  struct Cell {
    uint32_t node;
    size_t begin, end;
  };
  std::vector<Cell> cells;
  // One tree per orientation: its root is node `orientation`.
  std::stable_sort(
      records.begin(), records.end(),
      [](const GuidingRecord& a, const GuidingRecord& b) { return a.orientation < b.orientation; });
  std::vector<Job> jobs;
  field.nodes_.resize(kOrientations);
  size_t begin = 0;
  for (uint32_t orientation = 0; orientation < kOrientations; ++orientation) {
    size_t end = begin;
    while (end < records.size() && records[end].orientation == orientation) ++end;
    jobs.push_back({orientation, begin, end, lower, upper, 0});
    begin = end;
  }
  while (!jobs.empty()) {
    const Job job = jobs.back();
    jobs.pop_back();
    const size_t count = job.end - job.begin;
    if (count <= settings.maxRecordsPerCell || job.depth >= kMaxSpatialDepth) {
      field.nodes_[job.node].axis = kLeaf;
      field.nodes_[job.node].index = kNoDistribution;
      if (count >= settings.minRecordsPerCell) cells.push_back({job.node, job.begin, job.end});
      continue;
    }
    const Vec3f extent = job.upper - job.lower;
    const uint32_t axis = extent.x >= extent.y && extent.x >= extent.z ? 0
                          : extent.y >= extent.z                       ? 1
                                                                       : 2;
    const float split = 0.5f * (coordinate(job.lower, axis) + coordinate(job.upper, axis));
    const auto middle = std::stable_partition(
        records.begin() + std::ptrdiff_t(job.begin), records.begin() + std::ptrdiff_t(job.end),
        [&](const GuidingRecord& r) { return coordinate(r.position, axis) < split; });
    const size_t middleIndex = size_t(middle - records.begin());
    const uint32_t below = uint32_t(field.nodes_.size());
    field.nodes_.emplace_back();
    field.nodes_.emplace_back();
    field.nodes_[job.node] = {split, axis, below};
    Vec3f belowUpper = job.upper, aboveLower = job.lower;
    (axis == 0 ? belowUpper.x : axis == 1 ? belowUpper.y : belowUpper.z) = split;
    (axis == 0 ? aboveLower.x : axis == 1 ? aboveLower.y : aboveLower.z) = split;
    jobs.push_back({below, job.begin, middleIndex, job.lower, belowUpper, job.depth + 1});
    jobs.push_back({below + 1, middleIndex, job.end, aboveLower, job.upper, job.depth + 1});
  }

  // Each cell's directional quadtree, from its records' flux on the finest grid.
  std::vector<DirectionalDistribution> built(cells.size());
  std::vector<char> usable(cells.size(), 0);
  tbb::parallel_for(size_t(0), cells.size(), [&](size_t c) {
    const Cell& cell = cells[c];
    const auto fluxOf = [](const GuidingRecord& record) {
      return record.flux > 0 && std::isfinite(record.flux) ? record.flux : 0.0f;
    };
    FluxPyramid pyramid(settings.maxDirectionalDepth);
    for (size_t i = cell.begin; i < cell.end; ++i)
      pyramid.add(records[i].direction, fluxOf(records[i]));
    pyramid.sumUp();
    const float total = pyramid.flux(0, 0, 0);
    if (!(total > 0) || !std::isfinite(total)) return;
    DirectionalDistribution& distribution = built[c];
    struct Square {
      uint32_t node;
      int level;
      size_t u, v;
    };
    distribution.children_.push_back(0);
    distribution.share_.push_back(1);
    distribution.density_.push_back(kSquareToSolidAngle);
    std::vector<Square> queue{{0, 0, 0, 0}};
    for (size_t q = 0; q < queue.size(); ++q) {
      const Square square = queue[q];
      const float share = distribution.share_[square.node];
      // A node is refined where it holds much of the flux, and records enough that this is
      // not one bright sample's noise.
      if (square.level >= pyramid.depth() || share <= settings.splitShare ||
          pyramid.count(square.level, square.u, square.v) < settings.minRecordsToSplit)
        continue;
      const uint32_t first = uint32_t(distribution.share_.size());
      distribution.children_[square.node] = first;
      float childrenShare = 0;
      for (size_t k = 0; k < 4; ++k) {
        const size_t u = 2 * square.u + (k & 1), v = 2 * square.v + (k >> 1);
        distribution.children_.push_back(0);
        childrenShare +=
            distribution.share_.emplace_back(pyramid.flux(square.level + 1, u, v) / total);
        queue.push_back({first + uint32_t(k), square.level + 1, u, v});
      }
      // sample() picks a child by its share of the four: its density on the square is the
      // parent's times 4 times that.
      for (uint32_t k = 0; k < 4; ++k)
        distribution.density_.push_back(distribution.density_[square.node] *
                                        (4 * distribution.share_[first + k] / childrenShare));
    }

    // The guide probability α: the one under which the cell's training estimates c (drawn
    // from the BSDF's density p) would have had the least second moment, E_p[c² p / q] with
    // q = α g + (1 − α) p, against E_p[c²] without guiding. g at each record leaves out the
    // record's own flux, so that a lone bright record does not vouch for the guide it shaped.
    std::array<double, kGuideProbabilities.size()> guided{};
    double unguided = 0;
    const int depth = pyramid.depth();
    for (size_t i = cell.begin; i < cell.end; ++i) {
      const GuidingRecord& record = records[i];
      const float estimate = std::isfinite(record.estimate) ? record.estimate : 0.0f;
      if (!(estimate > 0) || !(record.sampledPdf > 0) || !std::isfinite(record.sampledPdf))
        continue;
      // The record's leaf, found by the finest grid cell it was counted in.
      const auto [u, v] = pyramid.finest(record.direction);
      uint32_t node = 0;
      int level = 0;
      while (distribution.children_[node] != 0) {
        ++level;
        const int shift = depth - level;
        node =
            distribution.children_[node] + uint32_t(((u >> shift) & 1) | (((v >> shift) & 1) << 1));
      }
      const int shift = depth - level;
      const float flux = fluxOf(record);
      const float othersFlux = total - flux;
      const float leafFlux = std::max(pyramid.flux(level, u >> shift, v >> shift) - flux, 0.0f);
      const double guidePdf = othersFlux > 0
                                  ? double(leafFlux) / othersFlux *
                                        double(size_t(1) << (2 * level)) * kSquareToSolidAngle
                                  : 0.0;
      const double p = record.sampledPdf, squared = double(estimate) * estimate;
      unguided += squared;
      for (size_t a = 0; a < kGuideProbabilities.size(); ++a) {
        const double alpha = kGuideProbabilities[a];
        guided[a] += squared * p / (alpha * guidePdf + (1 - alpha) * p);
      }
    }
    const size_t best = size_t(std::min_element(guided.begin(), guided.end()) - guided.begin());
    if (!(guided[best] < (1 - double(settings.minSecondMomentGain)) * unguided)) return;
    distribution.guideProbability_ = kGuideProbabilities[best];
    usable[c] = 1;
  });
  for (size_t c = 0; c < cells.size(); ++c) {
    if (!usable[c]) continue;
    field.nodes_[cells[c].node].index = uint32_t(field.distributions_.size());
    field.distributions_.push_back(std::move(built[c]));
  }
  return field;
}

const DirectionalDistribution* GuidingField::at(const Vec3f& position, const Vec3f& normal) const {
  if (!guides()) return nullptr;  // no descent where no cell guides (open scenes)
  const Node* node = &nodes_[orientationOf(normal)];
  while (node->axis != kLeaf)
    node = &nodes_[node->index + (coordinate(position, node->axis) < node->split ? 0 : 1)];
  return node->index == kNoDistribution ? nullptr : &distributions_[node->index];
}

}  // namespace penumbra
