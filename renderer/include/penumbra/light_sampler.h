// Choosing the light that next-event estimation samples at a shading point.
//
// Lights fall into two sets, each sampled once per shading point, so that neither starves the
// other (choosing between them by estimated contribution cannot know about occlusion, and a
// wrong guess there is the largest source of noise in scenes lit by a sky and a lamp):
// - infinite lights (dome, distant), whose contribution does not depend on where the point is:
//   each of them is sampled when there are at most kInfiniteLightsSampledEach (a sun and a sky
//   then never compete), otherwise one, chosen by its estimated irradiance;
// - local lights, organised in a light tree (Conty Estevez & Kulla 2018, "Importance Sampling of
//   Many Lights with Adaptive Tree Splitting"): each node bounds its lights' positions, emitted
//   power and emission directions, and a walk from the root picks one light with probability
//   proportional to the bound on what each subtree can contribute to the point. The tree is
//   4-wide (each node is two levels of a binary build, whose four groups are weighed at once in
//   SIMD lanes): half the levels, so half the serial chain of square roots and divisions a walk
//   waits on, and a choice among four tighter bounds instead of two looser ones and then two
//   more. Where the point lies within the root's bounding sphere, the bound says least about
//   which child gives more: there the walk splits and goes down every child of the root
//   (adaptive tree splitting, Conty Estevez & Kulla 2018 §5), so that up to kMaxLocalChoices
//   local lights are sampled at a point among many lights, each walk with a number of its own.
//   The root's two binary levels split many lights of different colours by colour rather than
//   by place: the walk chooses by a grey power (LightBounds), so among many lights of every hue
//   the colour of the few sampled at a point is most of the noise; one light from each colour
//   group is much less so, while the walk below still chooses by place (with fewer lights per
//   group the samples of a pixel already spread over them). The groups each span the lights'
//   extent, so near its edge a point splits where it would not have by place (more shadow rays),
//   and warm and cool lamps mixed are grouped by colour too.
//
// Each choice is a strategy of its own, so the estimate sums them. Every probability is a pure
// function of (point, normal, light), so that the integrator can weigh emission met by
// BSDF-sampled rays against light sampling (multiple importance sampling).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "penumbra/light.h"
#include "penumbra/sampler.h"

namespace penumbra {

class LightSampler {
 public:
  /// Up to this many infinite lights, each is sampled at every shading point.
  static constexpr size_t kInfiniteLightsSampledEach = 4;
  /// Children of a light-tree node: one per lane of LightClusters.
  static constexpr int kBranching = LightClusters::kLanes;
  static_assert(kBranching == 4, "a node is two levels of the binary build");
  /// Local lights sampled at a point at most: one per child of the root, where the walk splits.
  static constexpr uint32_t kMaxLocalChoices = uint32_t(kBranching);

  LightSampler() = default;
  explicit LightSampler(const std::vector<Light>& lights);

  struct Choice {
    size_t index = 0;
    float probability = 0;
    /// Which of the point's kMaxChoices light samples this choice takes: infinite lights the
    /// first kInfiniteLightsSampledEach, local lights the rest, so that the lights of one set
    /// draw the same numbers whatever the other set holds.
    uint32_t slot = 0;
  };
  /// At most this many choices per shading point: every infinite light sampled each, and as
  /// many local lights as the splitting walk can reach.
  static constexpr uint32_t kMaxChoices = uint32_t(kInfiniteLightsSampledEach) + kMaxLocalChoices;

