// Cryptomatte (Psyop's specification 1.2): ids made from names by MurmurHash3_x86_32 (seed 0),
// stored as floats, and a pixel's ids ranked by the share of its samples that saw each.
//
// The renderer knows placements (an object's own placement or one copy of an instancer), not
// names: the film counts, per pixel, the samples whose camera ray first hit each placement, and
// a resolve maps placements to the hashes of the names its caller gives them (placements that
// share a name — a material, an asset — add up). Samples on faces that a per-face binding gives
// a material of their own are counted apart by its slot, so that a material layer can name them
// by that material. Counts are integers, so the coverage does not depend on the order threads add
// samples in.
#pragma once

#include <cstdint>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

namespace penumbra {

/// MurmurHash3_x86_32 of `bytes` (Austin Appleby's public-domain algorithm).
uint32_t murmurHash3(std::string_view bytes, uint32_t seed = 0);
/// The float a Cryptomatte image stores for `hash` (conversion "uint32_to_float32"): its bits,
/// with the lowest exponent bit flipped where the exponent is all zeros or all ones, so that no
/// id is a denormal, an infinity or a NaN.
float cryptomatteFloat(uint32_t hash);
/// The bits of that float (what a manifest writes as 8 hex digits).
uint32_t cryptomatteBits(uint32_t hash);

/// Identifies what a camera ray hit: an object and which of its instancer's copies (-1: the
/// object's own placement).
using PlacementKey = uint64_t;
inline PlacementKey placementKey(uint32_t object, int copy) {
  return (uint64_t(object) << 32) | uint64_t(uint32_t(copy + 1));
}
/// The object a placement key names.
inline uint32_t objectOf(PlacementKey placement) {
  return uint32_t(placement >> 32);
}
/// The Cryptomatte hash (of a name) of each placement.
using PlacementHashes = std::unordered_map<PlacementKey, uint32_t>;
/// For each object with per-face bindings (Geometry::setMeshFaceMaterials), the Cryptomatte hash
/// of the name of each slot's material (slot k at k - 1).
using SlotHashes = std::unordered_map<uint32_t, std::vector<uint32_t>>;

/// One rank of a pixel: an id (the hash's float) and the share of the pixel's samples with it.
struct CryptomatteRank {
  float id = 0;
  float coverage = 0;
};
/// The ids of `counts` (hash, samples that saw it; a hash may repeat: its counts add up) ranked
/// by coverage (count / `samples`), largest first, equal coverage by smaller hash first.
std::vector<CryptomatteRank> rankCoverage(std::vector<std::pair<uint32_t, uint32_t>> counts,
                                          uint32_t samples);

/// Per pixel, how many samples first hit each placement.
class CryptomatteCoverage {
 public:
  /// Forgets every sample and holds `pixels` pixels.
  void reset(size_t pixels);
  size_t pixels() const { return pixels_.size(); }
  /// One more sample of `pixel` first hit `placement`, on a face of per-face binding slot
  /// `faceSlot` (FirstHitSample::faceSlot; 0: the placement's own material).
  void add(size_t pixel, PlacementKey placement, uint32_t faceSlot = 0);
  /// `depth` ranks of `pixel` (of `samples` samples) as (id, coverage) pairs, 2 × depth
  /// floats written to `out` (zeros past the last id). Samples take their placement's hash,
  /// those on faces of a slot of their own the slot's hash in `slots` when given (a material
  /// layer); placements (and slots) missing from the maps count as misses.
  void resolve(size_t pixel, uint32_t samples, const PlacementHashes& hashes, int depth, float* out,
               const SlotHashes* slots = nullptr) const;

  /// Appends the counts to `out` (a checkpoint).
  void saveState(std::vector<uint8_t>& out) const;
  /// Reads what saveState wrote from `cursor` (advanced past it, not beyond `end`). Throws
  /// std::invalid_argument for malformed data or another pixel count.
  void loadState(const uint8_t*& cursor, const uint8_t* end);

 private:
  struct Count {
    PlacementKey placement;
    uint32_t faceSlot;
    uint32_t samples;
  };
  std::vector<std::vector<Count>> pixels_;
};

}  // namespace penumbra
