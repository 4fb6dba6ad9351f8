// Caustics seen through glass, by photon density estimation. The light tracer (caustics.h)
// joins a light path's last vertex to the camera, which fails where the camera sees that
// surface only through smooth glass or metal: the join would have to refract or reflect on its
// way to the lens. There the path tracer would find the caustic only by chance (the lamp's light
// through the casters, seen through casters again). With caustics=photons
// (IntegratorSettings::causticPhotons), where a camera path reaches a receiving surface through
// casters alone, the light tracer's arrivals on receivers (photons) near that point are summed
// instead (Jensen 1996; radius shrinking with the sample index as progressive photon mapping's,
// Knaus and Zwicker 2011), and the path tracer leaves those paths' light out exactly as it does
// for the surfaces the camera sees directly. The estimate is biased by the blur of its radius
// and consistent: the radius goes to zero as the samples grow, slowly enough that the noise
// does too.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/math.h"

namespace penumbra {

/// A light path's arrival on a receiving surface.
struct Photon {
  Vec3f position;
  Vec3f normal;        // geometric, at the arrival
  Vec3f towardsLight;  // the direction it arrived from
  /// The light path's β over |cos| of its arrival (RGB): Σ power · f(wo, towardsLight) |cos_s|
  /// over photons within r, over (light paths · πr²), is the light leaving towards wo.
  Vec3f power;
  int casters = 0;  // casters it passed on its way from the lamp
};

/// The photons of one sample index, found by position: a hash grid of cubic cells.
class PhotonGrid {
 public:
  PhotonGrid() = default;
  /// `cellSize`: about twice the radius lookups use.
  PhotonGrid(std::vector<Photon> photons, float cellSize);

  /// Calls visit(photon) for each photon within `radius` of `centre`, in a fixed order.
  template <typename Visit>
  void forEachWithin(const Vec3f& centre, float radius, Visit&& visit) const;

 private:
  struct Cell {
    int x, y, z;
    bool operator==(const Cell& other) const {
      return x == other.x && y == other.y && z == other.z;
    }
  };
  Cell cellOf(const Vec3f& position) const;
  size_t bucketOf(const Cell& cell) const;

  float cellSize_ = 1;
  std::vector<Photon> photons_;       // by bucket, in the order given within each
  std::vector<uint32_t> bucketEnds_;  // photons_[end of bucket b - 1] ...: prefix sums
};

/// The photons of the sample indices a render traces next, each index's its own (so that how a
/// render's samples are split into calls does not change what a sample sees), and the radius
/// the path tracer's lookups use there.
class CausticPhotons {
 public:
  /// Lookup radius at sample index 0, in camera-ray footprints (RayCone radii) at the receiver.
  static constexpr float kFootprints = 2.0f;
  /// Progressive photon mapping's α: sample index i's squared radius is (i + α) / (i + 1) of
  /// index i − 1's (r² ~ i^(α−1)): the blur and the noise both vanish; 2/3 as Knaus and
  /// Zwicker advise.
  static constexpr double kAlpha = 2.0 / 3.0;

  explicit CausticPhotons(uint32_t pathsPerSample = 1) : pathsPerSample_(pathsPerSample) {}

  /// A sample index's photons, in path order, and the camera-ray footprint typical of where
  /// they lie (for the grid's cells).
  struct Arrivals {
    std::vector<Photon> photons;
    float footprint = 1;
  };
  /// Replaces the photons held by those of sample indices [first, first + arrivals.size()).
  void hold(uint32_t first, std::vector<Arrivals> arrivals);
  /// Sample index `sampleIndex`'s photons, within the radius (radius) that a camera ray whose
  /// footprint at the receiver is `footprint` gathers them; throws std::out_of_range for an
  /// index not held.
  const PhotonGrid& at(uint32_t sampleIndex) const { return held(sampleIndex).grid; }
  float radius(uint32_t sampleIndex, float footprint) const {
    return kFootprints * footprint * held(sampleIndex).radiusScale;
  }
  /// What each photon's power is multiplied by within `radius`: 1 / (light paths · πr²).
  float perPhoton(float radius) const {
    return 1 / (float(pathsPerSample_) * kPi * radius * radius);
  }

 private:
  struct Held {
    PhotonGrid grid;
    float radiusScale;
  };
  const Held& held(uint32_t sampleIndex) const;
  /// r_i² / r_0² of sample index `index`, Π_{j=1}^{i} (j + α) / (j + 1): a product of exactly
  /// rounded operations, the same on every machine, continued from the last index asked (sample
  /// indices are held in ascending order, so a render computes each factor once).
  double squaredRadiusScale(uint32_t index);

  uint32_t pathsPerSample_;
  uint32_t first_ = 0;
  std::vector<Held> held_;
  uint32_t productIndex_ = 0;  // squaredRadiusScale's last index and value
  double product_ = 1;
};

template <typename Visit>
void PhotonGrid::forEachWithin(const Vec3f& centre, float radius, Visit&& visit) const {
  if (photons_.empty()) return;
  const Cell low = cellOf(centre - Vec3f(radius)), high = cellOf(centre + Vec3f(radius));
  const float radius2 = radius * radius;
  for (int z = low.z; z <= high.z; ++z)
    for (int y = low.y; y <= high.y; ++y)
      for (int x = low.x; x <= high.x; ++x) {
        const Cell cell{x, y, z};
        const size_t bucket = bucketOf(cell);
        for (uint32_t i = bucket > 0 ? bucketEnds_[bucket - 1] : 0; i < bucketEnds_[bucket]; ++i) {
          const Photon& photon = photons_[i];
          const Vec3f offset = photon.position - centre;
          // Cells sharing a bucket are told apart, so that no photon counts twice.
          if (dot(offset, offset) <= radius2 && cellOf(photon.position) == cell) visit(photon);
        }
      }
}

}  // namespace penumbra
