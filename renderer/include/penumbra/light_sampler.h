// Choosing the light that next-event estimation samples at a shading point.
//
// Lights fall into two sets that are estimated differently, so that neither starves the other:
// infinite lights (dome, distant), whose contribution does not depend on where the point is, and
// local lights, organised in a light tree (Conty Estevez & Kulla 2018, "Importance Sampling of
// Many Lights with Adaptive Tree Splitting"): each node bounds its lights' positions, emitted
// power and emission directions, and a single walk from the root picks a light with probability
// proportional to the bound on what each subtree can contribute to the point. The set itself is
// chosen per point in proportion to the two estimates (kept within [kMinSetShare, 1 -
// kMinSetShare] when both sets are present, because neither estimate knows about occlusion).
//
// Every probability is a pure function of (point, normal, light), so that the integrator can
// weigh emission met by BSDF-sampled rays against light sampling (multiple importance sampling).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "penumbra/light.h"

namespace penumbra {

class LightSampler {
 public:
  /// Share of light samples each set keeps, whatever the estimates say, when both are present.
  static constexpr float kMinSetShare = 0.25f;

  LightSampler() = default;
  explicit LightSampler(const std::vector<Light>& lights);

  struct Choice {
    size_t index = 0;
    float probability = 0;
  };
  /// A light for next-event estimation at the receiver, from one uniform number; none when no
  /// light can reach it.
  std::optional<Choice> sample(const Receiver& receiver, float u) const;
  /// The probability that sample() picks light `index` at the receiver.
  float probability(const Receiver& receiver, size_t index) const;

  /// Depth of the light tree (for tests and statistics).
  int treeDepth() const;

 private:
  struct Node {
    LightBounds bounds;
    uint32_t children[2] = {0, 0};  // interior nodes
    uint32_t light = 0;             // leaves: the light's index
    bool leaf = false;
  };
  /// Where a local light's leaf is: the branch taken at each level, from the root.
  struct LeafPath {
    uint64_t branches = 0;  // bit k: 1 for the second child at depth k
    int depth = -1;         // -1: not a local light
  };

  /// Builds the subtree of lights[begin, end) whose root is reached by `path`; returns its index.
  uint32_t build(std::vector<uint32_t>& lights, size_t begin, size_t end,
                 const std::vector<LightBounds>& bounds, LeafPath path);
  /// The probability that the walk goes from `parent` to its first child at the receiver; none
  /// where neither child's lights can reach it.
  std::optional<float> firstChildProbability(const Node& parent, const Receiver& receiver) const;
  /// Probability of choosing the local set at the receiver (0 or 1 when a set is empty).
  float localShare(const Receiver& receiver) const;
  /// Estimated irradiance of infinite light `i` (of infinite_) at the receiver; never 0.
  float infiniteWeight(size_t i, const Receiver& receiver) const;
  float infiniteTotal(const Receiver& receiver) const;

  struct InfiniteLight {
    uint32_t index = 0;
    float irradiance = 0;    // on a surface facing it, unoccluded
    Vec3f towardsLight;      // distant lights: the direction light comes from; dome: zero
    float cosHalfAngle = 1;  // distant lights: the cone's half-angle, as cosine and sine
    float sinHalfAngle = 0;
  };

  std::vector<Node> nodes_;      // nodes_[0] is the root, when there are local lights
  std::vector<LeafPath> paths_;  // by light index
  std::vector<InfiniteLight> infinite_;
};

}  // namespace penumbra
