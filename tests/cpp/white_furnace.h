// A white furnace for the renderer's tests: a scene under a uniform dome of radiance 1, seen
// through the integrator, whose white diffuse objects must look like the dome.
#pragma once

#include <utility>
#include <vector>

#include "penumbra/aov.h"
#include "penumbra/camera.h"
#include "penumbra/filter.h"
#include "penumbra/integrator.h"
#include "penumbra/light.h"
#include "penumbra/scene.h"
#include "transforms.h"

namespace penumbra::test {

struct FurnaceImage {
  double meanRadiance = 0;  // over every sample of the image, the dome included
  double coverage = 0;      // the fraction of samples whose camera ray hit the scene
};

/// Lights `scene` by a white dome alone, commits it, and renders 16 × 16 pixels at 64 samples
/// from a camera at z = 6 looking down −z, with the path and diffuse depths raised to 32 and
/// `indirectSamples` paths from each camera ray's first surface.
inline FurnaceImage renderUnderWhiteDome(Scene& scene, int indirectSamples = 1) {
  LightParams dome;
  dome.type = LightType::Dome;
  std::vector<Light> lights;
  lights.emplace_back(dome);
  scene.lights().setLights(std::move(lights));
  scene.commit();
  CameraParams lens;
  lens.cameraToWorld = translation(0, 0, 6);
  const int size = 16;
  const Camera camera(lens, size, size);
  const PixelFilter filter;
  IntegratorSettings settings;
  settings.maxPathDepth = settings.maxDiffuseDepth = 32;
  settings.indirectSamples = indirectSamples;
  double sum = 0;
  int seen = 0;
  const uint32_t samples = 64;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (uint32_t i = 0; i < samples; ++i) {
        FirstHitSample first;
        const CameraSample sample =
            renderCameraSample(scene, camera, filter, x, y, i, settings, &first);
        sum += (sample.radiance.x + sample.radiance.y + sample.radiance.z) / 3;
        seen += first.hit;
      }
  const double total = double(size) * size * samples;
  return {sum / total, seen / total};
}

}  // namespace penumbra::test
