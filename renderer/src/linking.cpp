#include "penumbra/linking.h"

#include <algorithm>

namespace penumbra {

void LinkingTable::setClasses(const std::vector<LinkingClass>& classes) {
  size_t slots = 0;
  for (const LinkingClass& linking : classes) {
    for (const uint32_t slot : linking.lightExcludedSlots)
      slots = std::max(slots, size_t(slot) + 1);
    for (const uint32_t slot : linking.shadowExcludedSlots)
      slots = std::max(slots, size_t(slot) + 1);
  }
  classCount_ = classes.size() + 1;
  slots_ = slots;
  words_ = (slots + 63) / 64;
  lightBits_.assign(classCount_ * words_, 0);
  shadowBits_.assign(classCount_ * words_, 0);
  shadowLinkedSlots_.assign(slots, 0);
  for (size_t i = 0; i < classes.size(); ++i) {
    const size_t first = (i + 1) * words_;
    for (const uint32_t slot : classes[i].lightExcludedSlots)
      lightBits_[first + slot / 64] |= uint64_t(1) << (slot % 64);
    for (const uint32_t slot : classes[i].shadowExcludedSlots) {
      shadowBits_[first + slot / 64] |= uint64_t(1) << (slot % 64);
      shadowLinkedSlots_[slot] = 1;
    }
  }
}

}  // namespace penumbra
