// Render settings: one table (renderOptions) defines each option once. Every front end spells
// an option after its key: penumbra-record's flag --maxPathDepth, Renderer.render's keyword
// max_path_depth and a UsdRenderSettings prim's attribute penumbra:maxPathDepth.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace penumbra::plugin {

/// The render delegate's settings (renderOptions() says what each means), each starting at its
/// option's default; unknown keys are rejected.
struct RenderSettingsMap {
  RenderSettingsMap();

  int samples;  // target samples per pixel: a render pass converges there
  int seed;
  int threads;
  int maxPathDepth;
  int maxDiffuseDepth;
  int maxGlossyDepth;
  int maxTransmissionDepth;
  int maxVolumeDepth;
  int complexity;
  int directLighting;
  int domeSampling;  // DomeSampling
  float adaptiveThreshold;
  int adaptiveMinSamples;
  float indirectClamp;
  float glossyFilter;
  int caustics;                // 1 (default): light tracing too (caustics.h); 0: path tracer alone;
                               // 2: light tracing and photons (caustic_photons.h)
  int indirectSamples;         // paths that go on from each camera ray's first surface; 0: auto
  int lightSamples;            // next-event estimates at each camera ray's first surface
  int guidingTrainingSamples;  // samples per pixel that train path guiding; 0: no guiding
  int textureCacheMB;
  int cryptomatteDepth;  // ranks per pixel of Cryptomatte AOVs

  /// Throws std::invalid_argument for an unknown key, an out-of-range value or a fraction for an
  /// integer setting.
  void set(const std::string& key, double value);
  std::map<std::string, double> asMap() const;
};

/// The kind of value an option takes.
enum class RenderOptionType {
  Int,
  Float,
  Level,  // one of named levels, held as the level's index ("low": 0)
};

/// A render option: its value's kind, range and defaults, and how front ends present it.
struct RenderOption {
  std::string key;  // camelCase
  RenderOptionType type = RenderOptionType::Int;
  int RenderSettingsMap::* intField = nullptr;  // Int and Level
  float RenderSettingsMap::* floatField = nullptr;
  double defaultValue = 0;  // the render delegate's
  /// What penumbra-record and Renderer.render use when neither they nor the render settings
  /// prim set the option (they render finished images: more samples than a preview).
  double frontEndDefault = 0;
  double minimum = 0;
  double maximum = 0;
  std::vector<std::string> levels;  // Level: the name of each value from 0
  std::string help;                 // one line, ending without the default
  std::string defaultMeaning;       // what the default does when its number does not say ("off")
  std::string metavar;              // the value's placeholder in --help ("N"); empty: the key's
  std::string shortFlag;            // another spelling of the flag ("-spp"), or empty
  bool usdrecordFlag = false;       // usdrecord has this flag too
  bool changesPixels = true;        // false: only how fast or in how much memory
  /// False: the front ends set it from their own options (the texture cache from the memory
  /// budget), so it is no flag, keyword or attribute of its own.
  bool userSet = true;

  /// Why `value` cannot be this option's ("must be at least 1"), or empty when it can.
  std::string problem(double value) const;
};

/// Every render option, in the order front ends list them.
const std::vector<RenderOption>& renderOptions();
/// Throws std::invalid_argument naming the known keys when there is no option `key`.
const RenderOption& renderOption(const std::string& key);

}  // namespace penumbra::plugin
