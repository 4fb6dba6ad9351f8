// Prims the C++ render tests build their scenes from.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "transforms.h"

namespace penumbra::test {

/// A square in the XZ plane at height y, facing +Y (counter-clockwise seen from above).
inline void addFloor(plugin::RenderDelegate& delegate, const plugin::PrimId& id, float halfSize,
                     float y = 0) {
  delegate.insertRprim("mesh", id);
  plugin::Mesh& mesh = delegate.mesh(id);
  mesh.setPoints({{-halfSize, y, -halfSize},
                  {-halfSize, y, halfSize},
                  {halfSize, y, halfSize},
                  {halfSize, y, -halfSize}});
  mesh.setTopology({4}, {0, 1, 2, 3}, false, "none");
}

/// A closed UV sphere (shared seam and pole vertices, so every edge has two faces).
inline void addSphere(plugin::RenderDelegate& delegate, const plugin::PrimId& id, float radius,
                      int stacks = 32, int slices = 64) {
  std::vector<Vec3f> points{{0, radius, 0}};
  for (int i = 1; i < stacks; ++i) {
    const float theta = kPi * float(i) / float(stacks);
    for (int j = 0; j < slices; ++j) {
      const float phi = 2 * kPi * float(j) / float(slices);
      points.push_back({radius * std::sin(theta) * std::cos(phi), radius * std::cos(theta),
                        -radius * std::sin(theta) * std::sin(phi)});
    }
  }
  points.push_back({0, -radius, 0});
  const int bottom = int(points.size()) - 1;
  const auto ring = [&](int i, int j) { return 1 + (i - 1) * slices + (j % slices); };
  std::vector<int> counts, indices;
  for (int j = 0; j < slices; ++j) {
    counts.push_back(3);
    indices.insert(indices.end(), {0, ring(1, j), ring(1, j + 1)});
    counts.push_back(3);
    indices.insert(indices.end(), {bottom, ring(stacks - 1, j + 1), ring(stacks - 1, j)});
  }
  for (int i = 1; i + 1 < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      counts.push_back(4);
      indices.insert(indices.end(),
                     {ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
  delegate.insertRprim("mesh", id);
  delegate.mesh(id).setPoints(std::move(points));
  delegate.mesh(id).setTopology(std::move(counts), std::move(indices), false, "none");
}

/// Camera "/cam" with a square aperture of 1 (its field of view set by `focalLength`).
inline void addCamera(plugin::RenderDelegate& delegate, const Transform& transform,
                      float focalLength = 50) {
  delegate.insertSprim("camera", "/cam");
  CameraParams params;
  params.focalLength = focalLength;
  params.horizontalAperture = params.verticalAperture = 1;
  params.nearClip = 0.01f;
  delegate.camera("/cam").setParams(params);
  delegate.camera("/cam").setTransform(transform);
}

/// Syncs the delegate's scene (a pass that renders no sample) and returns camera "/cam" as a
/// `size` x `size` image sees it: for tests that call the renderer below the render pass.
inline Camera syncedCamera(plugin::RenderDelegate& delegate, int size) {
  plugin::RenderPass(delegate, "/cam", size, size).execute(0);
  return Camera(delegate.camera("/cam").params(), size, size);
}

/// Grey balls on a grey floor under a sky, seen from above. Seen from the floor, the balls hide
/// part of the sky; lit by the sky alone they are much darker than it (with an albedo below ½,
/// what they reflect is below half the sky's radiance). With `sun`, a sun whose irradiance is five
/// times the sky's (the benchmark's outdoor scenes have about four) lights them too, and their
/// sunlit sides are brighter than the sky.
inline void ballsUnderSky(plugin::RenderDelegate& delegate, bool sun) {
  addFloor(delegate, "/floor", 20);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  for (int i = 0; i < 3; ++i) {
    const std::string id = "/ball" + std::to_string(i);
    addSphere(delegate, id, 0.6f, 12, 24);
    delegate.mesh(id).setTransform(translation(1.3 * (i - 1), 0.6, 0));
    delegate.mesh(id).setDisplayColor({Vec3f(0.4f)}, Interpolation::Constant);
  }
  delegate.insertSprim("domeLight", "/sky");
  delegate.light("/sky").setParam("intensity", 0.35f);
  if (sun) {
    delegate.insertSprim("distantLight", "/sun");
    delegate.light("/sun").setParam("intensity", 6.0f);
    delegate.light("/sun").setParam("angle", 2.0f);
    delegate.light("/sun").setParam("normalize", true);
    delegate.light("/sun").setTransform(facingDown(0, 10, 0));
  }
  addCamera(delegate, facingDown(0, 5, 0), 1.5f);
}

/// A grey floor (Lambertian, albedo 0.5) under a double-sided square `ceiling` at height
/// `ceilingHeight`, both 100 units across.
inline void floorUnderCeiling(plugin::RenderDelegate& delegate, const plugin::PrimId& ceiling,
                              float ceilingHeight) {
  addFloor(delegate, "/floor", 50);
  delegate.mesh("/floor").setDisplayColor({Vec3f(0.5f)}, Interpolation::Constant);
  addFloor(delegate, ceiling, 50, ceilingHeight);
  delegate.mesh(ceiling).setDoubleSided(true);
}

/// floorUnderCeiling with the ceiling at height 3, lit only by a panel facing up below it, seen
/// from above by "/cam": the camera sees nothing the panel lights directly, and all of the
/// floor's light is found beyond the surfaces camera rays meet.
inline void floorLitByCeiling(plugin::RenderDelegate& delegate) {
  floorUnderCeiling(delegate, "/ceiling", 3);
  delegate.insertSprim("rectLight", "/panel");
  delegate.light("/panel").setParam("intensity", 20.0f);
  const double facingUp[16] = {1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 2.5, 0, 1};
  delegate.light("/panel").setTransform(Transform::fromRowMajor(facingUp));
  addCamera(delegate, facingDown(0, 2, 0), 10);
}

}  // namespace penumbra::test
