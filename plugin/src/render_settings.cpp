#include "penumbra/plugin/render_settings.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "penumbra/integrator.h"
#include "penumbra/texture.h"

namespace penumbra::plugin {

namespace {

constexpr double kIntMax = std::numeric_limits<int>::max();
constexpr double kFloatMax = std::numeric_limits<float>::max();
/// Far more threads than any machine has cores, and far below what oneTBB can hold: an arena of
/// more than 65536 slots crashes its workers (slot ids are 16-bit). The same on every machine,
/// so a job validated on one host is valid on any.
constexpr int kMaxThreads = 1024;

RenderOption integerOption(std::string key, int RenderSettingsMap::* field, int defaultValue,
                           int minimum, std::string metavar, std::string help) {
  RenderOption option;
  option.key = std::move(key);
  option.intField = field;
  option.defaultValue = option.frontEndDefault = defaultValue;
  option.minimum = minimum;
  option.maximum = kIntMax;
  option.metavar = std::move(metavar);
  option.help = std::move(help);
  return option;
}

/// A real option in [0, maximum], off (0) by default.
RenderOption realOption(std::string key, float RenderSettingsMap::* field, double maximum,
                        std::string metavar, std::string help) {
  RenderOption option;
  option.key = std::move(key);
  option.type = RenderOptionType::Float;
  option.floatField = field;
  option.maximum = maximum;
  option.metavar = std::move(metavar);
  option.help = std::move(help);
  option.defaultMeaning = "off";
  return option;
}

/// A level option, its first level by default.
RenderOption levelOption(std::string key, int RenderSettingsMap::* field,
                         std::vector<std::string> levels, std::string help) {
  RenderOption option;
  option.key = std::move(key);
  option.type = RenderOptionType::Level;
  option.intField = field;
  option.maximum = double(levels.size() - 1);
  option.levels = std::move(levels);
  option.help = std::move(help);
  return option;
}

std::vector<RenderOption> buildRenderOptions() {
  using Settings = RenderSettingsMap;
  std::vector<RenderOption> options;
  RenderOption& samples = options.emplace_back(
      integerOption("samples", &Settings::samples, 16, 1, "N", "samples per pixel"));
  samples.frontEndDefault = 64;
  samples.shortFlag = "-spp";
  options.push_back(integerOption("seed", &Settings::seed, 0, 0, "", "random seed"));
  RenderOption& threads = options.emplace_back(
      integerOption("threads", &Settings::threads, 0, 0, "N", "render threads"));
  threads.defaultMeaning = "every core";
  threads.maximum = kMaxThreads;
  threads.changesPixels = false;
  options.push_back(integerOption("maxPathDepth", &Settings::maxPathDepth, 8, 0, "N",
                                  "maximum number of bounces of a path"));
  options.push_back(integerOption("maxDiffuseDepth", &Settings::maxDiffuseDepth, 4, 0, "N",
                                  "maximum number of diffuse bounces of a path"));
  options.push_back(integerOption("maxGlossyDepth", &Settings::maxGlossyDepth, 4, 0, "N",
                                  "maximum number of glossy bounces of a path"));
  options.push_back(integerOption("maxTransmissionDepth", &Settings::maxTransmissionDepth, 8, 0,
                                  "N", "maximum number of transmission bounces of a path"));
  options.push_back(integerOption("maxVolumeDepth", &Settings::maxVolumeDepth, 4, 0, "N",
                                  "maximum number of scattering events in volumes of a path"));
  RenderOption& complexity = options.emplace_back(levelOption(
      "complexity", &Settings::complexity, {"low", "medium", "high", "veryhigh"},
      "how finely subdivision surfaces are diced: Penumbra renders their limit surface, "
      "within about a pixel at low, each level halving that"));
  complexity.shortFlag = "-c";
  complexity.usdrecordFlag = true;
  options.push_back(levelOption("directLighting", &Settings::directLighting,
                                {"mis", "light", "bsdf"},
                                "how direct light is estimated, a diagnostic: multiple importance "
                                "sampling, or light or BSDF sampling alone"));
  options.push_back(levelOption(
      "domeSampling", &Settings::domeSampling, {"auto", "mis", "bsdf"},
      "how the light of untextured dome lights is found at the surfaces camera rays meet: mis "
      "samples them as every light, beside the BSDF-sampled ray; bsdf leaves them to that ray, "
      "less noisy where what occludes the sky is about as bright as the sky (sunlit scenes); "
      "auto gives the shadow ray the share of their light, from none to mis's, that a pilot of "
      "a few thousand paths finds least noisy (docs/dome-sampling.md). Unbiased either way"));
  options.push_back(realOption("adaptiveThreshold", &Settings::adaptiveThreshold, 1, "T",
                               "adaptive sampling: pixels take samples in proportion to their "
                               "noise, each stopping once its estimated relative error is below "
                               "T*sqrt(n/16) after n samples (e.g. 0.05); --samples is then a "
                               "cap"));
  options.push_back(integerOption("adaptiveMinSamples", &Settings::adaptiveMinSamples, 16, 2, "N",
                                  "samples every pixel takes before adaptive sampling may stop "
                                  "it"));
  options.push_back(realOption("indirectClamp", &Settings::indirectClamp, kFloatMax, "L",
                               "limit each sample of indirect light to L (largest RGB "
                               "component), as Cycles' clamp: fewer fireflies, a biased, darker "
                               "image"));
  options.push_back(realOption("glossyFilter", &Settings::glossyFilter, kFloatMax, "F",
                               "blur sharp reflection and refraction lobes met after rougher "
                               "bounces, as Cycles' filter glossy (Cycles' default: 1): caustics "
                               "converge sooner, biased"));
  RenderOption& caustics = options.emplace_back(levelOption(
      "caustics", &Settings::caustics, {"path", "light", "photons"},
      "how light that passes smooth glass or metal, or that smooth plastic reflects, onto the "
      "surfaces camera rays meet is found: light also traces paths from the lamps through the "
      "glass, metal and plastic and joins them to the camera; path leaves it to the path tracer, "
      "which finds a lamp through glass only by "
      "chance (fireflies; Penumbra's images before 2026-12-06); both unbiased. photons is light, "
      "and where the camera sees a surface only through glass or metal, the light paths' "
      "arrivals near the point seen are summed: biased (a blur that shrinks as samples grow), "
      "consistent (docs/caustics.md)"));
  caustics.defaultValue = caustics.frontEndDefault = 1;
  RenderOption& indirectSamples = options.emplace_back(integerOption(
      "indirectSamples", &Settings::indirectSamples, 0, 0, "N",
      "paths that go on from each camera ray's first surface (branched path tracing): its "
      "indirect light is their mean, for the cost of one camera ray and its direct light; "
      "unbiased, fewer camera samples for the same indirect noise; 0 lets a pilot of a few "
      "thousand paths choose 1 to 4, whichever it finds least noisy for the time "
      "(docs/branching.md)"));
  indirectSamples.maximum = penumbra::kMaxIndirectSamples;
  indirectSamples.defaultMeaning = "the pilot's choice";
  RenderOption& lightSamples = options.emplace_back(integerOption(
      "lightSamples", &Settings::lightSamples, 0, 0, "N",
      "estimates of the direct light at each camera ray's first surface, averaged: where the "
      "choice of light is the noise (many lights), more of them cost only their shadow rays; "
      "unbiased; 0 lets the same pilot choose 1 to 8 (docs/branching.md)"));
  lightSamples.maximum = penumbra::kMaxLightSamples;
  lightSamples.defaultMeaning = "the pilot's choice";
  RenderOption& guiding = options.emplace_back(integerOption(
      "guidingTrainingSamples", &Settings::guidingTrainingSamples, 0, 0, "N",
      "path guiding: the first N samples per pixel learn where indirect light comes from, and "
      "later samples aim rough surfaces' bounces there as well as by their BSDF "
      "(docs/path-guiding.md); 0 turns guiding off"));
  guiding.maximum = 1024;
  RenderOption& textureCache = options.emplace_back(integerOption(
      "textureCacheMB", &Settings::textureCacheMB, int(TextureSystem::kDefaultCacheBytes >> 20), 16,
      "MB",
      "memory of the texture tile cache in MiB: texture lookups hold about this much texture "
      "data whatever the textures' resolution"));
  textureCache.changesPixels = false;
  textureCache.userSet = false;
  RenderOption& cryptomatteDepth = options.emplace_back(integerOption(
      "cryptomatteDepth", &Settings::cryptomatteDepth, 6, 1, "N",
      "ids per pixel of the Cryptomatte AOVs (CryptoObject, CryptoMaterial, CryptoAsset), the "
      "most covering first: N/2 RGBA layers, rounded up"));
  cryptomatteDepth.maximum = 64;
  return options;
}

std::string formatValue(double value) {
  std::string text = std::to_string(value);
  text.erase(text.find_last_not_of('0') + 1);
  if (text.back() == '.') text.pop_back();
  return text;
}

}  // namespace

const std::vector<RenderOption>& renderOptions() {
  static const std::vector<RenderOption> options = buildRenderOptions();
  return options;
}

const RenderOption& renderOption(const std::string& key) {
  for (const RenderOption& option : renderOptions())
    if (option.key == key) return option;
  std::string known;
  for (const RenderOption& option : renderOptions())
    known += (known.empty() ? "" : ", ") + option.key;
  throw std::invalid_argument("unknown render setting '" + key + "' (known: " + known + ")");
}

std::string RenderOption::problem(double value) const {
  const bool unbounded = maximum == (type == RenderOptionType::Float ? kFloatMax : kIntMax);
  if (!(value >= minimum && value <= maximum)) {
    if (!unbounded)
      return "must be in [" + formatValue(minimum) + ", " + formatValue(maximum) + "]";
    if (type == RenderOptionType::Float)
      return "must be a finite number >= " + formatValue(minimum);
    if (value > maximum) return "must be at most " + formatValue(maximum);
    return minimum == 0 ? "cannot be negative" : "must be at least " + formatValue(minimum);
  }
  if (type != RenderOptionType::Float && value != std::floor(value)) return "must be an integer";
  return {};
}

RenderSettingsMap::RenderSettingsMap() {
  for (const RenderOption& option : renderOptions()) set(option.key, option.defaultValue);
}

void RenderSettingsMap::set(const std::string& key, double value) {
  const RenderOption& option = renderOption(key);
  if (const std::string problem = option.problem(value); !problem.empty())
    throw std::invalid_argument("render setting " + key + " " + problem + ", got " +
                                formatValue(value));
  if (option.intField)
    this->*(option.intField) = int(value);
  else
    this->*(option.floatField) = float(value);
}

std::map<std::string, double> RenderSettingsMap::asMap() const {
  std::map<std::string, double> values;
  for (const RenderOption& option : renderOptions())
    values[option.key] =
        option.intField ? double(this->*(option.intField)) : this->*(option.floatField);
  return values;
}

}  // namespace penumbra::plugin
