// The film's accumulators as bytes (checkpoints): saved exactly, so that a film loaded from
// them resolves, tests convergence and adds samples as the film that saved them would.
#include <algorithm>

#include "penumbra/film.h"
#include "penumbra/state_io.h"

namespace penumbra {
namespace {

constexpr char kFilmTag[5] = "FILM";
constexpr uint32_t kFilmVersion = 3;  // 2: light-traced sums; 3: per pixel, with their even halves

}  // namespace

void Film::saveState(std::vector<uint8_t>& out) const {
  out.reserve(out.size() + pixels_.size() * (sizeof(Pixel) + sumStride_ * sizeof(double) +
                                             nearestStride_ * sizeof(float) + 1));
  StateWriter writer(out);
  const size_t block = writer.beginBlock(kFilmTag, kFilmVersion);
  writer.put(region_);
  writer.put(uint64_t(slots_.size()));
  for (const Slot& s : slots_) {
    writer.put(uint32_t(s.aov.kind));
    writer.putString(s.aov.primvar.str());
    writer.put(uint64_t(s.offset));
  }
  writer.put(uint64_t(pixels_.size()));
  for (const Pixel& pixel : pixels_) {  // field by field: no padding bytes in the state
    for (double sum : {pixel.red, pixel.green, pixel.blue, pixel.alpha, pixel.evenRed,
                       pixel.evenGreen, pixel.evenBlue})
      writer.put(sum);
    writer.put(pixel.depth);
    writer.put(pixel.samples);
    writer.put(pixel.rays);
  }
  writer.putArray(sums_);
  writer.putArray(nearest_);
  writer.put(lightPaths_);
  writer.put(uint64_t(lightTraced_.size()));
  for (const LightTraced& light : lightTraced_) {
    for (double sum :
         {light.red, light.green, light.blue, light.evenRed, light.evenGreen, light.evenBlue})
      writer.put(sum);
    writer.put(light.paths);
    writer.put(light.evenPaths);
  }
  writer.putArray(active_);
  writer.endBlock(block);
  if (wantsCryptomatte_) cryptomatte_.saveState(out);
}

void Film::loadState(const uint8_t*& cursor, const uint8_t* end) {
  StateReader reader(cursor, end, "the film state");
  reader.beginBlock(kFilmTag, kFilmVersion);
  if (!(reader.get<PixelRect>() == region_)) reader.fail("is of another image region");
  bool sameSlots = reader.get<uint64_t>() == slots_.size();
  for (size_t i = 0; sameSlots && i < slots_.size(); ++i) {
    const uint32_t kind = reader.get<uint32_t>();
    const std::string primvar = reader.getString();
    const uint64_t offset = reader.get<uint64_t>();
    sameSlots = kind == uint32_t(slots_[i].aov.kind) && primvar == slots_[i].aov.primvar.str() &&
                offset == slots_[i].offset;
  }
  if (!sameSlots) reader.fail("is of another set of AOVs");
  if (reader.get<uint64_t>() != pixels_.size()) reader.fail("is of another size");
  std::vector<Pixel> pixels(pixels_.size());
  for (Pixel& pixel : pixels) {
    for (double* sum : {&pixel.red, &pixel.green, &pixel.blue, &pixel.alpha, &pixel.evenRed,
                        &pixel.evenGreen, &pixel.evenBlue})
      *sum = reader.get<double>();
    pixel.depth = reader.get<float>();
    pixel.samples = reader.get<uint32_t>();
    pixel.rays = reader.get<uint64_t>();
  }
  std::vector<double> sums = reader.getArray<double>(sums_.size());
  std::vector<float> nearest = reader.getArray<float>(nearest_.size());
  const auto lightPaths = reader.get<uint64_t>();
  const auto lightTracedCount = reader.get<uint64_t>();
  if (lightTracedCount != 0 && lightTracedCount != pixels_.size())
    reader.fail("is of another size");
  std::vector<LightTraced> lightTraced(static_cast<size_t>(lightTracedCount));
  for (LightTraced& light : lightTraced) {
    for (double* sum :
         {&light.red, &light.green, &light.blue, &light.evenRed, &light.evenGreen, &light.evenBlue})
      *sum = reader.get<double>();
    light.paths = reader.get<uint64_t>();
    light.evenPaths = reader.get<uint64_t>();
    if (light.evenPaths > light.paths)
      reader.fail("counts more light paths of even sample indices than light paths");
  }
  std::vector<uint8_t> active = reader.getArray<uint8_t>(active_.size());
  reader.endBlock();
  CryptomatteCoverage cryptomatte;  // replaces cryptomatte_ only once all of it is read
  if (wantsCryptomatte_) {
    cryptomatte.reset(pixels_.size());
    cryptomatte.loadState(cursor, end);
  }
  pixels_ = std::move(pixels);
  sums_ = std::move(sums);
  nearest_ = std::move(nearest);
  active_ = std::move(active);
  lightPaths_ = lightPaths;
  lightTraced_ = std::move(lightTraced);
  if (wantsCryptomatte_) cryptomatte_ = std::move(cryptomatte);
  activePixels_ = size_t(std::count(active_.begin(), active_.end(), uint8_t(1)));
}

}  // namespace penumbra