  /// Calls `visit(Choice)` for each light next-event estimation samples at the receiver (see
  /// above), at most kMaxChoices times, with the numbers of one 4D draw: `u.x` chooses among
  /// many infinite lights; the walks down the tree take u.y, u.z, u.w and u.x in turn (a walk
  /// that does not split, u.y). Walks split into the root's children each have a number of
  /// their own: sharing one, children laid out alike (colour groups that each span the lights'
  /// extent) pick lights on the same side of the receiver together, and their errors add up
  /// instead of cancelling. (A fourth walk shares u.x with the choice among many infinite
  /// lights, a sum of its own.) A choice's probability is that of its light within its set, so
  /// the caller adds up what each choice gives.
  template <class Visit>
  void forEachChoice(const Receiver& receiver, const Sample4D& u, Visit&& visit) const {
    if (infinite_.size() <= kInfiniteLightsSampledEach) {
      uint32_t slot = 0;
      for (const InfiniteLight& light : infinite_) visit(Choice{light.index, 1.0f, slot++});
    } else if (const std::optional<Choice> choice = sampleInfinite(receiver, u.x)) {
      visit(*choice);
    }
    LocalChoices local;
    chooseLocal(receiver, u, local);
    for (size_t i = 0; i < local.count; ++i) visit(local.choices[i]);
  }
  /// Whether forEachChoice() reads its random numbers at all: with at most
  /// kInfiniteLightsSampledEach infinite lights and one local light, every choice is certain.
  bool choosesAtRandom() const {
    return infinite_.size() > kInfiniteLightsSampledEach || !nodes_.empty();
  }
  /// The probability that forEachChoice() visits light `index` at the receiver.
  float probability(const Receiver& receiver, size_t index) const;
  /// One infinite light, chosen in proportion to its estimated irradiance at the receiver.
  std::optional<Choice> sampleInfinite(const Receiver& receiver, float u) const;

  /// Depth of the light tree (for tests and statistics).
  int treeDepth() const;

 private:
  /// An interior node of the tree. Its children are nodes or lights: the lights are not
  /// nodes, so that a walk reads no node for the light it ends on, and the nodes of a tree of
  /// n lights are about n / 3.
  struct Node {
    LightClusters childClusters;         // a lane per child, the rest empty
    uint32_t children[kBranching] = {};  // child k: a light's index if bit k of childLights
    uint8_t childLights = 0;             // is set, else a node's
    Vec3f center;                        // of the bounding box of the node's lights
    float halfDiagonal2 = 0;             // squared radius of the box's bounding sphere
  };
  /// Where a local light's leaf is: the child taken at each level, from the root.
  struct LeafPath {
    uint64_t branches = 0;  // bits 2k and 2k + 1: the child taken at depth k
    int depth = -1;         // -1: not a local light
  };
  /// What a walk weighs a node's children by at a receiver: their importances and running sums
  /// (`before[k]`: lanes below k), added in one order for the walk and probability() alike.
  struct ChildWeights {
    std::array<float, kBranching> importance;
    std::array<float, kBranching> before;
    float total = 0;
  };

  /// The local lights chosen at a receiver, in the order of the nodes the walk split into
  /// (first children first), with their slots.
  struct LocalChoices {
    Choice choices[kMaxLocalChoices];
    size_t count = 0;
  };
  /// Fills `local` with the local lights chosen at the receiver: the walk from the root splits
  /// into every child where the receiver lies within the root's bounding sphere, and goes on
  /// from each child (or from the root) with one choice per level. Those walks are stepped
  /// together, level by level, so that their independent chains of square roots and divisions
  /// can overlap: each step weighs the nodes the walks stand on in one call
  /// (LightClusters::importances), each node's children at once in SIMD lanes. `u`: as
  /// forEachChoice()'s.
  void chooseLocal(const Receiver& receiver, const Sample4D& u, LocalChoices& local) const;
  /// Whether the receiver lies within `node`'s bounding sphere, where the walk goes down every
  /// child of the root.
  bool splits(const Node& node, const Receiver& receiver) const;
  /// Builds the subtree of lights[begin, end) (at least two) whose root is reached by `path`;
  /// returns its index and the bounds of its lights. `chromaticities`: each light's radiance
  /// over its luminance.
  std::pair<uint32_t, LightBounds> build(std::vector<uint32_t>& lights, size_t begin, size_t end,
                                         const std::vector<LightBounds>& bounds,
                                         const std::vector<Vec3f>& chromaticities, LeafPath path);
  /// A node's children's importances at a receiver, and their running sums.
  static ChildWeights weigh(const std::array<float, kBranching>& importance);
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

  std::vector<Node> nodes_;            // nodes_[0] is the root, when there are several local lights
  std::optional<uint32_t> loneLight_;  // the local light, when there is one
  std::vector<LeafPath> paths_;        // by light index
  std::vector<InfiniteLight> infinite_;
};

}  // namespace penumbra
