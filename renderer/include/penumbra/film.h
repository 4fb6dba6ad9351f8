// Accumulates camera samples per pixel. Samples are added in sample-index order within a pixel,
// so the sums, and hence the image, do not depend on how pixels are spread over threads.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "penumbra/cryptomatte.h"
#include "penumbra/integrator.h"

namespace penumbra {

/// A rectangle of an image's pixels: columns [x, x + width), rows [y, y + height), counted from
/// the top-left pixel.
struct PixelRect {
  int x = 0, y = 0, width = 0, height = 0;

  bool contains(const PixelRect& other) const {
    return other.x >= x && other.y >= y && other.x + other.width <= x + width &&
           other.y + other.height <= y + height;
  }
  bool operator==(const PixelRect& other) const {
    return x == other.x && y == other.y && width == other.width && height == other.height;
  }
};

class Film {
 public:
  /// A film of a whole `width` x `height` image. `aovs`: what the film accumulates besides
  /// colour, alpha, Z and the sample count, which it always has (a film without AOVs costs
  /// nothing more than colour). Duplicates are ignored.
  Film(int width, int height, std::vector<AovRequest> aovs = {});
  /// A film of the pixels `region` of a larger image: pixel (x, y) of the film is pixel
  /// (region.x + x, region.y + y) of the image, whose position seeds its samples (a crop
  /// renders exactly what the whole image holds there; see Film::updateConvergence for the
  /// one exception).
  explicit Film(const PixelRect& region, std::vector<AovRequest> aovs = {});

  int width() const { return region_.width; }
  int height() const { return region_.height; }
  /// The image pixels this film covers.
  const PixelRect& region() const { return region_; }
  /// The AOVs resolve() serves.
  bool has(const AovRequest& aov) const;
  /// Whether the film accumulates exactly `aovs` besides those every film has.
  bool accumulatesExactly(const std::vector<AovRequest>& aovs) const;
  /// Whether addSample needs each sample's FirstHitSample.
  bool wantsFirstHit() const { return wantsFirstHit_; }
  /// Drops every sample and makes every pixel active again.
  void clear();
  /// Adds sample `sampleIndex` of the film's pixel (x, y) (film coordinates, as isActive's);
  /// samples must come in index order. `firstHit` must be given when wantsFirstHit().
  void addSample(int x, int y, uint32_t sampleIndex, const CameraSample& sample,
                 const FirstHitSample* firstHit = nullptr);

  /// Light tracing (caustics.h): adds `light`, carried by a light path of sample index
  /// `sampleIndex`, to the light-traced sum of image pixel (x, y). A pixel's colour is the mean
  /// of its samples plus its light-traced sum over the light paths counted for it
  /// (addLightPaths), both of the sample indices it took: an active pixel takes the light paths
  /// of the indices its samples are added for, a stopped one (adaptive sampling) no more. So a
  /// pixel's value depends on its own samples alone, as without light paths, and a crop or farm
  /// band whose pixels all stop early resolves as the whole image does. Pixels outside the
  /// film's region, and stopped ones, are ignored.
  void addSplat(int x, int y, uint32_t sampleIndex, const Vec3f& light);
  /// Counts the `paths` light paths of sample index `sampleIndex`, traced for the whole image,
  /// for every active pixel (the indices of the splats added since the last such call).
  void addLightPaths(uint64_t paths, uint32_t sampleIndex);
  /// Counts `rays` more rays traced (by light paths) at image pixel (x, y), in raysTraced();
  /// pixels outside the film's region, and stopped ones, are ignored: as its light, a pixel
  /// counts the rays of the light paths of its own sample indices, so that farm bands that stop
  /// early add up to the whole image's count (which leaves out the rays of the light paths
  /// traced after their pixel stopped).
  void addRays(int x, int y, uint64_t rays);
  uint64_t lightPaths() const { return lightPaths_; }

  /// Floats per pixel of an AOV (4 for primvars, whatever their width; 0 for Cryptomatte AOVs,
  /// which resolveCryptomatte serves).
  static int channels(AovKind kind);
  /// The AOV per pixel, row-major from the top row, channels() floats each. How samples
  /// combine: filtered AOVs (color, alpha, normals, position, albedo, primvars) average all of
  /// them, misses counting as zero, as colour does; depth and Z keep the nearest hit (infinity
  /// where nothing was hit); ids keep the sample nearest the pixel centre (the first such in
  /// sample order; -1: it hit nothing). Throws std::invalid_argument for an AOV the film does
  /// not have.
  std::vector<float> resolve(const AovRequest& aov) const;
  /// Averaged scene-linear RGBA, row-major from the top row, 4 floats per pixel.
  std::vector<float> resolveColor() const;
  /// Nearest view-axis depth per pixel (infinity where nothing was hit).
  std::vector<float> resolveDepth() const;
  /// The Cryptomatte ranks per pixel (film pixels, row-major from the top row): `depth` (id,
  /// coverage) pairs, zero-padded to a multiple of 4 floats (whole RGBA layers), ids the
  /// `hashes` of the placements hit (for a material layer, `slots`: those of the faces that
  /// per-face bindings give a material of their own), coverage the share of the pixel's
  /// samples. Throws std::invalid_argument unless the film accumulates a Cryptomatte AOV, or for
  /// depth < 1.
  std::vector<float> resolveCryptomatte(const PlacementHashes& hashes, int depth,
                                        const SlotHashes* slots = nullptr) const;
  /// Floats per pixel of a Cryptomatte AOV of `depth` ranks: whole RGBA layers of 2 ranks.
  static int cryptomatteChannels(int depth) { return 4 * ((depth + 1) / 2); }

