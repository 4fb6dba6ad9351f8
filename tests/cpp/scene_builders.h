// Prims the C++ render tests build their scenes from.
#pragma once

#include <cmath>
#include <vector>

#include "penumbra/plugin/render_delegate.h"

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

}  // namespace penumbra::test
