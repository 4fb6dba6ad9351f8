#include "penumbra/film.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

#include "penumbra/shading.h"

namespace penumbra {
namespace {

/// AOVs every film has: they come from the colour accumulation itself.
bool isBuiltIn(AovKind kind) {
  return kind == AovKind::Color || kind == AovKind::Alpha || kind == AovKind::Z ||
         kind == AovKind::SampleCount;
}

bool isId(AovKind kind) {
  return kind == AovKind::PrimId || kind == AovKind::InstanceId || kind == AovKind::ElementId;
}

/// Whether the AOV keeps one value per pixel in nearest_ rather than sums in sums_.
bool isNearest(AovKind kind) {
  return kind == AovKind::Depth || isId(kind);
}

}  // namespace

Film::Film(int width, int height, std::vector<AovRequest> aovs)
    : Film(PixelRect{0, 0, width, height}, std::move(aovs)) {}

Film::Film(const PixelRect& region, std::vector<AovRequest> aovs) : region_(region) {
  if (region.width <= 0 || region.height <= 0)
    throw std::invalid_argument("film size must be positive, got " + std::to_string(region.width) +
                                "x" + std::to_string(region.height));
  if (region.x < 0 || region.y < 0)
    throw std::invalid_argument("a film's pixels start at (0, 0) or later, got (" +
                                std::to_string(region.x) + ", " + std::to_string(region.y) + ")");
  for (const AovRequest& aov : aovs) hasIds_ = hasIds_ || isId(aov.kind);
  nearestStride_ = hasIds_ ? 1 : 0;
  for (AovRequest& aov : aovs) {
    if (isBuiltIn(aov.kind) || slot(aov)) continue;
    wantsFirstHit_ = wantsFirstHit_ || aov.needsFirstHit();
    wantsCryptomatte_ = wantsCryptomatte_ || isCryptomatte(aov.kind);
    size_t& stride = isNearest(aov.kind) ? nearestStride_ : sumStride_;
    slots_.push_back({std::move(aov), stride});
    stride += size_t(channels(slots_.back().aov.kind));
  }
  clear();
}

int Film::channels(AovKind kind) {
  switch (kind) {
    case AovKind::Color:
    case AovKind::Primvar:
      return 4;
    case AovKind::Normal:
    case AovKind::CameraNormal:
    case AovKind::Position:
    case AovKind::Albedo:
    case AovKind::Variance:
      return 3;
    case AovKind::CryptoObject:
    case AovKind::CryptoMaterial:
    case AovKind::CryptoAsset:
      return 0;  // in cryptomatte_, not in sums_ or nearest_
    default:
      return 1;
  }
}

bool Film::has(const AovRequest& aov) const {
  return isBuiltIn(aov.kind) || slot(aov) != nullptr;
}

bool Film::accumulatesExactly(const std::vector<AovRequest>& aovs) const {
  const auto requested = [&](const Slot& s) {
    return std::find(aovs.begin(), aovs.end(), s.aov) != aovs.end();
  };
  return std::all_of(aovs.begin(), aovs.end(), [&](const AovRequest& aov) { return has(aov); }) &&
         std::all_of(slots_.begin(), slots_.end(), requested);
}

const Film::Slot* Film::slot(const AovRequest& aov) const {
  for (const Slot& candidate : slots_)
    if (candidate.aov == aov) return &candidate;
  return nullptr;
}

void Film::clear() {
  pixels_.assign(size_t(region_.width) * size_t(region_.height), Pixel{});
  lightTraced_.clear();
  lightPaths_ = 0;
  active_.assign(pixels_.size(), 1);
  activePixels_ = pixels_.size();
  if (wantsCryptomatte_) cryptomatte_.reset(pixels_.size());
  sums_.assign(pixels_.size() * sumStride_, 0.0);
  nearest_.assign(pixels_.size() * nearestStride_, 0.0f);
  for (size_t i = 0; nearestStride_ > 0 && i < pixels_.size(); ++i) {
    float* nearest = nearest_.data() + i * nearestStride_;
    if (hasIds_) nearest[0] = kInfinity;
    for (const Slot& s : slots_)
      if (isNearest(s.aov.kind))
        nearest[s.offset] = s.aov.kind == AovKind::Depth ? kInfinity : -1.0f;
  }
}

void Film::addFirstHit(size_t index, const CameraSample& sample, const FirstHitSample& firstHit) {
  double* sums = sums_.data() + index * sumStride_;
  float* nearest = nearest_.data() + index * nearestStride_;
  bool nearestToCentre = false;
  if (hasIds_) {
    const float distance = firstHit.filterOffset.x * firstHit.filterOffset.x +
                           firstHit.filterOffset.y * firstHit.filterOffset.y;
    if (distance < nearest[0]) {
      nearest[0] = distance;
      nearestToCentre = true;
    }
  }
  const auto add3 = [](double* sum, const Vec3f& value) {
    sum[0] += value.x;
    sum[1] += value.y;
    sum[2] += value.z;
  };
  for (const Slot& s : slots_) {
    switch (s.aov.kind) {
      case AovKind::Depth:
        nearest[s.offset] = std::min(nearest[s.offset], firstHit.distance);
        break;
      case AovKind::PrimId:
        if (nearestToCentre) nearest[s.offset] = float(firstHit.primId);
        break;
      case AovKind::InstanceId:
        if (nearestToCentre) nearest[s.offset] = float(firstHit.instanceId);
        break;
      case AovKind::ElementId:
        if (nearestToCentre) nearest[s.offset] = float(firstHit.elementId);
        break;
      case AovKind::Variance:
        add3(sums + s.offset, sample.radiance * sample.radiance);
        break;
      case AovKind::CryptoObject:
      case AovKind::CryptoMaterial:
      case AovKind::CryptoAsset:
        break;  // one count serves the three layers (below)
      default:
        if (!firstHit.hit) break;
        if (s.aov.kind == AovKind::Normal) add3(sums + s.offset, firstHit.normal);
        if (s.aov.kind == AovKind::CameraNormal) add3(sums + s.offset, firstHit.cameraNormal);
        if (s.aov.kind == AovKind::Position) add3(sums + s.offset, firstHit.position);
        if (s.aov.kind == AovKind::Albedo) add3(sums + s.offset, firstHit.albedo);
        if (s.aov.kind == AovKind::Primvar) {
          SurfacePoint point;
          point.shape = firstHit.shape;
          point.primitive = firstHit.primitive;
          point.u = firstHit.u;
          point.v = firstHit.v;
          point.instancePrimvars = firstHit.instancePrimvars;
          point.instance = uint32_t(std::max(firstHit.instanceId, 0));
          float value[4] = {0, 0, 0, 0};
          int valueWidth = 0;
          if (primvarAt(point, s.aov.primvar, value, &valueWidth))
            for (int c = 0; c < valueWidth; ++c) sums[s.offset + size_t(c)] += value[c];
        }
    }
  }
  if (wantsCryptomatte_ && firstHit.hit)
    cryptomatte_.add(index, placementKey(uint32_t(firstHit.primId), firstHit.instanceId),
                     firstHit.faceSlot);
}

void Film::addSample(int x, int y, uint32_t sampleIndex, const CameraSample& sample,
                     const FirstHitSample* firstHit) {
  const size_t index = size_t(y) * size_t(region_.width) + size_t(x);
  Pixel& pixel = pixels_[index];
  if (!slots_.empty()) {
    static const FirstHitSample kNone;
    addFirstHit(index, sample, firstHit ? *firstHit : kNone);
  }
  pixel.red += sample.radiance.x;
  pixel.green += sample.radiance.y;
  pixel.blue += sample.radiance.z;
  if (sampleIndex % 2 == 0) {
    pixel.evenRed += sample.radiance.x;
    pixel.evenGreen += sample.radiance.y;
    pixel.evenBlue += sample.radiance.z;
  }
  pixel.alpha += sample.alpha;
  pixel.depth = std::min(pixel.depth, sample.depth);
  pixel.rays += sample.rays;
  ++pixel.samples;
}

std::optional<size_t> Film::indexOfImagePixel(int x, int y) const {
  const int column = x - region_.x, row = y - region_.y;
  if (column < 0 || row < 0 || column >= region_.width || row >= region_.height)
    return std::nullopt;
  return size_t(row) * size_t(region_.width) + size_t(column);
}

void Film::addSplat(int x, int y, uint32_t sampleIndex, const Vec3f& light) {
  const std::optional<size_t> index = indexOfImagePixel(x, y);
  if (!index || !active_[*index]) return;
  if (lightTraced_.empty()) lightTraced_.resize(pixels_.size());
  LightTraced& sums = lightTraced_[*index];
  sums.red += light.x;
  sums.green += light.y;
  sums.blue += light.z;
  if (sampleIndex % 2 != 0) return;
  sums.evenRed += light.x;
  sums.evenGreen += light.y;
  sums.evenBlue += light.z;
}

void Film::addLightPaths(uint64_t paths, uint32_t sampleIndex) {
  lightPaths_ += paths;
  if (lightTraced_.empty()) lightTraced_.resize(pixels_.size());
  const bool even = sampleIndex % 2 == 0;
  for (size_t i = 0; i < pixels_.size(); ++i) {
    if (!active_[i]) continue;
    lightTraced_[i].paths += paths;
    if (even) lightTraced_[i].evenPaths += paths;
  }
}

void Film::addRays(int x, int y, uint64_t rays) {
  const std::optional<size_t> index = indexOfImagePixel(x, y);
  if (index && active_[*index]) pixels_[*index].rays += rays;
}

std::vector<float> Film::resolveColor() const {
  std::vector<float> rgba(pixels_.size() * 4, 0.0f);
  for (size_t i = 0; i < pixels_.size(); ++i) {
    const Pixel& pixel = pixels_[i];
    if (pixel.samples == 0) continue;
    const double scale = 1.0 / pixel.samples;
    const LightTraced* light =
        !lightTraced_.empty() && lightTraced_[i].paths > 0 ? &lightTraced_[i] : nullptr;
    const double perPath = light ? 1.0 / double(light->paths) : 0.0;
    rgba[4 * i] = float(pixel.red * scale + (light ? light->red * perPath : 0.0));
    rgba[4 * i + 1] = float(pixel.green * scale + (light ? light->green * perPath : 0.0));
    rgba[4 * i + 2] = float(pixel.blue * scale + (light ? light->blue * perPath : 0.0));
    rgba[4 * i + 3] = float(pixel.alpha * scale);
  }
  return rgba;
}

std::optional<Film::LightTracedHalves> Film::lightTracedHalves(size_t index) const {
  if (lightTraced_.empty()) return std::nullopt;
  const LightTraced& light = lightTraced_[index];
  if (!(light.evenPaths > 0 && light.paths > light.evenPaths)) return std::nullopt;
  const double paths = double(light.paths), evenPaths = double(light.evenPaths),
               oddPaths = double(light.paths - light.evenPaths);
  const std::array<double, 3> all{light.red, light.green, light.blue},
      even{light.evenRed, light.evenGreen, light.evenBlue};
  LightTracedHalves halves;
  for (size_t c = 0; c < 3; ++c) {
    halves.mean[c] = all[c] / paths;
    halves.halfDifference[c] = 0.5 * (even[c] / evenPaths - (all[c] - even[c]) / oddPaths);
  }
  return halves;
}

double Film::sampleRelativeVariance(size_t index) const {
  const Pixel& pixel = pixels_[index];
  if (pixel.samples < 2) return kInfinity;
  const double half = 0.5 * pixel.samples;
  const std::optional<LightTracedHalves> light = lightTracedHalves(index);
  const std::array<double, 3> all{pixel.red, pixel.green, pixel.blue},
      even{pixel.evenRed, pixel.evenGreen, pixel.evenBlue};
  double sampled = 0, lightTraced = 0;
  for (size_t c = 0; c < 3; ++c) {
    double mean = all[c] / pixel.samples;
    const double halfDifference = 0.5 * (even[c] - (all[c] - even[c])) / half;
    double lightHalfDifference = 0;
    if (light) {
      mean += light->mean[c];
      lightHalfDifference = light->halfDifference[c];
    }
    sampled += halfDifference * halfDifference / (mean * mean + 0.01);
    lightTraced += lightHalfDifference * lightHalfDifference / (mean * mean + 0.01);
  }
  // e² of the mean times n; the light-traced part's halves are of the same n sample indices.
  return sampled / 3 * pixel.samples + lightTraced / 3 * pixel.samples;
}

void Film::updateConvergence(float threshold) {
  std::vector<double> sampleVariance(pixels_.size());
  for (size_t i = 0; i < pixels_.size(); ++i) sampleVariance[i] = sampleRelativeVariance(i);
  const double squaredThreshold = double(threshold) * double(threshold);
  const int width = region_.width, height = region_.height;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const size_t i = size_t(y) * size_t(region_.width) + size_t(x);
      if (!active_[i]) continue;
      double sum = 0;
      int count = 0;
      for (int ny = std::max(0, y - 1); ny <= std::min(height - 1, y + 1); ++ny)
        for (int nx = std::max(0, x - 1); nx <= std::min(width - 1, x + 1); ++nx, ++count)
          sum += sampleVariance[size_t(ny) * size_t(width) + size_t(nx)];
      // n ≥ √kThresholdSamples·σ/threshold, squared.
      const double samples = pixels_[i].samples;
      if (sum / count * kThresholdSamples < squaredThreshold * samples * samples) {
        active_[i] = 0;
        --activePixels_;
      }
    }
}

