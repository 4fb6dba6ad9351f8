#include "penumbra/light_sampler.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>

namespace penumbra {
namespace {

constexpr int kBuckets = 12;
/// Deeper than this (in binary levels, two to a node of the tree) the build halves the list
/// instead of searching for the best split, so that leaf paths fit in 64 bits whatever the
/// lights' layout.
constexpr int kMaxSearchDepth = 32;

float surfaceArea(const LightBounds& bounds) {
  const Vec3f d = bounds.upper - bounds.lower;
  return 2 * (d.x * d.y + d.y * d.z + d.z * d.x);
}

/// The solid-angle measure of a bounds' emission directions (Conty Estevez & Kulla 2018, eq. 1):
/// how much of the sphere of directions its lights can send light into.
float orientationMeasure(const LightBounds& bounds) {
  const float thetaO = std::acos(std::clamp(bounds.cosThetaO, -1.0f, 1.0f));
  const float thetaE = std::acos(std::clamp(bounds.cosThetaE, -1.0f, 1.0f));
  const float thetaW = std::min(thetaO + thetaE, kPi);
  const float sinO = std::sin(thetaO), cosO = std::cos(thetaO);
  return 2 * kPi * (1 - cosO) +
         0.5f * kPi *
             (2 * thetaW * sinO - std::cos(thetaO - 2 * thetaW) - 2 * thetaO * sinO + cosO);
}

/// Surface-area-orientation heuristic cost of a group of lights (up to a common factor).
float splitCost(const LightBounds& bounds) {
  return bounds.power * orientationMeasure(bounds) * std::max(surfaceArea(bounds), 1e-12f);
}

/// A node at the levels the walk may split at is split by colour when it holds at least this
/// many lights and their chromaticities (radiance over luminance) spread by more than
/// kColourSplitSpread (a power-weighted standard deviation along an opponent-colour axis; a mix
/// of 2700 K and 6500 K lamps spreads by about 0.37, saturated hues by more), into two groups
/// each with at least kColourSplitMinShare of the power, whose means account for at least
/// kColourSplitMinSeparation of that spread's variance: colour groups, not an outlier or two
/// cut off from the rest (which would take a shadow ray of every point).
constexpr size_t kColourSplitMinLights = 16;
constexpr float kColourSplitSpread = 0.1f;
constexpr double kColourSplitMinShare = 0.25;
constexpr double kColourSplitMinSeparation = 0.5;

/// Where to split lights[begin, end) by colour (see above), after ordering them along the
/// opponent-colour axis (red-green, yellow-blue) their chromaticities spread most along: the cut
/// that separates them best (Otsu's, the most variance between the two groups' means). None
/// when they are not in colour groups.
std::optional<size_t> colourSplit(std::vector<uint32_t>& lights, size_t begin, size_t end,
                                  const std::vector<LightBounds>& bounds,
                                  const std::vector<Vec3f>& chromaticities) {
  const Vec3f axes[2] = {Vec3f(1, -1, 0) / std::sqrt(2.0f), Vec3f(1, 1, -2) / std::sqrt(6.0f)};
  double power = 0, widestVariance = double(kColourSplitSpread) * kColourSplitSpread;
  const Vec3f* axis = nullptr;
  for (const Vec3f& candidate : axes) {
    double sum = 0, sumOfSquares = 0;
    power = 0;
    for (size_t i = begin; i < end; ++i) {
      const double weight = bounds[lights[i]].power;
      const double x = dot(chromaticities[lights[i]], candidate);
      power += weight;
      sum += weight * x;
      sumOfSquares += weight * x * x;
    }
    const double mean = sum / power;
    const double variance = sumOfSquares / power - mean * mean;
    if (variance > widestVariance) {
      widestVariance = variance;
      axis = &candidate;
    }
  }
  if (!axis) return std::nullopt;
  const auto along = [&](uint32_t light) { return dot(chromaticities[light], *axis); };
  std::sort(lights.begin() + std::ptrdiff_t(begin), lights.begin() + std::ptrdiff_t(end),
            [&](uint32_t a, uint32_t b) {
              const float x = along(a), y = along(b);
              return x < y || (x == y && a < b);
            });
  double sum = 0;
  for (size_t i = begin; i < end; ++i) sum += bounds[lights[i]].power * along(lights[i]);
  // The variance between the groups' means is W_below W_above (mean_below - mean_above)² / W².
  double powerBelow = 0, sumBelow = 0, best = kColourSplitMinSeparation * widestVariance;
  std::optional<size_t> middle;
  for (size_t cut = begin + 1; cut < end; ++cut) {
    powerBelow += bounds[lights[cut - 1]].power;
    sumBelow += bounds[lights[cut - 1]].power * along(lights[cut - 1]);
    const double powerAbove = power - powerBelow;
    if (powerBelow < kColourSplitMinShare * power || powerAbove < kColourSplitMinShare * power)
      continue;
    const double difference = sumBelow / powerBelow - (sum - sumBelow) / powerAbove;
    const double between = powerBelow * powerAbove * difference * difference / (power * power);
    if (between > best) {
      best = between;
      middle = cut;
    }
  }
  return middle;
}

/// Where to cut lights[begin, end) (at least two lights) in two, reordering them: by colour at
/// the levels the walk may split at (`colourLevel`) when they are many lights of different
/// colours (see light_sampler.h); otherwise the cheapest cut into buckets along an axis of the
/// centroids' box; without one (all centroids together, or `binaryDepth` too deep), halfway.
size_t partition(std::vector<uint32_t>& lights, size_t begin, size_t end,
                 const std::vector<LightBounds>& bounds, const std::vector<Vec3f>& chromaticities,
                 int binaryDepth, bool colourLevel) {
  LightBounds centroids;
  for (size_t i = begin; i < end; ++i) {
    LightBounds point;
    point.lower = point.upper = bounds[lights[i]].centroid();
    point.power = 1;
    centroids = unite(centroids, point);
  }
  const std::optional<size_t> byColour =
      colourLevel && end - begin >= kColourSplitMinLights
          ? colourSplit(lights, begin, end, bounds, chromaticities)
          : std::nullopt;
  size_t middle = byColour ? *byColour : begin + (end - begin) / 2;
  float bestCost = kInfinity;
  int bestAxis = -1, bestBucket = 0;
  const Vec3f extent = centroids.upper - centroids.lower;
  for (int axis = 0; axis < 3 && !byColour && binaryDepth < kMaxSearchDepth; ++axis) {
    if (!(extent[axis] > 0)) continue;
    LightBounds buckets[kBuckets];
    const auto bucketOf = [&](uint32_t light) {
      const float t = (bounds[light].centroid()[axis] - centroids.lower[axis]) / extent[axis];
      return std::clamp(int(t * kBuckets), 0, kBuckets - 1);
    };
    for (size_t i = begin; i < end; ++i)
      buckets[bucketOf(lights[i])] = unite(buckets[bucketOf(lights[i])], bounds[lights[i]]);
    for (int split = 1; split < kBuckets; ++split) {
      LightBounds below, above;
      for (int b = 0; b < split; ++b) below = unite(below, buckets[b]);
      for (int b = split; b < kBuckets; ++b) above = unite(above, buckets[b]);
      if (!(below.power > 0) || !(above.power > 0)) continue;
      // Long thin boxes split across their length (the regularisation of Conty Estevez & Kulla).
      const float elongation = std::max({extent.x, extent.y, extent.z}) / extent[axis];
      const float cost = elongation * (splitCost(below) + splitCost(above));
      if (cost < bestCost) {
        bestCost = cost;
        bestAxis = axis;
        bestBucket = split;
      }
    }
    if (axis == bestAxis) {
      // Partition now, while bucketOf describes this axis.
      const auto firstAbove = std::partition(
          lights.begin() + std::ptrdiff_t(begin), lights.begin() + std::ptrdiff_t(end),
          [&](uint32_t light) { return bucketOf(light) < bestBucket; });
      middle = size_t(firstAbove - lights.begin());
    }
  }
  return middle;
}

}  // namespace

LightSampler::LightSampler(const std::vector<Light>& lights) : paths_(lights.size()) {
  std::vector<uint32_t> local;
  std::vector<LightBounds> bounds(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) {
    const Light& light = lights[i];
    if (light.isInfinite()) {
      const float irradiance = light.irradiance();
      const bool distant = light.type() == LightType::Distant;
      const float cosHalfAngle = distant ? light.cosHalfAngle() : 1.0f;
      if (irradiance > 0)
        infinite_.push_back({uint32_t(i), irradiance, distant ? light.towardsLight() : Vec3f(),
                             cosHalfAngle,
                             std::sqrt(std::max(0.0f, 1 - cosHalfAngle * cosHalfAngle))});
      continue;
    }
    bounds[i] = light.bounds();
    if (bounds[i].power > 0) local.push_back(uint32_t(i));
  }
  if (!local.empty()) {
    // Grey where the colour is not a colour: no luminance, or not finite.
    std::vector<Vec3f> chromaticities(lights.size(), Vec3f(1.0f));
    for (const uint32_t i : local) {
      const Vec3f radiance = componentMax(lights[i].meanRadiance(), Vec3f(0.0f));
      const Vec3f chromaticity = radiance / luminance(radiance);
      if (std::isfinite(chromaticity.x) && std::isfinite(chromaticity.y) &&
          std::isfinite(chromaticity.z))
        chromaticities[i] = chromaticity;
    }
    if (local.size() == 1) {
      loneLight_ = local[0];
      paths_[local[0]] = {0, 0};
    } else {
      nodes_.reserve(local.size() - 1);  // every node has two children or more
      build(local, 0, local.size(), bounds, chromaticities, {0, 0});
    }
  }
}

std::pair<uint32_t, LightBounds> LightSampler::build(std::vector<uint32_t>& lights, size_t begin,
                                                     size_t end,
                                                     const std::vector<LightBounds>& bounds,
                                                     const std::vector<Vec3f>& chromaticities,
                                                     LeafPath path) {
  const uint32_t index = uint32_t(nodes_.size());
  nodes_.emplace_back();
  // Two levels of a binary build: the list cut in two, and each part of several lights cut
  // again, give the node's (up to four) children. A node at depth d is at binary depth 2d, and
  // binary depths stay within 64 (kMaxSearchDepth searched levels, then at most 32 halvings of
  // fewer than 2^32 lights), so paths (two bits a level) fit in 64 bits.
  const int binaryDepth = 2 * path.depth;
  const bool colourLevel = path.depth == 0;  // the root, where the walk splits
  std::array<size_t, kBranching + 1> cuts{};
  int groups = 0;
  cuts[0] = begin;
  const size_t middle =
      partition(lights, begin, end, bounds, chromaticities, binaryDepth, colourLevel);
  for (const auto& [from, to] : {std::pair(begin, middle), std::pair(middle, end)}) {
    if (to - from > 1)
      cuts[++groups] =
          partition(lights, from, to, bounds, chromaticities, binaryDepth + 1, colourLevel);
    cuts[++groups] = to;
  }
  LightBounds all;
  for (int child = 0; child < groups; ++child) {
    const LeafPath childPath{path.branches | (uint64_t(child) << (2 * path.depth)), path.depth + 1};
    const bool isLight = cuts[child + 1] - cuts[child] == 1;
    uint32_t childIndex = 0;
    LightBounds childBounds;
    if (isLight) {
      childIndex = lights[cuts[child]];
      childBounds = bounds[childIndex];
      paths_[childIndex] = childPath;
    } else {
      std::tie(childIndex, childBounds) =
          build(lights, cuts[child], cuts[child + 1], bounds, chromaticities, childPath);
    }
    Node& node = nodes_[index];
    node.children[child] = childIndex;
    node.childLights |= uint8_t(uint8_t(isLight) << child);
    node.childClusters.set(child, childBounds);
    all = unite(all, childBounds);
  }
  nodes_[index].center = all.centroid();
  nodes_[index].halfDiagonal2 = all.halfDiagonal2();
  return {index, all};
}

int LightSampler::treeDepth() const {
  int depth = 0;
  for (const LeafPath& path : paths_) depth = std::max(depth, path.depth);
  return depth;
}

float LightSampler::infiniteWeight(size_t i, const Receiver& receiver) const {
  const InfiniteLight& light = infinite_[i];
  if (isBlack(light.towardsLight) || isBlack(receiver.normal)) return light.irradiance;
  // A distant light lights a surface by the cosine of its nearest direction, on either side; a
  // floor keeps lights in the surface's plane selectable.
  const float cosCenter = std::min(std::fabs(dot(light.towardsLight, receiver.normal)), 1.0f);
  // cos(max(0, centre angle − half-angle)), without inverse trigonometry.
  const float cosNearest = cosCenter >= light.cosHalfAngle
                               ? 1.0f
                               : cosCenter * light.cosHalfAngle +
                                     std::sqrt(1 - cosCenter * cosCenter) * light.sinHalfAngle;
  return light.irradiance * std::max(cosNearest, 1e-3f);
}

float LightSampler::infiniteTotal(const Receiver& receiver) const {
  float total = 0;
  for (size_t i = 0; i < infinite_.size(); ++i) total += infiniteWeight(i, receiver);
  return total;
}

LightSampler::ChildWeights LightSampler::weigh(const std::array<float, kBranching>& importance) {
  ChildWeights weights;
  weights.importance = importance;
  for (int child = 0; child < kBranching; ++child) {
    weights.before[child] = weights.total;
    weights.total += weights.importance[child];
  }
  return weights;
}

bool LightSampler::splits(const Node& node, const Receiver& receiver) const {
  const Vec3f offset = receiver.position - node.center;
  return dot(offset, offset) < node.halfDiagonal2;
}

void LightSampler::chooseLocal(const Receiver& receiver, const Sample4D& u,
                               LocalChoices& local) const {
  local.count = 0;
  if (nodes_.empty() && !loneLight_) return;
  // The root's own importance is not asked first: a lone light's sample says itself where it
  // gives nothing (most scenes have one), and among several the walk finds no child reaching.
  // The nodes the walk splits into, each reached with probability 1.
  struct Walk {
    uint32_t node = 0;  // or, where it has arrived, the light's index
    float u = 0;
    float probability = 1;
    bool arrived = false;  // at a light
    bool lost = false;     // none of the node's children's lights reach the receiver
  };
  static_assert(kMaxLocalChoices == 4, "one number of the 4D draw per walk");
  const float numbers[kMaxLocalChoices] = {u.y, u.z, u.w, u.x};
  Walk walks[kMaxLocalChoices];
  size_t count = 0;
  if (loneLight_) {
    walks[count++] = Walk{*loneLight_, numbers[0], 1, true};
  } else if (const Node& root = nodes_[0]; splits(root, receiver)) {
    const std::array<float, kBranching> importance = root.childClusters.importance(receiver);
    for (int child = 0; child < kBranching; ++child)
      if (importance[child] > 0) {
        walks[count] =
            Walk{root.children[child], numbers[count], 1, bool((root.childLights >> child) & 1u)};
        ++count;
      }
  } else {
    walks[count++] = Walk{0, numbers[0]};
  }
  // Each step takes every walk one level down, its nodes weighed in one call.
  for (;;) {
    const LightClusters* weighed[kMaxLocalChoices];
    size_t stepping[kMaxLocalChoices], steps = 0;
    for (size_t i = 0; i < count; ++i)
      if (!walks[i].lost && !walks[i].arrived) {
        weighed[steps] = &nodes_[walks[i].node].childClusters;
        stepping[steps++] = i;
      }
    if (steps == 0) break;
    std::array<float, kBranching> importances[kMaxLocalChoices];
    LightClusters::importances(weighed, steps, receiver, importances);
    for (size_t step = 0; step < steps; ++step) {
      Walk& walk = walks[stepping[step]];
      const ChildWeights weights = weigh(importances[step]);
      if (!(weights.total > 0 && weights.total < kInfinity)) {  // none reach it, or overflow
        walk.lost = true;
        continue;
      }
      // The child whose share of the total holds u, counted without branches: which child is a
      // coin toss the processor cannot predict. Empty children have no share; only a product
      // rounded up to the total lands past the last child with one.
      const float x = walk.u * weights.total;
      int child = 0;
      for (int k = 1; k < kBranching; ++k) child += int(x >= weights.before[k]);
      while (!(weights.importance[child] > 0)) --child;
      walk.u = std::min((x - weights.before[child]) / weights.importance[child], 0x1.fffffep-1f);
      walk.probability *= weights.importance[child] / weights.total;
      const Node& parent = nodes_[walk.node];
      walk.node = parent.children[child];
      walk.arrived = (parent.childLights >> child) & 1u;
    }
  }
  uint32_t slot = uint32_t(kInfiniteLightsSampledEach);
  for (size_t i = 0; i < count; ++i)
    if (!walks[i].lost)
      local.choices[local.count++] = Choice{walks[i].node, walks[i].probability, slot++};
}

std::optional<LightSampler::Choice> LightSampler::sampleInfinite(const Receiver& receiver,
                                                                 float u) const {
  if (infinite_.empty()) return std::nullopt;
  const float total = infiniteTotal(receiver);
  float cumulative = 0;
  for (size_t i = 0; i < infinite_.size(); ++i) {
    const float weight = infiniteWeight(i, receiver);
    cumulative += weight;
    if (u * total < cumulative || i + 1 == infinite_.size())
      return Choice{infinite_[i].index, weight / total};
  }
  return std::nullopt;
}

float LightSampler::probability(const Receiver& receiver, size_t index) const {
  const LeafPath& path = paths_[index];
  if (path.depth >= 0) {
    float probability = 1;
    uint32_t node = 0;
    for (int level = 0; level < path.depth; ++level) {
      const Node& parent = nodes_[node];
      const int branch = int((path.branches >> (2 * level)) & 3u);
      node = parent.children[branch];
      if (level == 0 && splits(parent, receiver)) {
        if (!(parent.childClusters.importance(receiver)[branch] > 0)) return 0;
        continue;
      }
      const ChildWeights weights = weigh(parent.childClusters.importance(receiver));
      if (!(weights.total > 0 && weights.total < kInfinity) || !(weights.importance[branch] > 0))
        return 0;
      probability *= weights.importance[branch] / weights.total;
    }
    return probability;
  }
  for (size_t i = 0; i < infinite_.size(); ++i)
    if (infinite_[i].index == index)
      return infinite_.size() <= kInfiniteLightsSampledEach
                 ? 1.0f
                 : infiniteWeight(i, receiver) / infiniteTotal(receiver);
  return 0;
}

}  // namespace penumbra