  /// Adaptive sampling: stops every active pixel that has taken its share of samples. A pixel's
  /// error e is the difference between the means of its even- and odd-indexed samples (half of
  /// it estimates the standard error of the full mean), relative to its value as rRMSE weighs it
  /// (|x − ref| / sqrt(ref² + 0.01)); its n samples give the spread of one sample, σ = e·√n,
  /// averaged in squares over its 3×3 neighbourhood so that one lucky estimate does not stop it.
  /// Where light paths add to the pixel, their part's error is measured alike (light paths of
  /// even against odd sample indices) and its spread adds to σ²: where the light tracer finds a
  /// caustic that the path tracer leaves out, the caustic's noise keeps the pixel active.
  /// The pixel stops once n ≥ √kThresholdSamples·σ/threshold, i.e. once e < threshold·
  /// √(n/kThresholdSamples): samples go in proportion to σ, which makes the image's mean squared
  /// relative error the least for the samples spent (stopping at e < threshold instead, n ∝ σ²,
  /// spends most samples on the noisiest few pixels). Call when every active pixel has the
  /// same, even number of samples. The neighbourhood is the film's: in a crop of a larger
  /// image, pixels within k pixels of a crop edge inside the image may decide differently from
  /// the whole image's after k tests (see RenderPass's crop margin).
  void updateConvergence(float threshold);
  bool isActive(int x, int y) const {
    return active_[size_t(y) * size_t(region_.width) + size_t(x)];
  }
  size_t activePixels() const { return activePixels_; }
  /// Samples taken per pixel, on average over the film.
  double meanSamples() const;
  /// Samples taken by the pixels of `within` (image coordinates; default: the whole film),
  /// which must lie in the film.
  uint64_t samplesTaken(const std::optional<PixelRect>& within = std::nullopt) const;
  /// Rays traced for the samples of the pixels of `within` (as samplesTaken), and the light
  /// paths' counted there (addRays).
  uint64_t raysTraced(const std::optional<PixelRect>& within = std::nullopt) const;

  /// Appends the film's exact accumulators (sums, counts, active pixels) to `out` as a "FILM"
  /// block (state_io.h); members with state of their own append their blocks after it.
  void saveState(std::vector<uint8_t>& out) const;
  /// Replaces the accumulators by a state saveState wrote, read from [cursor, end) (cursor ends
  /// past it): resolving and adding samples then go on exactly as on the film that saved it.
  /// Throws std::invalid_argument, leaving the film unchanged, for a truncated state or one of
  /// another region or AOV set.
  void loadState(const uint8_t*& cursor, const uint8_t* end);

 private:
  struct Pixel {
    double red = 0, green = 0, blue = 0, alpha = 0;
    double evenRed = 0, evenGreen = 0, evenBlue = 0;  // samples with an even index
    float depth = kInfinity;
    uint32_t samples = 0;
    uint64_t rays = 0;
  };
  /// A pixel's light-traced sums (addSplat) and the light paths counted for it (addLightPaths),
  /// of all its sample indices and of the even ones.
  struct LightTraced {
    double red = 0, green = 0, blue = 0, evenRed = 0, evenGreen = 0, evenBlue = 0;
    uint64_t paths = 0, evenPaths = 0;
  };
  /// Pixel `index`'s light-traced part: its mean per channel, and half the difference between
  /// its means over the light paths of even and of odd sample indices, whose square estimates
  /// the variance of that mean; none until both halves have light paths.
  struct LightTracedHalves {
    std::array<double, 3> mean, halfDifference;
  };
  std::optional<LightTracedHalves> lightTracedHalves(size_t index) const;
  /// The relative variance of one of pixel `index`'s samples, e²·n, its light-traced part's
  /// included (see updateConvergence); infinite below two samples.
  double sampleRelativeVariance(size_t index) const;
  /// The sample count at which updateConvergence's threshold is the pixel's relative error.
  static constexpr double kThresholdSamples = 16;
  /// Where an AOV's per-pixel data starts: in sums_ (filtered AOVs, variance) or in nearest_.
  struct Slot {
    AovRequest aov;
    size_t offset;
  };
  const Slot* slot(const AovRequest& aov) const;
  /// The index in pixels_ of image pixel (x, y); empty outside the film's region.
  std::optional<size_t> indexOfImagePixel(int x, int y) const;
  /// Adds a sample's first hit to the AOVs of pixel `index`.
  void addFirstHit(size_t index, const CameraSample& sample, const FirstHitSample& firstHit);
  /// Calls `visit(pixel)` for each pixel of `within` (image coordinates) or of the whole film.
  template <typename Visit>
  void forEachPixel(const std::optional<PixelRect>& within, Visit visit) const;

  PixelRect region_;
  std::vector<Pixel> pixels_;
  std::vector<Slot> slots_;
  bool wantsFirstHit_ = false;
  bool hasIds_ = false;       // nearest_ starts with the squared centre distance of the ids
  size_t sumStride_ = 0;      // doubles per pixel in sums_
  size_t nearestStride_ = 0;  // floats per pixel in nearest_
  std::vector<double> sums_;
  std::vector<float> nearest_;
  std::vector<uint8_t> active_;
  size_t activePixels_ = 0;
  std::vector<LightTraced> lightTraced_;  // per pixel; empty until light paths are counted
  uint64_t lightPaths_ = 0;               // traced for the image, whichever pixels took them
  bool wantsCryptomatte_ = false;
  CryptomatteCoverage cryptomatte_;  // empty unless wantsCryptomatte_
};

}  // namespace penumbra
