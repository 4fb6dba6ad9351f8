#include "volume_transport.h"

#include <array>
#include <cmath>
#include <vector>

namespace penumbra {
namespace {

/// Tentative collisions one ray may take through the volumes before it is ended (absorbed,
/// or opaque for a shadow ray): a guard against majorants so large that steps stop advancing.
/// Rays through a thick cloud take hundreds.
constexpr int kMaxTentativeCollisions = 1 << 16;

float exponentialStep(float majorant, float u) {
  return -std::log1p(-u) / majorant;
}

/// The mean of the components as (x + y + z) · (1/3), which rounds differently from average():
/// the volume estimators' images were made with it.
float sumTimesOneThird(const Vec3f& v) {
  return (v.x + v.y + v.z) * (1.0f / 3);
}

/// The volumes that a ray crosses, walked together: each volume's majorant cells (MajorantWalk)
/// merged into stretches over which the sum of the majorants of the volumes there is constant.
class MergedMajorants {
 public:
  /// `passes(placed)`: whether the ray goes through a volume as if it were not there (the
  /// shadow rays of a light whose shadow link excludes it).
  template <typename Passes>
  MergedMajorants(const VolumeSet& volumes, const Ray& ray, float tMax, float majorantScale,
                  Passes passes)
      : scale_(majorantScale), t_(ray.tNear) {
    for (const VolumeSet::Placed& placed : volumes.shown()) {
      if (passes(placed)) continue;
      if (!placed.objectToWorld.isAnimated() && !crosses(placed.worldBounds, ray, tMax)) continue;
      const Transform worldToObject = placed.objectToWorld.isAnimated()
                                          ? placed.objectToWorld.at(ray.time).inverse()
                                          : placed.worldToObject;
      const Vec3f origin = worldToObject.applyToPoint(ray.origin);
      const Vec3f direction = worldToObject.applyToVector(ray.direction);
      if (!isFinite(origin) || !isFinite(direction))
        continue;  // a degenerate placement at this time
      Track track{placed.volume.get(),
                  placed.linkingClass,
                  origin,
                  direction,
                  MajorantWalk(*placed.volume, origin, direction, ray.tNear, tMax),
                  {},
                  false};
      track.live = track.walk.next(&track.segment);
      if (!track.live) continue;
      if (count_ == inPlace_.size()) overflow_.assign(inPlace_.begin(), inPlace_.end());
      if (count_ >= inPlace_.size())
        overflow_.push_back(track);
      else
        inPlace_[count_] = track;
      ++count_;
    }
  }
  MergedMajorants(const MergedMajorants&) = delete;
  MergedMajorants& operator=(const MergedMajorants&) = delete;

  /// The next tentative collision (empty stretches skipped), where the ray then is: its
  /// distance and the summed majorant there; false once the ray has left every volume.
  bool nextTentativeCollision(RandomStream& random, float* t, float* majorant) {
    float end = 0;
    while (stretch(&end, majorant)) {
      if (*majorant > 0) {
        const float candidate = t_ + exponentialStep(*majorant, random.next());
        if (candidate < end) {
          advanceTo(candidate);
          *t = candidate;
          return true;
        }
      }
      advanceTo(end);
    }
    return false;
  }

  /// The volumes' summed coefficients at `t` (inside the current stretch), and one of the
  /// volumes there, chosen in proportion to its scattering (by `u`): the medium that scatters.
  MediumCoefficients coefficientsAt(float t, float u, ScatteringMedium* medium) const {
    MediumCoefficients sum;
    const Track* covering[8];
    float scatterings[8];
    int count = 0;
    for (const Track& track : tracks()) {
      if (!track.live || track.segment.tStart > t) continue;
      const MediumCoefficients c = track.volume->at(track.origin + track.direction * t);
      sum.scattering += c.scattering;
      sum.absorption += c.absorption;
      sum.emission += c.emission;
      if (count < 8) {
        covering[count] = &track;
        scatterings[count++] = sumTimesOneThird(c.scattering);
      }
    }
    int chosen = 0;
    if (count > 1) {
      float total = 0;
      for (int k = 0; k < count; ++k) total += scatterings[k];
      float target = u * total;
      for (chosen = 0; chosen < count; ++chosen)
        if ((target -= scatterings[chosen]) < 0) break;
      chosen = std::min(chosen, count - 1);
    }
    *medium = count > 0 ? ScatteringMedium{covering[chosen]->volume->anisotropy(),
                                           covering[chosen]->linkingClass}
                        : ScatteringMedium{};
    return sum;
  }

