// Light and shadow linking (UsdLux collection:lightLink and collection:shadowLink), as plain
// indices: which lights each placement is cut off from.
//
// A light whose links are not "everything" has a link slot (Light::linkSlot; -1: it lights and
// shadows everything, the common case, which costs nothing). Each placement (an object's own, or
// an instancer copy) carries a linking class (0: linked to every light); a class is two bit sets
// over the slots: the lights whose light link excludes it (it receives none of their light) and
// those whose shadow link excludes it (it does not block their shadow rays). Looking a light up
// for a shading point is one bit test, whatever the number of classes and slots.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace penumbra {

/// One linking class: the link slots that exclude its placements.
struct LinkingClass {
  std::vector<uint32_t> lightExcludedSlots;   // lights whose light link leaves it out
  std::vector<uint32_t> shadowExcludedSlots;  // lights whose shadow link leaves it out
};

class LinkingTable {
 public:
  /// The class of placements every light lights and shadows.
  static constexpr uint32_t kLinkedToAll = 0;

  /// Replaces the classes: `classes[i]` becomes class i + 1 (class 0 is always kLinkedToAll).
  void setClasses(const std::vector<LinkingClass>& classes);
  /// How many classes there are, kLinkedToAll included.
  size_t classCount() const { return classCount_; }

  /// Whether light slot `slot` (-1: a light linked to everything) leaves class `linkingClass`
  /// unlit. A class past the end is linked to everything.
  bool lightExcluded(uint32_t linkingClass, int slot) const {
    return excluded(lightBits_, linkingClass, slot);
  }
  /// Whether placements of class `linkingClass` let the shadow rays of light slot `slot` pass.
  bool shadowExcluded(uint32_t linkingClass, int slot) const {
    return excluded(shadowBits_, linkingClass, slot);
  }
  /// Whether some class lets the shadow rays of slot `slot` pass (otherwise its shadow rays
  /// are traced as any other light's).
  bool shadowLinked(int slot) const {
    return slot >= 0 && size_t(slot) < shadowLinkedSlots_.size() && shadowLinkedSlots_[slot];
  }

 private:
  bool excluded(const std::vector<uint64_t>& bits, uint32_t linkingClass, int slot) const {
    if (linkingClass == kLinkedToAll || slot < 0 || linkingClass >= classCount_ ||
        size_t(slot) >= slots_)
      return false;
    const size_t word = linkingClass * words_ + size_t(slot) / 64;
    return (bits[word] >> (size_t(slot) % 64)) & 1u;
  }

  size_t classCount_ = 1;
  size_t slots_ = 0;                              // one past the highest slot any class names
  size_t words_ = 0;                              // 64-bit words per class
  std::vector<uint64_t> lightBits_, shadowBits_;  // classCount_ × words_
  std::vector<uint8_t> shadowLinkedSlots_;        // by slot
};

}  // namespace penumbra
