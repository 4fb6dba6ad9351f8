#include "subdivision_primvars.h"

#include <opensubdiv/far/primvarRefiner.h>

namespace penumbra::detail {

namespace Far = OpenSubdiv::Far;

WeldedFaceVarying weldFaceVarying(const Primvar& primvar, const MeshData& cage) {
  const size_t width = size_t(primvar.width);
  WeldedFaceVarying welded;
  welded.valueIndices.resize(cage.faceVertexIndices.size());
  std::vector<std::vector<int>> valuesAtVertex(cage.points.size());
  for (size_t faceVertex = 0; faceVertex < cage.faceVertexIndices.size(); ++faceVertex) {
    const float* value = &primvar.values[faceVertex * width];
    std::vector<int>& candidates = valuesAtVertex[size_t(cage.faceVertexIndices[faceVertex])];
    int match = -1;
    for (int candidate : candidates)
      if (std::equal(value, value + width, &welded.values[size_t(candidate) * width])) {
        match = candidate;
        break;
      }
    if (match < 0) {
      match = welded.valueCount++;
      welded.values.insert(welded.values.end(), value, value + width);
      candidates.push_back(match);
    }
    welded.valueIndices[faceVertex] = match;
  }
  return welded;
}

namespace {

/// A primvar value OpenSubdiv's PrimvarRefiner and stencil tables can accumulate.
template <int Width>
struct Tuple {
  float value[Width];

  void Clear() { std::fill(value, value + Width, 0.0f); }
  void AddWithWeight(const Tuple& source, float weight) {
    for (int i = 0; i < Width; ++i) value[i] += weight * source.value[i];
  }
};

/// Interpolates `base` (the cage's values) through every refinement level and onto the patch
/// table's local points, giving the array that patch control indices address.
template <int Width>
std::vector<float> refineTuples(const Far::TopologyRefiner& refiner, const Far::PatchTable& patches,
                                const std::vector<float>& base, RefinedKind kind, int channel) {
  using Value = Tuple<Width>;
  const bool faceVarying = kind == RefinedKind::FaceVarying;
  const int levelTotal =
      faceVarying ? refiner.GetNumFVarValuesTotal(channel) : refiner.GetNumVerticesTotal();
  int localPoints = patches.GetNumLocalPoints();
  if (kind == RefinedKind::Varying) localPoints = patches.GetNumLocalPointsVarying();
  if (faceVarying) localPoints = patches.GetNumLocalPointsFaceVarying(channel);
  std::vector<Value> refined(size_t(levelTotal + localPoints));
  const size_t baseCount = base.size() / Width;
  for (size_t i = 0; i < baseCount; ++i)
    std::copy(&base[i * Width], &base[i * Width] + Width, refined[i].value);

  Far::PrimvarRefiner primvarRefiner(refiner);
  Value* source = refined.data();
  for (int level = 1; level <= refiner.GetMaxLevel(); ++level) {
    const Far::TopologyLevel& parent = refiner.GetLevel(level - 1);
    Value* destination =
        source + (faceVarying ? parent.GetNumFVarValues(channel) : parent.GetNumVertices());
    switch (kind) {
      case RefinedKind::Vertex:
        primvarRefiner.Interpolate(level, source, destination);
        break;
      case RefinedKind::Varying:
        primvarRefiner.InterpolateVarying(level, source, destination);
        break;
      case RefinedKind::FaceVarying:
        primvarRefiner.InterpolateFaceVarying(level, source, destination, channel);
        break;
    }
    source = destination;
  }
  Value* local = refined.data() + levelTotal;
  switch (kind) {
    case RefinedKind::Vertex:
      patches.ComputeLocalPointValues(refined.data(), local);
      break;
    case RefinedKind::Varying:
      patches.ComputeLocalPointValuesVarying(refined.data(), local);
      break;
    case RefinedKind::FaceVarying:
      patches.ComputeLocalPointValuesFaceVarying(refined.data(), local, channel);
      break;
  }
  std::vector<float> flat(refined.size() * Width);
  for (size_t i = 0; i < refined.size(); ++i)
    std::copy(refined[i].value, refined[i].value + Width, &flat[i * Width]);
  return flat;
}

}  // namespace

std::vector<float> refine(const Far::TopologyRefiner& refiner, const Far::PatchTable& patches,
                          const std::vector<float>& base, int width, RefinedKind kind,
                          int channel) {
  switch (width) {
    case 1:
      return refineTuples<1>(refiner, patches, base, kind, channel);
    case 2:
      return refineTuples<2>(refiner, patches, base, kind, channel);
    case 3:
      return refineTuples<3>(refiner, patches, base, kind, channel);
    default:
      return refineTuples<4>(refiner, patches, base, kind, channel);
  }
}

std::vector<float> flatten(const std::vector<Vec3f>& points) {
  std::vector<float> flat(points.size() * 3);
  for (size_t i = 0; i < points.size(); ++i) {
    flat[3 * i] = points[i].x;
    flat[3 * i + 1] = points[i].y;
    flat[3 * i + 2] = points[i].z;
  }
  return flat;
}

}  // namespace penumbra::detail
