#include "penumbra/plugin/render_pass.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "penumbra/branching.h"
#include "penumbra/dome_sampling.h"
#include "penumbra/plugin/render_settings.h"
#include "penumbra/render.h"
#include "penumbra/state_io.h"

namespace penumbra::plugin {

namespace {

/// `crop` grown by `margin` pixels on every side, then clipped to the image; throws
/// std::invalid_argument unless `crop` is a non-empty part of the image.
PixelRect cropWithMargin(int width, int height, const PixelRect& crop, int margin) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("image size must be positive, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  if (crop.width <= 0 || crop.height <= 0 || !PixelRect{0, 0, width, height}.contains(crop))
    throw std::invalid_argument("crop (" + std::to_string(crop.x) + ", " + std::to_string(crop.y) +
                                ") " + std::to_string(crop.width) + "x" +
                                std::to_string(crop.height) + " is not a non-empty part of the " +
                                std::to_string(width) + "x" + std::to_string(height) + " image");
  if (margin < 0) throw std::invalid_argument("crop margin must be >= 0");
  const int left = std::max(0, crop.x - margin), top = std::max(0, crop.y - margin);
  const int right = int(std::min<int64_t>(width, int64_t(crop.x) + crop.width + margin));
  const int bottom = int(std::min<int64_t>(height, int64_t(crop.y) + crop.height + margin));
  return {left, top, right - left, bottom - top};
}

/// Sample indices whose photons (caustic_photons.h) are held at once.
constexpr int kPhotonSamplesAtOnce = 8;

constexpr char kPassTag[5] = "PASS";
constexpr uint32_t kPassVersion = 1;

/// The settings among `used` that change pixels (a saved state's samples stay valid under the
/// others).
std::map<std::string, double> pixelSettings(const std::map<std::string, double>& used) {
  std::map<std::string, double> kept;
  for (const RenderOption& option : renderOptions()) {
    const auto found = used.find(option.key);
    if (option.changesPixels && found != used.end()) kept.insert(*found);
  }
  return kept;
}

}  // namespace

RenderPass::RenderPass(RenderDelegate& delegate, PrimId cameraId, int width, int height)
    : RenderPass(delegate, std::move(cameraId), width, height, PixelRect{0, 0, width, height}) {}

RenderPass::RenderPass(RenderDelegate& delegate, PrimId cameraId, int width, int height,
                       PixelRect crop, int margin)
    : delegate_(delegate),
      cameraId_(std::move(cameraId)),
      imageWidth_(width),
      imageHeight_(height),
      crop_(crop),
      film_(cropWithMargin(width, height, crop, margin)) {}

const std::vector<std::string>& RenderPass::aovNames() {
  return penumbra::aovNames();
}

void RenderPass::setAovs(const std::vector<std::string>& names) {
  std::vector<AovRequest> requests;
  for (const std::string& name : names) requests.push_back(parseAov(name));
  if (film_.accumulatesExactly(requests)) return;
  film_ = Film(film_.region(), std::move(requests));
  samplesDone_ = 0;
}

int RenderPass::aovChannels(const std::string& name) const {
  const AovRequest request = parseAov(name);
  if (request.kind == AovKind::Primvar)
    return std::max(1, delegate_.scene().geometry().primvarWidth(request.primvar));
  if (isCryptomatte(request.kind))
    return Film::cryptomatteChannels(delegate_.settings().cryptomatteDepth);
  return Film::channels(request.kind);
}

int RenderPass::nextConvergenceTest(int samplesDone, int minSamples) {
  // The first test at the minimum, made even so that the two halves of a pixel's samples
  // compare like with like; then at powers of two: a pixel stopped at 2^k samples holds the
  // first 2^k points of its Sobol sequence, a whole net, which is less noisy than a count in
  // between (and fewer tests reach fewer pixels, see adaptiveSamplingReach).
  const int first = minSamples + minSamples % 2;
  if (samplesDone < first) return first;
  int64_t power = 1;
  while (power <= samplesDone) power *= 2;
  return int(std::min<int64_t>(power, std::numeric_limits<int>::max()));
}

int RenderPass::adaptiveSamplingReach(int samples, int minSamples) {
  int tests = 0;
  for (int test = nextConvergenceTest(0, minSamples); test < samples;
       test = nextConvergenceTest(test, minSamples))
    ++tests;
  return tests;
}

void RenderPass::reset() {
  film_.clear();
  samplesDone_ = 0;
  guidingField_.reset();
  guidingRecorder_.clear();
  guidingRecordedThrough_ = 0;
  constantDomeShare_.reset();
  firstSurfaceSamples_.reset();
  regionBranches_.reset();
}

void RenderPass::execute(int samples, const std::atomic<bool>* cancel) {
  if (samples < 0) throw std::invalid_argument("sample count must be >= 0");
  const Camera& cameraPrim = delegate_.camera(cameraId_);
  const RenderSettingsMap& settings = delegate_.settings();
  // The render's samples in all (callers step towards the "samples" setting a few at a time).
  const uint64_t plannedSamples = uint64_t(std::max(samples, settings.samples));
  delegate_.sync({cameraPrim.params(), imageWidth_},
                 uint64_t(film_.width()) * uint64_t(film_.height()) * plannedSamples);
  // The target sample count does not change what a sample is; everything else does.
  std::map<std::string, double> settingsUsed = settings.asMap();
  settingsUsed.erase("samples");
  settingsUsed.erase("threads");
  settingsUsed.erase("cryptomatteDepth");  // how the film is resolved, not what a sample is
  if (delegate_.sceneVersion() != sceneVersion_ || cameraPrim.syncCount() != cameraSyncCount_ ||
      settingsUsed != settingsUsed_) {
    reset();
    sceneVersion_ = delegate_.sceneVersion();
    cameraSyncCount_ = cameraPrim.syncCount();
    settingsUsed_ = std::move(settingsUsed);
  }
  exposureScale_ = cameraPrim.params().exposureScale;
  if (samples == 0) return;
  const int end = samplesDone_ + samples;
  if (settings.adaptiveThreshold > 0) checkCropMargin(end);
  const penumbra::Camera camera(cameraPrim.params(), imageWidth_, imageHeight_);
  const PixelFilter filter;  // renderSamples' own
  std::optional<CausticTracer> caustics;
  if (settings.caustics >= 1) {
    caustics.emplace(delegate_.scene(), camera, filter, integratorSettings());
    if (!caustics->active()) caustics.reset();
  }
  // Photons are traced before the samples that gather them, a few sample indices at a time
  // (each index's own: they hold a few bytes per pixel each).
  std::optional<CausticPhotons> photons;
  if (caustics && settings.caustics == 2) photons = caustics->makePhotons();
  RenderSettings renderSettings =
      pilotedSettings(camera, caustics ? &caustics->takeover() : nullptr);
  const int trainingSamples = settings.guidingTrainingSamples;
  const size_t filmPixels = size_t(film_.width()) * size_t(film_.height());
  while (samplesDone_ < end && film_.activePixels() > 0) {
    const int checkpoint = settings.adaptiveThreshold > 0
                               ? nextConvergenceTest(samplesDone_, settings.adaptiveMinSamples)
                               : end;
    int stop = std::min(end, checkpoint);
    // The training samples are rendered unguided; they train the field as they go where they
    // are the whole image's (else prepareGuiding traces them for the whole image).
    const bool training = trainingSamples > 0 && samplesDone_ < trainingSamples;
    if (training) stop = std::min(stop, trainingSamples);
    const bool recordHere = training && guidingRecordedThrough_ == samplesDone_ &&
                            film_.region() == PixelRect{0, 0, imageWidth_, imageHeight_} &&
                            film_.activePixels() == filmPixels;
    if (trainingSamples > 0 && !training && !guidingField_)
      prepareGuiding(camera, renderSettings, cancel);
    renderSettings.integrator.guidingRecorder = recordHere ? &guidingRecorder_ : nullptr;
    renderSettings.integrator.guidingField = guidingField_ ? &*guidingField_ : nullptr;
    for (int first = samplesDone_; first < stop;) {
      const int last = photons ? std::min(stop, first + kPhotonSamplesAtOnce) : stop;
      if (photons)
        dropIfCancelled(caustics->trace(uint32_t(first), uint32_t(last - first), film_,
                                        settings.threads, cancel, &*photons));
      renderSettings.integrator.causticPhotons = photons ? &*photons : nullptr;
      const bool rendered = renderSamples(delegate_.scene(), camera, film_, uint32_t(first),
                                          uint32_t(last - first), renderSettings, cancel);
      renderSettings.integrator.causticPhotons = nullptr;  // they hold these indices alone
      dropIfCancelled(rendered);
      if (caustics && !photons)
        dropIfCancelled(caustics->trace(uint32_t(first), uint32_t(last - first), film_,
                                        settings.threads, cancel));
      first = last;
    }
    if (recordHere) guidingRecordedThrough_ = stop;
    samplesDone_ = stop;
    if (settings.adaptiveThreshold > 0 && stop == checkpoint)
      film_.updateConvergence(settings.adaptiveThreshold);
  }
  samplesDone_ = end;
  for (const auto& [aovName, bufferId] : aovBindings_) {
    RenderBuffer& buffer = delegate_.renderBuffer(bufferId);
    if (buffer.width() != width() || buffer.height() != height())
      throw std::invalid_argument(bufferId + ": render buffer is " +
                                  std::to_string(buffer.width()) + "x" +
                                  std::to_string(buffer.height()) + ", the pass renders " +
                                  std::to_string(width()) + "x" + std::to_string(height()));
    buffer.resolve(aov(aovName), aovChannels(aovName), converged());
  }
}

void RenderPass::dropIfCancelled(bool finished) {
  if (finished) return;
  reset();
  throw RenderCancelled();
}

void RenderPass::prepareGuiding(const penumbra::Camera& camera,
                                const penumbra::RenderSettings& renderSettings,
                                const std::atomic<bool>* cancel) {
  const int trainingSamples = delegate_.settings().guidingTrainingSamples;
  if (guidingRecordedThrough_ < trainingSamples) {
    // A crop, a resumed render or pixels stopped early: the training samples the film did not
    // record are traced again over the whole image, so that every pass trains the same field.
    penumbra::RenderSettings tracing = renderSettings;
    tracing.integrator.guidingField = nullptr;
    tracing.integrator.guidingRecorder = &guidingRecorder_;
    dropIfCancelled(traceSamples(
        delegate_.scene(), camera, imageWidth_, imageHeight_, uint32_t(guidingRecordedThrough_),
        uint32_t(trainingSamples - guidingRecordedThrough_), tracing, cancel));
    guidingRecordedThrough_ = trainingSamples;
  }
  guidingField_ = GuidingField::build(guidingRecorder_.take());
}

float RenderPass::constantDomeShareUsed() const {
  switch (DomeSampling(delegate_.settings().domeSampling)) {
    case DomeSampling::Mis:
      return 1;
    case DomeSampling::Bsdf:
      return 0;
    case DomeSampling::Auto:
      break;
  }
  return constantDomeShare_.value_or(1.0f);
}

float RenderPass::constantDomeShare(const penumbra::Camera& camera,
                                    const penumbra::RenderSettings& renderSettings) {
  // Over the whole image, so that a crop or a band chooses as the whole image does.
  if (DomeSampling(delegate_.settings().domeSampling) == DomeSampling::Auto && !constantDomeShare_)
    constantDomeShare_ =
        runDomeSamplingPilot(delegate_.scene(), camera, imageWidth_, imageHeight_, renderSettings)
            .firstSurfaceShare();
  return constantDomeShareUsed();
}

double RenderPass::indirectSamplesUsed() const {
  const int setting = delegate_.settings().indirectSamples;
  if (setting > 0) return setting;
  return regionBranches_ ? regionBranches_->mean(imageWidth_, imageHeight_) : 1.0;
}

int RenderPass::lightSamplesUsed() const {
  const int setting = delegate_.settings().lightSamples;
  return setting > 0 ? setting : firstSurfaceSamples_ ? firstSurfaceSamples_->lightSamples : 1;
}

void RenderPass::chooseFirstSurfaceSamples(const penumbra::Camera& camera,
                                           const penumbra::RenderSettings& renderSettings) {
  const RenderSettingsMap& settings = delegate_.settings();
  if ((settings.indirectSamples != 0 && settings.lightSamples != 0) || firstSurfaceSamples_) return;
  // Over the whole image, so that a crop or a band chooses as the whole image does.
  const BranchingPilot pilot =
      runBranchingPilot(delegate_.scene(), camera, imageWidth_, imageHeight_, renderSettings);
  firstSurfaceSamples_ = pilot.choose({settings.indirectSamples, settings.lightSamples});
  if (settings.indirectSamples == 0) regionBranches_ = pilot.chooseRegions(*firstSurfaceSamples_);
}

RenderSettings RenderPass::pilotedSettings(const penumbra::Camera& camera,
                                           const penumbra::CausticTakeover* caustics) {
  RenderSettings renderSettings;
  renderSettings.threads = delegate_.settings().threads;
  renderSettings.integrator = integratorSettings();
  renderSettings.integrator.caustics = caustics;
  renderSettings.integrator.firstSurfaceConstantDomeShare =
      constantDomeShare(camera, renderSettings);
  chooseFirstSurfaceSamples(camera, renderSettings);
  const RenderSettingsMap& settings = delegate_.settings();
  renderSettings.integrator.indirectSamples = std::max(settings.indirectSamples, 1);
  renderSettings.integrator.regionBranches = regionBranches();
  renderSettings.integrator.lightSamples = lightSamplesUsed();
  return renderSettings;
}

void RenderPass::checkCropMargin(int samples) const {
  const int reach = adaptiveSamplingReach(samples, delegate_.settings().adaptiveMinSamples);
  const PixelRect& film = film_.region();
  // On each side the film reaches the image's edge, or `reach` pixels past the crop.
  const int filmRight = film.x + film.width, filmBottom = film.y + film.height;
  const bool enough =
      (film.x == 0 || crop_.x - film.x >= reach) && (film.y == 0 || crop_.y - film.y >= reach) &&
      (filmRight == imageWidth_ || filmRight - (crop_.x + crop_.width) >= reach) &&
      (filmBottom == imageHeight_ || filmBottom - (crop_.y + crop_.height) >= reach);
  if (!enough)
    throw std::invalid_argument("adaptive sampling at " + std::to_string(samples) +
                                " samples needs a crop margin of " + std::to_string(reach) +
                                " pixels to render the crop as the whole image would");
}

IntegratorSettings RenderPass::integratorSettings() const {
  const RenderSettingsMap& settings = delegate_.settings();
  IntegratorSettings integrator;
  integrator.seed = uint32_t(settings.seed);
  integrator.maxPathDepth = settings.maxPathDepth;
  integrator.maxDiffuseDepth = settings.maxDiffuseDepth;
  integrator.maxGlossyDepth = settings.maxGlossyDepth;
  integrator.maxTransmissionDepth = settings.maxTransmissionDepth;
  integrator.maxVolumeDepth = settings.maxVolumeDepth;
  integrator.directLighting = DirectLighting(settings.directLighting);
  integrator.indirectClamp = settings.indirectClamp;
  integrator.glossyFilter = settings.glossyFilter;
  integrator.lightSamples = settings.lightSamples;
  return integrator;
}

RawRayThroughput RenderPass::measureRawThroughput() {
  execute(0);  // sync
  const penumbra::Camera camera(delegate_.camera(cameraId_).params(), imageWidth_, imageHeight_);
  // The rays of unguided samples, branching as the pass does.
  RenderSettings renderSettings = pilotedSettings(camera);
  return penumbra::measureRawThroughput(delegate_.scene(), camera, imageWidth_, imageHeight_,
                                        renderSettings.threads, 3, &renderSettings.integrator);
}

void RenderPass::setAovBindings(std::map<std::string, PrimId> bindings) {
  for (const auto& [aovName, bufferId] : bindings) {
    if (isCryptomatte(parseAov(aovName).kind))
      throw std::invalid_argument("AOV '" + aovName +
                                  "' is resolved with names (RenderPass::cryptomatte), not bound");
    if (!film_.has(parseAov(aovName)))
      throw std::invalid_argument("AOV '" + aovName + "' is not accumulated by this render pass");
    delegate_.renderBuffer(bufferId);
  }
  aovBindings_ = std::move(bindings);
}

std::vector<float> RenderPass::aov(const std::string& name) const {
  const AovRequest request = parseAov(name);
  if (!film_.has(request))
    throw std::invalid_argument("AOV '" + name + "' is not accumulated by this render pass");
  std::vector<float> values = film_.resolve(request);
  if (request.kind == AovKind::Color && exposureScale_ != 1) {
    for (size_t i = 0; i < values.size(); i += 4)  // RGBA: alpha is coverage
      for (size_t c = 0; c < 3; ++c) values[i + c] *= exposureScale_;
  } else if (request.kind == AovKind::Variance && exposureScale_ != 1) {
    for (float& value : values) value *= exposureScale_ * exposureScale_;
  }
  // Primvars are accumulated as 4 floats: keep as many as the primvar has.
  return cropped(values, size_t(Film::channels(request.kind)), size_t(aovChannels(name)));
}

std::vector<float> RenderPass::cryptomatte(
    const std::map<PrimId, std::vector<std::string>>& names,
    const std::map<PrimId, std::vector<std::string>>& subsetNames) const {
  const int depth = delegate_.settings().cryptomatteDepth;
  const size_t channels = size_t(Film::cryptomatteChannels(depth));
  const SlotHashes slots = delegate_.slotHashes(subsetNames);
  return cropped(film_.resolveCryptomatte(delegate_.placementHashes(names), depth,
                                          subsetNames.empty() ? nullptr : &slots),
                 channels, channels);
}

std::vector<float> RenderPass::cropped(const std::vector<float>& values, size_t stored,
                                       size_t wanted) const {
  // A film with a margin keeps only the crop's pixels.
  const PixelRect& filmRegion = film_.region();
  if (wanted == stored && filmRegion == crop_) return values;
  std::vector<float> cropped(size_t(crop_.width) * size_t(crop_.height) * wanted);
  for (int y = 0; y < crop_.height; ++y)
    for (int x = 0; x < crop_.width; ++x) {
      const size_t filmPixel = size_t(crop_.y - filmRegion.y + y) * size_t(filmRegion.width) +
                               size_t(crop_.x - filmRegion.x + x);
      std::copy_n(
          values.begin() + std::ptrdiff_t(filmPixel * stored), wanted,
          cropped.begin() + std::ptrdiff_t((size_t(y) * size_t(crop_.width) + size_t(x)) * wanted));
    }
  return cropped;
}

std::vector<uint8_t> RenderPass::saveState(const std::string& renderKey) const {
  std::vector<uint8_t> state;
  // Reserved up front: GCC 12 otherwise warns of an overflow (-Wstringop-overflow, a false
  // positive) on the first insert into the empty vector once beginBlock is inlined.
  state.reserve(1024);
  StateWriter writer(state);
  const size_t block = writer.beginBlock(kPassTag, kPassVersion);
  writer.putString(renderKey);
  writer.put(imageWidth_);
  writer.put(imageHeight_);
  writer.put(crop_);
  const std::map<std::string, double> settings = pixelSettings(settingsUsed_);
  writer.put(uint64_t(settings.size()));
  for (const auto& [key, value] : settings) {
    writer.putString(key);
    writer.put(value);
  }
  writer.put(samplesDone_);
  writer.endBlock(block);
  film_.saveState(state);
  return state;
}

void RenderPass::loadState(const std::vector<uint8_t>& state, const std::string& renderKey) {
  if (sceneVersion_ == ~uint64_t(0))
    throw std::logic_error("RenderPass::loadState needs the scene synced first (execute(0))");
  const uint8_t* cursor = state.data();
  const uint8_t* end = state.data() + state.size();
  StateReader reader(cursor, end, "the render pass state");
  reader.beginBlock(kPassTag, kPassVersion);
  if (reader.getString() != renderKey) reader.fail("is of another render (render key)");
  const int width = reader.get<int>(), height = reader.get<int>();
  if (width != imageWidth_ || height != imageHeight_)
    reader.fail("is of a " + std::to_string(width) + "x" + std::to_string(height) + " image, not " +
                std::to_string(imageWidth_) + "x" + std::to_string(imageHeight_));
  if (!(reader.get<PixelRect>() == crop_)) reader.fail("is of another crop");
  std::map<std::string, double> settings;
  for (uint64_t i = reader.get<uint64_t>(); i > 0; --i) {
    std::string key = reader.getString();
    settings[key] = reader.get<double>();
  }
  if (settings != pixelSettings(settingsUsed_)) reader.fail("was rendered with other settings");
  const int samplesDone = reader.get<int>();
  if (samplesDone < 0) reader.fail("has a negative sample count");
  reader.endBlock();
  film_.loadState(cursor, end);
  if (cursor != end) {
    reset();
    reader.fail("has more than a render pass's state");
  }
  samplesDone_ = samplesDone;
}

}  // namespace penumbra::plugin