template <typename Visit>
void Film::forEachPixel(const std::optional<PixelRect>& within, Visit visit) const {
  const PixelRect rect = within.value_or(region_);
  if (!region_.contains(rect))
    throw std::invalid_argument("pixels (" + std::to_string(rect.x) + ", " +
                                std::to_string(rect.y) + ") " + std::to_string(rect.width) + "x" +
                                std::to_string(rect.height) + " are not all on the film");
  for (int y = rect.y - region_.y; y < rect.y - region_.y + rect.height; ++y)
    for (int x = rect.x - region_.x; x < rect.x - region_.x + rect.width; ++x)
      visit(pixels_[size_t(y) * size_t(region_.width) + size_t(x)]);
}

uint64_t Film::raysTraced(const std::optional<PixelRect>& within) const {
  uint64_t total = 0;
  forEachPixel(within, [&total](const Pixel& pixel) { total += pixel.rays; });
  return total;
}

uint64_t Film::samplesTaken(const std::optional<PixelRect>& within) const {
  uint64_t total = 0;
  forEachPixel(within, [&total](const Pixel& pixel) { total += pixel.samples; });
  return total;
}

double Film::meanSamples() const {
  return double(samplesTaken()) / double(pixels_.size());
}

std::vector<float> Film::resolve(const AovRequest& aov) const {
  switch (aov.kind) {
    case AovKind::Color:
      return resolveColor();
    case AovKind::Z:
      return resolveDepth();
    case AovKind::Alpha: {
      std::vector<float> alpha(pixels_.size(), 0.0f);
      for (size_t i = 0; i < pixels_.size(); ++i)
        if (pixels_[i].samples > 0) alpha[i] = float(pixels_[i].alpha / pixels_[i].samples);
      return alpha;
    }
    case AovKind::SampleCount: {
      std::vector<float> count(pixels_.size());
      for (size_t i = 0; i < pixels_.size(); ++i) count[i] = float(pixels_[i].samples);
      return count;
    }
    default:
      break;
  }
  if (isCryptomatte(aov.kind))
    throw std::invalid_argument("a Cryptomatte AOV is resolved with names (resolveCryptomatte)");
  const Slot* found = slot(aov);
  if (!found) throw std::invalid_argument("the film does not accumulate this AOV");
  const size_t channelCount = size_t(channels(aov.kind));
  std::vector<float> values(pixels_.size() * channelCount, 0.0f);
  for (size_t i = 0; i < pixels_.size(); ++i) {
    float* out = values.data() + i * channelCount;
    if (isNearest(aov.kind)) {
      out[0] = nearest_[i * nearestStride_ + found->offset];
      continue;
    }
    const Pixel& pixel = pixels_[i];
    if (pixel.samples == 0) continue;
    const double* sums = sums_.data() + i * sumStride_ + found->offset;
    const double n = pixel.samples;
    if (aov.kind == AovKind::Variance) {
      // The variance of the pixel's mean: the samples' unbiased variance over their count,
      // plus its light-traced part's, estimated from its two halves (one degree of freedom).
      if (pixel.samples < 2) continue;
      const double means[3] = {pixel.red / n, pixel.green / n, pixel.blue / n};
      const std::optional<LightTracedHalves> light = lightTracedHalves(i);
      for (size_t c = 0; c < 3; ++c) {
        double variance = std::max(0.0, (sums[c] - n * means[c] * means[c]) / (n - 1)) / n;
        if (light) variance += light->halfDifference[c] * light->halfDifference[c];
        out[c] = float(variance);
      }
      continue;
    }
    for (size_t c = 0; c < channelCount; ++c) out[c] = float(sums[c] / n);
  }
  return values;
}

std::vector<float> Film::resolveCryptomatte(const PlacementHashes& hashes, int depth,
                                            const SlotHashes* slots) const {
  if (!wantsCryptomatte_)
    throw std::invalid_argument("the film does not accumulate a Cryptomatte AOV");
  if (depth < 1)
    throw std::invalid_argument("Cryptomatte depth must be at least 1, got " +
                                std::to_string(depth));
  const size_t stride = size_t(cryptomatteChannels(depth));
  std::vector<float> values(pixels_.size() * stride, 0.0f);
  for (size_t i = 0; i < pixels_.size(); ++i)
    cryptomatte_.resolve(i, pixels_[i].samples, hashes, depth, values.data() + i * stride, slots);
  return values;
}

std::vector<float> Film::resolveDepth() const {
  std::vector<float> depth(pixels_.size());
  for (size_t i = 0; i < pixels_.size(); ++i) depth[i] = pixels_[i].depth;
  return depth;
}

}  // namespace penumbra
