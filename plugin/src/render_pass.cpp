#include "penumbra/plugin/render_pass.h"

#include <algorithm>
#include <stdexcept>

#include "penumbra/render.h"

namespace penumbra::plugin {

RenderPass::RenderPass(RenderDelegate& delegate, PrimId cameraId, int width, int height)
    : delegate_(delegate), cameraId_(std::move(cameraId)), film_(width, height) {}

const std::vector<std::string>& RenderPass::aovNames() {
  return penumbra::aovNames();
}

void RenderPass::setAovs(const std::vector<std::string>& names) {
  std::vector<AovRequest> requests;
  for (const std::string& name : names) requests.push_back(parseAov(name));
  if (film_.accumulatesExactly(requests)) return;
  film_ = Film(film_.width(), film_.height(), std::move(requests));
  samplesDone_ = 0;
}

int RenderPass::aovChannels(const std::string& name) const {
  const AovRequest request = parseAov(name);
  if (request.kind == AovKind::Primvar)
    return std::max(1, delegate_.scene().primvarWidth(request.primvar));
  return Film::channels(request.kind);
}

int RenderPass::nextConvergenceTest(int samplesDone, int minSamples) {
  // Even counts, so that the two halves of a pixel's samples compare like with like.
  int test = minSamples + minSamples % 2;
  while (test <= samplesDone) test += std::max(4, test / 16 * 2);
  return test;
}

void RenderPass::reset() {
  film_.clear();
  samplesDone_ = 0;
}

void RenderPass::execute(int samples, const std::atomic<bool>* cancel) {
  if (samples < 0) throw std::invalid_argument("sample count must be >= 0");
  const Camera& cameraPrim = delegate_.camera(cameraId_);
  delegate_.sync({cameraPrim.params(), film_.width()});
  const RenderSettingsMap& settings = delegate_.settings();
  // The target sample count does not change what a sample is; everything else does.
  std::map<std::string, double> settingsUsed = settings.asMap();
  settingsUsed.erase("samples");
  settingsUsed.erase("threads");
  if (delegate_.sceneVersion() != sceneVersion_ || cameraPrim.syncCount() != cameraSyncCount_ ||
      settingsUsed != settingsUsed_) {
    reset();
    sceneVersion_ = delegate_.sceneVersion();
    cameraSyncCount_ = cameraPrim.syncCount();
    settingsUsed_ = std::move(settingsUsed);
  }
  if (samples == 0) return;
  const penumbra::Camera camera(cameraPrim.params(), film_.width(), film_.height());
  RenderSettings renderSettings;
  renderSettings.threads = settings.threads;
  renderSettings.integrator.seed = uint32_t(settings.seed);
  renderSettings.integrator.maxPathDepth = settings.maxPathDepth;
  renderSettings.integrator.maxDiffuseDepth = settings.maxDiffuseDepth;
  renderSettings.integrator.maxGlossyDepth = settings.maxGlossyDepth;
  renderSettings.integrator.maxTransmissionDepth = settings.maxTransmissionDepth;
  renderSettings.integrator.directLighting = DirectLighting(settings.directLighting);
  renderSettings.integrator.indirectClamp = settings.indirectClamp;
  renderSettings.integrator.glossyFilter = settings.glossyFilter;
  const int end = samplesDone_ + samples;
  while (samplesDone_ < end && film_.activePixels() > 0) {
    const int checkpoint = settings.adaptiveThreshold > 0
                               ? nextConvergenceTest(samplesDone_, settings.adaptiveMinSamples)
                               : end;
    const int stop = std::min(end, checkpoint);
    if (!renderSamples(delegate_.scene(), camera, film_, uint32_t(samplesDone_),
                       uint32_t(stop - samplesDone_), renderSettings, cancel)) {
      reset();
      throw RenderCancelled();
    }
    samplesDone_ = stop;
    if (stop == checkpoint) film_.updateConvergence(settings.adaptiveThreshold);
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

RawRayThroughput RenderPass::measureRawThroughput() {
  execute(0);  // sync
  const penumbra::Camera camera(delegate_.camera(cameraId_).params(), film_.width(),
                                film_.height());
  return penumbra::measureRawThroughput(delegate_.scene(), camera, film_.width(), film_.height(),
                                        delegate_.settings().threads);
}

void RenderPass::setAovBindings(std::map<std::string, PrimId> bindings) {
  for (const auto& [aovName, bufferId] : bindings) {
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
  const size_t stored = size_t(Film::channels(request.kind));
  const size_t wanted = size_t(aovChannels(name));
  if (wanted == stored) return values;
  // Primvars are accumulated as 4 floats: keep as many as the primvar has.
  std::vector<float> trimmed(values.size() / stored * wanted);
  for (size_t i = 0; i < values.size() / stored; ++i)
    std::copy_n(values.begin() + ptrdiff_t(i * stored), wanted,
                trimmed.begin() + ptrdiff_t(i * wanted));
  return trimmed;
}

}  // namespace penumbra::plugin