 private:
  /// The stretch from the current position: its end and summed majorant; false when every
  /// volume is behind.
  bool stretch(float* end, float* majorant) const {
    bool any = false;
    float nearestEnd = kInfinity, sum = 0;
    for (const Track& track : tracks()) {
      if (!track.live) continue;
      any = true;
      if (track.segment.tStart > t_) {
        nearestEnd = std::min(nearestEnd, track.segment.tStart);
      } else {
        nearestEnd = std::min(nearestEnd, track.segment.tEnd);
        sum += track.segment.majorant;
      }
    }
    *end = nearestEnd;
    *majorant = sum * scale_;
    return any;
  }
  /// Moves the current position to `t` (within the current stretch or at its end).
  void advanceTo(float t) {
    t_ = t;
    for (Track& track : tracks())
      while (track.live && track.segment.tEnd <= t_) track.live = track.walk.next(&track.segment);
  }
  struct Track {
    const Volume* volume;
    uint32_t linkingClass;    // the placement's (linking.h)
    Vec3f origin, direction;  // the ray in the volume's object space (same parameter t)
    MajorantWalk walk;
    MajorantSegment segment;
    bool live;
  };

  static bool crosses(const Bounds3f& box, const Ray& ray, float tMax) {
    float t0 = ray.tNear, t1 = tMax;
    for (int axis = 0; axis < 3; ++axis) {
      const float inverse = 1 / ray.direction[axis];
      float near = (box.lower[axis] - ray.origin[axis]) * inverse;
      float far = (box.upper[axis] - ray.origin[axis]) * inverse;
      if (std::isnan(near) || std::isnan(far)) continue;  // on a slab plane: keep it
      if (near > far) std::swap(near, far);
      t0 = std::max(t0, near);
      t1 = std::min(t1, far);
    }
    return t0 <= t1;
  }

  template <typename T>
  struct Range {
    T* first;
    size_t count;
    T* begin() const { return first; }
    T* end() const { return first + count; }
  };
  Range<const Track> tracks() const {
    return {count_ > inPlace_.size() ? overflow_.data() : inPlace_.data(), count_};
  }
  Range<Track> tracks() {
    return {count_ > inPlace_.size() ? overflow_.data() : inPlace_.data(), count_};
  }

