// A progressive render pass (cf. HdRenderPass): each execute() syncs what is dirty and adds more
// samples per pixel to its render buffers, restarting when the scene or camera changed.
#pragma once

#include <atomic>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "penumbra/branching.h"
#include "penumbra/caustics.h"
#include "penumbra/film.h"
#include "penumbra/guiding.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/render.h"
#include "penumbra/throughput.h"

namespace penumbra::plugin {

/// Thrown by RenderPass::execute when its cancel flag was set.
class RenderCancelled : public std::runtime_error {
 public:
  RenderCancelled() : std::runtime_error("render cancelled") {}
};

class RenderPass {
 public:
  /// Renders a `width` x `height` image. Throws std::invalid_argument for a non-positive size.
  RenderPass(RenderDelegate& delegate, PrimId cameraId, int width, int height);
  /// Renders only the pixels `crop` of a `width` x `height` image, bit-identical to the same
  /// pixels of the whole image (tiles of a farm). With adaptive sampling a pixel's samples
  /// depend on its neighbours (see Film::updateConvergence), so the pass also renders up to
  /// `margin` pixels around the crop (within the image) and discards them; execute() throws
  /// std::invalid_argument if the margin is below adaptiveSamplingReach() for its sample count.
  /// Throws std::invalid_argument for a crop not inside the image or a negative margin.
  RenderPass(RenderDelegate& delegate, PrimId cameraId, int width, int height, PixelRect crop,
             int margin = 0);

  /// How far, in pixels, adaptive sampling's decisions reach in `samples` samples per pixel:
  /// the number of convergence tests before the last sample (each test looks one pixel
  /// further, see Film::updateConvergence).
  static int adaptiveSamplingReach(int samples, int minSamples);

  /// Syncs, then renders `samples` more samples per pixel. Sample indices continue where the
  /// previous call stopped, so execute(64) equals 4 × execute(16) bit for bit. With adaptive
  /// sampling, pixels are tested for convergence at fixed sample counts (adaptiveMinSamples, then
  /// each power of two above it), whatever the calls' sizes.
  /// Throws std::out_of_range if the camera is not in the render index. Setting `cancel` (from
  /// another thread) stops the render within a sample per thread: the accumulated samples are
  /// dropped (as by reset()) and RenderCancelled is thrown.
  void execute(int samples, const std::atomic<bool>* cancel = nullptr);
  void reset();

  /// The pass's exact state (samples done, the film's accumulators, what they were rendered
  /// with) under `renderKey`, the caller's name for the render (a checkpoint's key).
  std::vector<uint8_t> saveState(const std::string& renderKey) const;
  /// Continues from a state saveState gave: later execute() calls add the same samples as on
  /// the pass that saved it, so the image ends bit-identical. Call after execute(0) synced the
  /// scene. Throws std::invalid_argument, leaving the pass unchanged, for a truncated state or
  /// one of another render key, image size, crop, AOV set or render settings (threads, the
  /// target sample count and the texture cache aside); a state with bytes past its end leaves
  /// the pass reset.
  void loadState(const std::vector<uint8_t>& state, const std::string& renderKey);

  int samplesDone() const { return samplesDone_; }
  /// Samples per pixel actually taken, on average (fewer than samplesDone() where adaptive
  /// sampling stopped pixels).
  double meanSamples() const {
    return double(samplesTaken()) / (double(crop_.width) * double(crop_.height));
  }
  /// Samples taken by all the pixels together.
  uint64_t samplesTaken() const { return film_.samplesTaken(crop_); }
  /// Rays traced through the scene's BVH for the samples accumulated so far.
  uint64_t raysTraced() const { return film_.raysTraced(crop_); }
  /// Light paths traced for caustics (penumbra/caustics.h) so far: 0 where the light tracer
  /// took nothing.
  uint64_t lightPathsTraced() const { return film_.lightPaths(); }
  /// The share of its MIS weight next-event estimation keeps for untextured domes at the first
  /// surfaces (docs/dome-sampling.md): the domeSampling setting's (mis 1, bsdf 0), or the
  /// pilot's choice (auto; 1 before the pass has rendered samples, and where the scene has no
  /// such dome).
  float constantDomeShareUsed() const;
  /// The paths that go on from each camera ray's first surface (docs/branching.md): the
  /// indirectSamples setting's, or (0) the mean over the image's pixels of the pilot's counts
  /// per region (1 before the pass has rendered samples).
  double indirectSamplesUsed() const;
  /// The pilot's counts per region (indirectSamples 0), once the pass has rendered samples;
  /// null where the setting sets one count.
  const penumbra::FirstSurfaceBranches* regionBranches() const {
    return regionBranches_ ? &*regionBranches_ : nullptr;
  }
  /// The light estimates at each camera ray's first surface (docs/branching.md): the
  /// lightSamples setting's, or (0) the pilot's choice (1 before the pass has rendered samples).
  int lightSamplesUsed() const;
  /// Syncs, then times Embree alone on this pass's camera and scene (see throughput.h), with
  /// the render settings' thread count, on made-up rays and on the rays of one unguided sample
  /// per pixel with the render settings (branching as they say).
  RawRayThroughput measureRawThroughput();
  /// The target sample count is reached, or adaptive sampling has stopped every pixel.
  bool converged() const {
    return samplesDone_ >= delegate_.settings().samples || film_.activePixels() == 0;
  }
  /// The size of what the pass renders: the crop's, or the image's.
  int width() const { return crop_.width; }
  int height() const { return crop_.height; }

