// Subdivision primvars: face-varying data welded into OpenSubdiv channels, and primvar values
// refined through OpenSubdiv's levels onto the patch table's points, where patches combine them.
#pragma once

#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/topologyRefiner.h>

#include <algorithm>
#include <vector>

#include "penumbra/mesh.h"

namespace penumbra::detail {

/// A face-varying channel's topology: face-vertex values that are equal at the same vertex are
/// welded into one value (smooth across the faces that share it); differing ones form a seam.
struct WeldedFaceVarying {
  std::vector<int> valueIndices;  // per face-vertex
  std::vector<float> values;      // width floats per welded value
  int valueCount = 0;
};

WeldedFaceVarying weldFaceVarying(const Primvar& primvar, const MeshData& cage);

enum class RefinedKind { Vertex, Varying, FaceVarying };

/// Interpolates `base` (the cage's values) through every refinement level and onto the patch
/// table's local points, giving the array that patch control indices address.
/// `width` (1 to 4) floats per value.
std::vector<float> refine(const OpenSubdiv::Far::TopologyRefiner& refiner,
                          const OpenSubdiv::Far::PatchTable& patches,
                          const std::vector<float>& base, int width, RefinedKind kind, int channel);

/// x, y, z of every point, one after another.
std::vector<float> flatten(const std::vector<Vec3f>& points);

// Inline: called at every tessellation vertex and curvature sample.

/// Sum of weights[i] * values[indices[i]] for `width`-float values.
inline void combine(const std::vector<float>& values, int width,
                    OpenSubdiv::Far::ConstIndexArray indices, const float* weights, float* result) {
  std::fill(result, result + width, 0.0f);
  for (int i = 0; i < indices.size(); ++i) {
    const float* value = &values[size_t(indices[i]) * size_t(width)];
    for (int c = 0; c < width; ++c) result[c] += weights[i] * value[c];
  }
}

inline Vec3f combinePoints(const std::vector<float>& points,
                           OpenSubdiv::Far::ConstIndexArray indices, const float* weights) {
  float sum[3];
  combine(points, 3, indices, weights, sum);
  return {sum[0], sum[1], sum[2]};
}

}  // namespace penumbra::detail