  // The volumes the ray crosses: in place for the few a ray usually meets (a heap allocation
  // per ray costs about as much as tracking through a thin medium), on the heap beyond.
  std::array<Track, 4> inPlace_;
  std::vector<Track> overflow_;
  size_t count_ = 0;
  float scale_;
  float t_;
};

/// RGB coefficients read at the path's wavelengths when it carries a spectrum.
MediumCoefficients atWavelengths(const MediumCoefficients& c, const MediumSpectrum& spectrum) {
  if (!spectrum.wavelengths) return c;
  const Vec3f& lambda = spectrum.wavelengths->lambda;
  return {RgbSpectrum::unbounded(c.scattering).at(lambda),
          RgbSpectrum::unbounded(c.absorption).at(lambda),
          RgbSpectrum::unbounded(c.emission).at(lambda)};
}

/// An RGB spectrum upsampled without bound reaches at most twice its largest component; σs and
/// σa are upsampled apart, so their sum at a wavelength reaches at most twice the largest
/// component of each, which the majorant (of the largest component of their sum) bounds twice.
float majorantScale(const MediumSpectrum& spectrum) {
  return spectrum.wavelengths ? 4.0f : 1.0f;
}

}  // namespace

FlightOutcome sampleFreeFlight(const VolumeSet& volumes, const Ray& ray, float tMax,
                               const MediumSpectrum& spectrum, RandomStream& random,
                               Vec3f* throughput, Vec3f* emitted, MediumScattering* scattering) {
  MergedMajorants majorants(volumes, ray, tMax, majorantScale(spectrum),
                            [](const VolumeSet::Placed&) { return false; });
  float t = 0, majorant = 0;
  for (int collisions = 0; majorants.nextTentativeCollision(random, &t, &majorant);) {
    scattering->position = ray.origin + ray.direction * t;
    scattering->distance = t;
    if (++collisions > kMaxTentativeCollisions) return FlightOutcome::Absorbed;
    ScatteringMedium medium;
    const MediumCoefficients c =
        atWavelengths(majorants.coefficientsAt(t, random.next(), &medium), spectrum);
    Vec3f& beta = *throughput;
    *emitted += beta * c.emission * (1 / majorant);
    const Vec3f nullCollision{std::max(majorant - c.scattering.x - c.absorption.x, 0.0f),
                              std::max(majorant - c.scattering.y - c.absorption.y, 0.0f),
                              std::max(majorant - c.scattering.z - c.absorption.z, 0.0f)};
    // History-aware probabilities (Kutz et al. 2017): the events in proportion to what they
    // would carry of the path's weight; for grey media and weights, the analogue ones.
    const float pAbsorb = sumTimesOneThird(beta * c.absorption),
                pScatter = sumTimesOneThird(beta * c.scattering),
                pNull = sumTimesOneThird(beta * nullCollision);
    const float total = pAbsorb + pScatter + pNull;
    if (!(total > 0)) return FlightOutcome::Absorbed;
    const float u = random.next() * total;
    if (u < pAbsorb) return FlightOutcome::Absorbed;
    if (u < pAbsorb + pScatter) {
      beta *= c.scattering * (total / (majorant * pScatter));
      scattering->anisotropy = medium.anisotropy;
      scattering->linkingClass = medium.linkingClass;
      return FlightOutcome::Scattered;
    }
    beta *= nullCollision * (total / (majorant * pNull));
  }
  return FlightOutcome::Passed;
}

Vec3f estimateTransmittance(const VolumeSet& volumes, const Ray& ray, float tMax,
                            const MediumSpectrum& spectrum, RandomStream& random,
                            const LinkingTable& linking, int linkSlot) {
  MergedMajorants majorants(volumes, ray, tMax, majorantScale(spectrum),
                            [&](const VolumeSet::Placed& placed) {
                              return linking.shadowExcluded(placed.linkingClass, linkSlot);
                            });
  Vec3f transmittance{1.0f};
  float t = 0, majorant = 0;
  for (int collisions = 0; majorants.nextTentativeCollision(random, &t, &majorant);) {
    if (++collisions > kMaxTentativeCollisions) return Vec3f(0.0f);
    ScatteringMedium medium;
    const MediumCoefficients c =
        atWavelengths(majorants.coefficientsAt(t, 0.5f, &medium), spectrum);
    const Vec3f extinction = c.scattering + c.absorption;
    transmittance *= Vec3f(std::max(1 - extinction.x / majorant, 0.0f),
                           std::max(1 - extinction.y / majorant, 0.0f),
                           std::max(1 - extinction.z / majorant, 0.0f));
    // Russian roulette once little is left: ratio tracking through a thick cloud would
    // otherwise take every tentative collision to find what is nearly zero.
    const float largest = maxComponent(transmittance);
    if (largest < 0.1f) {
      if (random.next() >= 0.5f) return Vec3f(0.0f);
      transmittance *= 2.0f;
    }
  }
  return transmittance;
}

}  // namespace penumbra