  /// The AOVs a pass can accumulate (penumbra::aovNames(): color, alpha, depth, Z, normal,
  /// Neye, position, albedo, primId, instanceId, elementId, primvars:NAME, sampleCount,
  /// variance; docs/aovs.md).
  static const std::vector<std::string>& aovNames();
  /// Which AOVs to accumulate besides color, alpha, Z and sampleCount (which every pass has),
  /// and no others (they cost time): a change drops the samples taken. Throws std::invalid_argument
  /// for an unknown name.
  void setAovs(const std::vector<std::string>& names);
  /// Resolved buffer of the crop (or image), row-major from the top, aovChannels(name) floats
  /// per pixel; colour (not alpha) times the camera's exposure scale (CameraParams), variance
  /// times its square. Throws std::invalid_argument for an unknown name or one not accumulated
  /// (see setAovs).
  std::vector<float> aov(const std::string& name) const;
  /// A Cryptomatte AOV (CryptoObject, CryptoMaterial or CryptoAsset, accumulated: see
  /// setAovs) of the crop (or image), row-major from the top: per pixel the render settings'
  /// cryptomatteDepth ranks as (id, coverage) pairs, zero-padded to whole RGBA layers
  /// (aovChannels). `names`: the names of the placements for this layer
  /// (RenderDelegate::placementHashes); a placement without one counts as a miss. A material
  /// layer also names the materials of meshes' subsets (`subsetNames`: mesh id → the name of
  /// each of its subsets' materials, in setSubsetMaterials' order; RenderDelegate::slotHashes):
  /// samples on the faces a subset binds take its name, not their placement's.
  std::vector<float> cryptomatte(
      const std::map<PrimId, std::vector<std::string>>& names,
      const std::map<PrimId, std::vector<std::string>>& subsetNames = {}) const;
  /// Floats per pixel of an AOV: 4 for color, 3 for vectors, a primvar's width as the scene's
  /// meshes have it (1 where none has it), 4 per two ranks of Cryptomatte AOVs, 1 otherwise.
  int aovChannels(const std::string& name) const;
  /// AOV bindings (cf. HdRenderPassAovBinding): after every execute() each bound AOV is
  /// resolved into its render buffer, which must have the pass's size. Throws
  /// std::invalid_argument for an unknown AOV, std::out_of_range for a missing buffer.
  void setAovBindings(std::map<std::string, PrimId> bindings);

 private:
  /// Where a step of execute() did not finish (`cancel` was set), drops the pass's samples (as
  /// reset()) and throws RenderCancelled.
  void dropIfCancelled(bool finished);
  /// The first sample count after `samplesDone` at which adaptive sampling tests pixels.
  static int nextConvergenceTest(int samplesDone, int minSamples);
  /// Throws std::invalid_argument if the crop's margin is too narrow for adaptive sampling to
  /// take `samples` samples per pixel in the crop as in the whole image.
  void checkCropMargin(int samples) const;
  /// What a sample is, from the render settings (the render loop sets per pass whether it
  /// branches and guides).
  IntegratorSettings integratorSettings() const;
  /// The crop's pixels of `values`, resolved for the film with `stored` floats per pixel, of
  /// which the first `wanted` are kept.
  std::vector<float> cropped(const std::vector<float>& values, size_t stored, size_t wanted) const;

  /// Path guiding: records the samples that train it while they are rendered, and builds the
  /// field once they are all taken (docs/path-guiding.md).
  void prepareGuiding(const penumbra::Camera& camera,
                      const penumbra::RenderSettings& renderSettings,
                      const std::atomic<bool>* cancel);
  /// The share of its MIS weight next-event estimation keeps for untextured domes at the camera
  /// rays' first surfaces: as the domeSampling setting says (mis 1, bsdf 0), or (auto) as the
  /// pilot chose, once per render (penumbra/dome_sampling.h).
  float constantDomeShare(const penumbra::Camera& camera,
                          const penumbra::RenderSettings& renderSettings);
  /// Runs the branching pilot for `renderSettings` (with their dome share) once per render
  /// where the indirectSamples or lightSamples setting leaves its count to it (0), and keeps
  /// its choice (penumbra/branching.h).
  void chooseFirstSurfaceSamples(const penumbra::Camera& camera,
                                 const penumbra::RenderSettings& renderSettings);
  /// What a sample of this pass is rendered with (guiding aside): the settings' threads and
  /// integrator, with the dome share, the branches and the light estimates the pilots chose,
  /// leaving out what `caustics` takes (the pilots too, as the samples will).
  penumbra::RenderSettings pilotedSettings(const penumbra::Camera& camera,
                                           const penumbra::CausticTakeover* caustics = nullptr);

  RenderDelegate& delegate_;
  PrimId cameraId_;
  int imageWidth_, imageHeight_;
  PixelRect crop_;  // the pixels aov() returns
  Film film_;       // the crop and its margin
  int samplesDone_ = 0;
  // What the accumulated samples were rendered with; any change restarts accumulation.
  uint64_t sceneVersion_ = ~uint64_t(0);
  int cameraSyncCount_ = -1;
  float exposureScale_ = 1;  // the camera's, at the last execute
  std::map<std::string, double> settingsUsed_;
  std::map<std::string, PrimId> aovBindings_;
  // Path guiding: the field once trained, the training records until then, and the samples
  // [0, guidingRecordedThrough_) of every image pixel they hold.
  std::optional<GuidingField> guidingField_;
  GuidingRecorder guidingRecorder_;
  int guidingRecordedThrough_ = 0;
  std::optional<float> constantDomeShare_;  // the dome pilot's choice, once made
  // The branching pilot's choice, once made: its one count of each kind, and its branches per
  // region where the indirectSamples setting leaves them to it.
  std::optional<penumbra::BranchingPilot::Choice> firstSurfaceSamples_;
  std::optional<penumbra::FirstSurfaceBranches> regionBranches_;
};

}  // namespace penumbra::plugin
