// The limit-surface tessellator: OpenSubdiv feature-adaptive patches over a validated cage
// (subdivision_cage.h) with refined primvars (subdivision_primvars.h), diced face by face with
// Bfr tessellation patterns and stitched into one watertight triangle mesh.
#include "penumbra/subdivision.h"

#include <opensubdiv/bfr/tessellation.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/ptexIndices.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "subdivision_cage.h"
#include "subdivision_primvars.h"

namespace penumbra {

namespace Bfr = OpenSubdiv::Bfr;
namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

namespace {

// Feature-adaptive isolation depth: irregular vertices are refined this many times before
// Gregory end caps (1/8 of a face across) take over; their deviation from the true limit surface
// is far below a pixel, and level 4 costs ~1.5x the set-up time for no visible gain. Semi-sharp
// creases need no deeper isolation: single-crease patches evaluate them exactly.
constexpr int kIsolationLevel = 3;

// The most control points of any patch OpenSubdiv builds here: a Gregory basis patch (20);
// regular B-spline 16, Gregory triangle 18, Loop box-spline 12, bilinear 4.
constexpr int kMaxPatchPoints = 20;

// Sampling second derivatives on a 4x4 grid per patch misses the maxima between samples of the
// quadratic (in the other parameter) second derivative; this margin covers them.
constexpr float kCurvatureSamplingMargin = 1.25f;

/// Whether a primvar is evaluated at every tessellation vertex (rather than passed through).
bool isEvaluated(Interpolation interpolation) {
  return interpolation == Interpolation::Varying || interpolation == Interpolation::Vertex ||
         interpolation == Interpolation::FaceVarying;
}

/// A cage primvar prepared for evaluation on the patches.
struct RefinedPrimvar {
  PrimvarName name;
  Interpolation interpolation;
  int width;
  std::vector<float> values;  // as authored (constant, uniform) or refined (the others)
  int faceVaryingChannel = -1;
};

/// One base face's tessellation, evaluated: pattern coordinates (boundary first, as Bfr orders
/// them), triangles over them, and the limit surface at each.
struct FaceDicing {
  int boundaryCount = 0;
  std::vector<float> coords;  // (u, v) per tessellation vertex
  std::vector<int> facets;    // 3 coordinate indices per triangle, counter-clockwise in (u, v)
  std::vector<Vec3f> positions, normals;
  std::vector<std::vector<float>> primvars;  // per evaluated primvar: width floats per vertex
};

}  // namespace

struct LimitSurfaceTessellator::Impl {
  Sdc::SchemeType scheme = Sdc::SCHEME_CATMARK;
  bool leftHanded = false;
  bool doubleSided = false;
  size_t pointCount = 0;
  size_t faceCount = 0;
  std::unique_ptr<Far::TopologyRefiner> refiner;  // null for a cage without faces
  std::unique_ptr<Far::PatchTable> patches;
  std::unique_ptr<Far::PatchMap> patchMap;
  std::vector<int> firstPtexFace;   // per base face
  std::vector<int> faceOfPtexFace;  // per ptex face
  std::vector<uint8_t> hasSurface;  // per base face: not a hole, and patches cover it
  // Where the limit normal is discontinuous (infinitely sharp creases and corners, non-manifold
  // topology, every edge of a bilinear cage) each face keeps its own output points.
  std::vector<uint8_t> splitVertex, splitEdge;
  std::vector<RefinedPrimvar> primvars;  // the cage's, then displayColor
  int displayColorPrimvar = -1;
  Interpolation displayColorInterpolation = Interpolation::Constant;

  const Far::TopologyLevel& base() const { return refiner->GetLevel(0); }

  Bfr::Parameterization parameterization(int face) const {
    return Bfr::Parameterization(scheme, base().GetFaceVertices(face).size());
  }

  struct PatchLocation {
    const Far::PatchTable::PatchHandle* handle;
    int ptexFace;
    float s, t;
  };

  PatchLocation locate(int face, const Bfr::Parameterization& param, const float uv[2]) const {
    float st[2] = {uv[0], uv[1]};
    int ptexFace = firstPtexFace[size_t(face)];
    if (param.HasSubFaces()) ptexFace += param.ConvertCoordToNormalizedSubFace(uv, st);
    return {patchMap->FindPatch(ptexFace, st[0], st[1]), ptexFace, st[0], st[1]};
  }

  LimitSample evaluatePoint(const std::vector<float>& refinedPoints, const PatchLocation& at,
                            bool triangular) const {
    float wP[kMaxPatchPoints], wDu[kMaxPatchPoints], wDv[kMaxPatchPoints];
    patches->EvaluateBasis(*at.handle, at.s, at.t, wP, wDu, wDv);
    const Far::ConstIndexArray controls = patches->GetPatchVertices(*at.handle);
    LimitSample sample;
    sample.position = detail::combinePoints(refinedPoints, controls, wP);
    sample.dPdu = detail::combinePoints(refinedPoints, controls, wDu);
    sample.dPdv = detail::combinePoints(refinedPoints, controls, wDv);
    Vec3f normal = cross(sample.dPdu, sample.dPdv);
    if (!(length(normal) > 0.0f)) {
      // A degenerate tangent plane (collapsed cage, cone tip): take the normal a hair towards
      // the ptex face's centre, which is what the surface around the point shows.
      const float centre = triangular ? 1.0f / 3.0f : 0.5f;
      const float s = at.s + (centre - at.s) * 1e-3f, t = at.t + (centre - at.t) * 1e-3f;
      const Far::PatchTable::PatchHandle* handle = patchMap->FindPatch(at.ptexFace, s, t);
      if (handle) {
        patches->EvaluateBasis(*handle, s, t, wP, wDu, wDv);
        const Far::ConstIndexArray nearby = patches->GetPatchVertices(*handle);
        normal = cross(detail::combinePoints(refinedPoints, nearby, wDu),
                       detail::combinePoints(refinedPoints, nearby, wDv));
      }
    }
    sample.normal = length(normal) > 0.0f ? normalize(normal) : Vec3f(0, 0, 1);
    if (leftHanded) sample.normal = -sample.normal;
    return sample;
  }

  void evaluatePrimvar(const RefinedPrimvar& primvar, const PatchLocation& at,
                       float* result) const {
    float weights[kMaxPatchPoints];
    switch (primvar.interpolation) {
      case Interpolation::Vertex:
        patches->EvaluateBasis(*at.handle, at.s, at.t, weights);
        detail::combine(primvar.values, primvar.width, patches->GetPatchVertices(*at.handle),
                        weights, result);
        break;
      case Interpolation::Varying:
        patches->EvaluateBasisVarying(*at.handle, at.s, at.t, weights);
        detail::combine(primvar.values, primvar.width, patches->GetPatchVaryingVertices(*at.handle),
                        weights, result);
        break;
      case Interpolation::FaceVarying:
        patches->EvaluateBasisFaceVarying(*at.handle, at.s, at.t, weights, nullptr, nullptr,
                                          nullptr, nullptr, nullptr, primvar.faceVaryingChannel);
        detail::combine(primvar.values, primvar.width,
                        patches->GetPatchFVarValues(*at.handle, primvar.faceVaryingChannel),
                        weights, result);
        break;
      case Interpolation::Constant:
      case Interpolation::Uniform:
        break;
    }
  }

  std::vector<float> refinePoints(const std::vector<Vec3f>& points) const {
    if (points.size() != pointCount)
      throw std::invalid_argument("points has " + std::to_string(points.size()) +
                                  " entries but the cage has " + std::to_string(pointCount));
    detail::checkFinitePoints(points);
    return detail::refine(*refiner, *patches, detail::flatten(points), 3,
                          detail::RefinedKind::Vertex, 0);
  }

  FaceDicing dice(int face, const std::vector<int>& edgeRates, int innerRate,
                  const std::vector<float>& refinedPoints) const {
    const Bfr::Parameterization param = parameterization(face);
    const Far::ConstIndexArray edges = base().GetFaceEdges(face);
    std::vector<int> rates(size_t(edges.size()) + 1);
    for (int k = 0; k < edges.size(); ++k) rates[size_t(k)] = edgeRates[size_t(edges[k])];
    rates.back() = innerRate;
    const Bfr::Tessellation pattern(param, int(rates.size()), rates.data(),
                                    Bfr::Tessellation::Options().SetFacetSize(3));
    FaceDicing dicing;
    const size_t coordCount = size_t(pattern.GetNumCoords());
    dicing.boundaryCount = pattern.GetNumBoundaryCoords();
    dicing.coords.resize(2 * coordCount);
    pattern.GetCoords(dicing.coords.data());
    dicing.facets.resize(3 * size_t(pattern.GetNumFacets()));
    pattern.GetFacets(dicing.facets.data());

    const bool triangular = param.GetType() == Bfr::Parameterization::TRI;
    dicing.positions.resize(coordCount);
    dicing.normals.resize(coordCount);
    dicing.primvars.resize(primvars.size());
    for (size_t p = 0; p < primvars.size(); ++p)
      if (isEvaluated(primvars[p].interpolation))
        dicing.primvars[p].resize(coordCount * size_t(primvars[p].width));
    for (size_t i = 0; i < coordCount; ++i) {
      const PatchLocation at = locate(face, param, &dicing.coords[2 * i]);
      const LimitSample sample = evaluatePoint(refinedPoints, at, triangular);
      dicing.positions[i] = sample.position;
      dicing.normals[i] = sample.normal;
      for (size_t p = 0; p < primvars.size(); ++p)
        if (isEvaluated(primvars[p].interpolation))
          evaluatePrimvar(primvars[p], at, &dicing.primvars[p][i * size_t(primvars[p].width)]);
    }
    return dicing;
  }
};

LimitSurfaceTessellator::LimitSurfaceTessellator(const MeshData& cage, SubdivisionScheme scheme,
                                                 const SubdivisionTags& tags)
    : impl_(std::make_unique<Impl>()) {
  detail::validateCage(cage, scheme, tags);
  const Sdc::Options options = detail::subdivisionOptions(tags);

  std::vector<Primvar> allPrimvars = cage.primvars;
  if (!cage.displayColor.empty()) {
    Primvar displayColor{"displayColor", detail::flatten(cage.displayColor), 3,
                         cage.displayColorInterpolation};
    impl_->displayColorPrimvar = int(allPrimvars.size());
    impl_->displayColorInterpolation = cage.displayColorInterpolation;
    allPrimvars.push_back(std::move(displayColor));
  }
  for (const Primvar& primvar : allPrimvars) validatePrimvar(primvar, cage);

  Impl& impl = *impl_;
  impl.scheme = detail::toOsdScheme(scheme);
  impl.leftHanded = cage.leftHanded;
  impl.doubleSided = cage.doubleSided;
  impl.pointCount = cage.points.size();
  impl.faceCount = cage.faceVertexCounts.size();
  for (const Primvar& primvar : allPrimvars)
    impl.primvars.push_back(
        {primvar.name, primvar.interpolation, primvar.width, primvar.values, -1});
  if (impl.faceCount == 0) return;

  std::vector<detail::WeldedFaceVarying> welded;
  for (size_t p = 0; p < allPrimvars.size(); ++p)
    if (allPrimvars[p].interpolation == Interpolation::FaceVarying) {
      impl.primvars[p].faceVaryingChannel = int(welded.size());
      welded.push_back(detail::weldFaceVarying(allPrimvars[p], cage));
    }
  std::vector<Far::TopologyDescriptor::FVarChannel> channels(welded.size());
  for (size_t c = 0; c < welded.size(); ++c) {
    channels[c].numValues = welded[c].valueCount;
    channels[c].valueIndices = welded[c].valueIndices.data();
  }

  std::vector<int> creasePairs;
  std::vector<float> creaseWeights;
  const bool sharpnessPerEdge = tags.creaseSharpnesses.size() != tags.creaseLengths.size();
  size_t chainStart = 0, edgeIndex = 0;
  for (size_t crease = 0; crease < tags.creaseLengths.size(); ++crease) {
    const size_t length = size_t(tags.creaseLengths[crease]);
    for (size_t i = chainStart; i + 1 < chainStart + length; ++i, ++edgeIndex) {
      creasePairs.push_back(tags.creaseIndices[i]);
      creasePairs.push_back(tags.creaseIndices[i + 1]);
      creaseWeights.push_back(tags.creaseSharpnesses[sharpnessPerEdge ? edgeIndex : crease]);
    }
    chainStart += length;
  }

  Far::TopologyDescriptor descriptor;
  descriptor.numVertices = int(cage.points.size());
  descriptor.numFaces = int(cage.faceVertexCounts.size());
  descriptor.numVertsPerFace = cage.faceVertexCounts.data();
  descriptor.vertIndicesPerFace = cage.faceVertexIndices.data();
  descriptor.numCreases = int(creaseWeights.size());
  descriptor.creaseVertexIndexPairs = creasePairs.data();
  descriptor.creaseWeights = creaseWeights.data();
  descriptor.numCorners = int(tags.cornerIndices.size());
  descriptor.cornerVertexIndices = tags.cornerIndices.data();
  descriptor.cornerWeights = tags.cornerSharpnesses.data();
  descriptor.numHoles = int(tags.holeIndices.size());
  descriptor.holeIndices = tags.holeIndices.data();
  descriptor.numFVarChannels = int(channels.size());
  descriptor.fvarChannels = channels.data();

  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  impl.refiner.reset(Factory::Create(descriptor, Factory::Options(impl.scheme, options)));
  if (!impl.refiner)
    throw std::invalid_argument("OpenSubdiv cannot represent this mesh's topology");

  Far::PatchTableFactory::Options patchOptions(kIsolationLevel);
  patchOptions.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
  patchOptions.useInfSharpPatch = true;
  patchOptions.useSingleCreasePatch = true;
  patchOptions.generateFVarTables = !channels.empty();
  patchOptions.generateFVarLegacyLinearPatches = false;  // smooth face-varying patches
  patchOptions.generateLegacySharpCornerPatches = false;
  impl.refiner->RefineAdaptive(patchOptions.GetRefineAdaptiveOptions());
  impl.patches.reset(Far::PatchTableFactory::Create(*impl.refiner, patchOptions));
  impl.patchMap = std::make_unique<Far::PatchMap>(*impl.patches);

  const Far::TopologyLevel& base = impl.base();
  const Far::PtexIndices ptexIndices(*impl.refiner);
  impl.firstPtexFace.resize(impl.faceCount);
  impl.faceOfPtexFace.resize(size_t(ptexIndices.GetNumFaces()));
  impl.hasSurface.assign(impl.faceCount, 0);
  for (int face = 0; face < int(impl.faceCount); ++face) {
    const int first = ptexIndices.GetFaceId(face);
    const int subFaces =
        impl.parameterization(face).HasSubFaces() ? base.GetFaceVertices(face).size() : 1;
    impl.firstPtexFace[size_t(face)] = first;
    bool covered = !base.IsFaceHole(face);
    for (int sub = 0; sub < subFaces; ++sub) {
      impl.faceOfPtexFace[size_t(first + sub)] = face;
      covered = covered && impl.patchMap->FindPatch(first + sub, 0.25, 0.25) != nullptr;
    }
    impl.hasSurface[size_t(face)] = covered;
  }

  const bool splitEverywhere = scheme == SubdivisionScheme::Bilinear;
  impl.splitEdge.resize(size_t(base.GetNumEdges()));
  for (int edge = 0; edge < base.GetNumEdges(); ++edge)
    impl.splitEdge[size_t(edge)] = splitEverywhere || base.IsEdgeNonManifold(edge) ||
                                   (base.IsEdgeInfSharp(edge) && !base.IsEdgeBoundary(edge));
  impl.splitVertex.resize(size_t(base.GetNumVertices()));
  for (int vertex = 0; vertex < base.GetNumVertices(); ++vertex) {
    bool split = splitEverywhere || base.IsVertexNonManifold(vertex) ||
                 (base.IsVertexInfSharp(vertex) && base.GetVertexFaces(vertex).size() > 1);
    for (int edge : base.GetVertexEdges(vertex)) split = split || impl.splitEdge[size_t(edge)];
    impl.splitVertex[size_t(vertex)] = split;
  }

  for (RefinedPrimvar& primvar : impl.primvars) {
    switch (primvar.interpolation) {
      case Interpolation::Vertex:
        primvar.values = detail::refine(*impl.refiner, *impl.patches, primvar.values, primvar.width,
                                        detail::RefinedKind::Vertex, 0);
        break;
      case Interpolation::Varying:
        primvar.values = detail::refine(*impl.refiner, *impl.patches, primvar.values, primvar.width,
                                        detail::RefinedKind::Varying, 0);
        break;
      case Interpolation::FaceVarying:
        primvar.values = detail::refine(
            *impl.refiner, *impl.patches, welded[size_t(primvar.faceVaryingChannel)].values,
            primvar.width, detail::RefinedKind::FaceVarying, primvar.faceVaryingChannel);
        break;
      case Interpolation::Constant:
      case Interpolation::Uniform:
        break;
    }
  }
}

LimitSurfaceTessellator::~LimitSurfaceTessellator() = default;
LimitSurfaceTessellator::LimitSurfaceTessellator(LimitSurfaceTessellator&&) noexcept = default;
LimitSurfaceTessellator& LimitSurfaceTessellator::operator=(LimitSurfaceTessellator&&) noexcept =
    default;

size_t LimitSurfaceTessellator::faceCount() const {
  return impl_->faceCount;
}

std::vector<float> LimitSurfaceTessellator::curvatureBounds(
    const std::vector<Vec3f>& points) const {
  const Impl& impl = *impl_;
  std::vector<float> bounds(impl.faceCount, 0.0f);
  if (!impl.refiner) return bounds;
  const std::vector<float> refinedPoints = impl.refinePoints(points);
  // Patch-local sample positions, nudged inside so that the patch map finds this very patch.
  const float samples[4] = {1e-4f, 1.0f / 3.0f, 2.0f / 3.0f, 1.0f - 1e-4f};
  float wP[kMaxPatchPoints], wDu[kMaxPatchPoints], wDv[kMaxPatchPoints];
  float wDuu[kMaxPatchPoints], wDuv[kMaxPatchPoints], wDvv[kMaxPatchPoints];
  for (int array = 0; array < impl.patches->GetNumPatchArrays(); ++array) {
    const Far::PatchDescriptor::Type type = impl.patches->GetPatchArrayDescriptor(array).GetType();
    const bool triangular = type == Far::PatchDescriptor::LOOP ||
                            type == Far::PatchDescriptor::GREGORY_TRIANGLE ||
                            type == Far::PatchDescriptor::TRIANGLES;
    const Far::ConstPatchParamArray params = impl.patches->GetPatchParams(array);
    for (int patch = 0; patch < impl.patches->GetNumPatches(array); ++patch) {
      const Far::PatchParam& param = params[patch];
      const int ptexFace = param.GetFaceId();
      const int face = impl.faceOfPtexFace[size_t(ptexFace)];
      // Sub-face parameters span half an edge: a rate of N segments per edge gives N/2 per
      // sub-face edge, so second derivatives count 4 times in per-edge units.
      const float unitScale = impl.parameterization(face).HasSubFaces() ? 4.0f : 1.0f;
      float bound = 0.0f;
      for (float s0 : samples)
        for (float t0 : samples) {
          if (triangular && s0 + t0 > 1.0f) continue;
          float s = s0, t = t0;
          if (triangular)
            param.UnnormalizeTriangle(s, t);
          else
            param.Unnormalize(s, t);
          const Far::PatchTable::PatchHandle* handle = impl.patchMap->FindPatch(ptexFace, s, t);
          if (!handle) continue;
          impl.patches->EvaluateBasis(*handle, s, t, wP, wDu, wDv, wDuu, wDuv, wDvv);
          const Far::ConstIndexArray controls = impl.patches->GetPatchVertices(*handle);
          const float uu = length(detail::combinePoints(refinedPoints, controls, wDuu));
          const float uv = length(detail::combinePoints(refinedPoints, controls, wDuv));
          const float vv = length(detail::combinePoints(refinedPoints, controls, wDvv));
          // Any unit direction d: |d_u^2 Puu + 2 d_u d_v Puv + d_v^2 Pvv| <= max(|Puu|,|Pvv|)
          // + |Puv|.
          bound = std::max(bound, std::max(uu, vv) + uv);
        }
      float& faceBound = bounds[size_t(face)];
      faceBound = std::max(faceBound, bound * unitScale * kCurvatureSamplingMargin);
    }
  }
  for (size_t face = 0; face < impl.faceCount; ++face)
    if (!impl.hasSurface[face]) bounds[face] = 0.0f;
  return bounds;
}

TriangleMesh LimitSurfaceTessellator::tessellate(const std::vector<Vec3f>& points,
                                                 const std::vector<int>& rates) const {
  const Impl& impl = *impl_;
  if (rates.size() != 1 && rates.size() != impl.faceCount)
    throw std::invalid_argument("tessellation rates has " + std::to_string(rates.size()) +
                                " entries, expected 1 or one per face (" +
                                std::to_string(impl.faceCount) + ")");
  for (size_t i = 0; i < rates.size(); ++i)
    if (rates[i] < 1)
      throw std::invalid_argument("tessellation rates[" + std::to_string(i) +
                                  "] = " + std::to_string(rates[i]) + " is below 1");

  TriangleMesh mesh;
  mesh.doubleSided = impl.doubleSided;
  std::vector<std::vector<float>> values(impl.primvars.size());
  for (size_t p = 0; p < impl.primvars.size(); ++p)
    if (!isEvaluated(impl.primvars[p].interpolation)) values[p] = impl.primvars[p].values;

  if (impl.refiner) {
    const std::vector<float> refinedPoints = impl.refinePoints(points);
    const Far::TopologyLevel& base = impl.base();

    // Sub-face parameterisations halve every edge: their rates go up to even so the halves
    // stay whole.
    std::vector<int> faceRates(impl.faceCount);
    for (int face = 0; face < int(impl.faceCount); ++face) {
      const int rate = rates.size() == 1 ? rates[0] : rates[size_t(face)];
      faceRates[size_t(face)] =
          impl.parameterization(face).HasSubFaces() ? rate + (rate & 1) : rate;
    }
    // A shared edge is diced at the finer of its faces' rates, once for both: watertight.
    std::vector<int> edgeRates(size_t(base.GetNumEdges()), 1);
    for (int face = 0; face < int(impl.faceCount); ++face)
      if (impl.hasSurface[size_t(face)])
        for (int edge : base.GetFaceEdges(face))
          edgeRates[size_t(edge)] = std::max(edgeRates[size_t(edge)], faceRates[size_t(face)]);

    std::vector<FaceDicing> dicings(impl.faceCount);
    tbb::parallel_for(size_t(0), impl.faceCount, [&](size_t face) {
      if (impl.hasSurface[face])
        dicings[face] = impl.dice(int(face), edgeRates, faceRates[face], refinedPoints);
    });

    // Stitch the faces together: corners and edge interiors are shared through the base
    // vertex and edge they lie on (edge points stored in the edge's own direction).
    std::vector<int> vertexPoint(size_t(base.GetNumVertices()), -1);
    std::vector<int> edgePoint(size_t(base.GetNumEdges()), -1);
    uint32_t faceVaryingSlots = 0;
    for (int face = 0; face < int(impl.faceCount); ++face) {
      if (!impl.hasSurface[size_t(face)]) continue;
      const FaceDicing& dicing = dicings[size_t(face)];
      const size_t coordCount = dicing.positions.size();
      auto addPoint = [&](size_t local, const Vec3f& position) {
        mesh.points.push_back(position);
        mesh.normals.push_back(dicing.normals[local]);
        for (size_t p = 0; p < impl.primvars.size(); ++p) {
          const Interpolation interpolation = impl.primvars[p].interpolation;
          if (interpolation != Interpolation::Vertex && interpolation != Interpolation::Varying)
            continue;
          const size_t width = size_t(impl.primvars[p].width);
          const float* value = &dicing.primvars[p][local * width];
          values[p].insert(values[p].end(), value, value + width);
        }
        return int(mesh.points.size() - 1);
      };
      // The output point for coordinate `local`, which lies on a shared vertex or edge point
      // whose first output point is `*shared` (-1: none yet).
      auto sharedPoint = [&](size_t local, int shared, bool split) {
        if (shared < 0) return addPoint(local, dicing.positions[local]);
        return split ? addPoint(local, mesh.points[size_t(shared)]) : shared;
      };

      std::vector<int> outputIndex(coordCount);
      const Far::ConstIndexArray faceVertices = base.GetFaceVertices(face);
      const Far::ConstIndexArray faceEdges = base.GetFaceEdges(face);
      size_t local = 0;
      for (int k = 0; k < faceVertices.size(); ++k) {
        const size_t vertex = size_t(faceVertices[k]);
        const int point = sharedPoint(local, vertexPoint[vertex], impl.splitVertex[vertex]);
        if (vertexPoint[vertex] < 0) vertexPoint[vertex] = point;
        outputIndex[local++] = point;

        const size_t edge = size_t(faceEdges[k]);
        const int inner = edgeRates[edge] - 1;
        const bool forward = base.GetEdgeVertices(int(edge))[0] == int(vertex);
        const bool firstVisit = edgePoint[edge] < 0;
        if (firstVisit) edgePoint[edge] = int(mesh.points.size());
        for (int along = 0; along < inner; ++along) {
          const int j = forward ? along : inner - 1 - along;
          const size_t coord = local + size_t(j);
          outputIndex[coord] =
              firstVisit ? addPoint(coord, dicing.positions[coord])
                         : sharedPoint(coord, edgePoint[edge] + along, impl.splitEdge[edge]);
        }
        local += size_t(inner);
      }
      for (; local < coordCount; ++local)
        outputIndex[local] = addPoint(local, dicing.positions[local]);

      for (size_t facet = 0; facet + 2 < dicing.facets.size(); facet += 3) {
        int corners[3] = {dicing.facets[facet], dicing.facets[facet + 1], dicing.facets[facet + 2]};
        if (impl.leftHanded) std::swap(corners[1], corners[2]);
        for (int corner : corners) {
          mesh.triangles.push_back(uint32_t(outputIndex[size_t(corner)]));
          mesh.cornerFaceVertex.push_back(faceVaryingSlots + uint32_t(corner));
        }
        mesh.sourceFace.push_back(uint32_t(face));
      }
      for (size_t p = 0; p < impl.primvars.size(); ++p)
        if (impl.primvars[p].interpolation == Interpolation::FaceVarying)
          values[p].insert(values[p].end(), dicing.primvars[p].begin(), dicing.primvars[p].end());
      faceVaryingSlots += uint32_t(coordCount);
    }
  }

  if (impl.displayColorPrimvar >= 0) {
    const std::vector<float>& color = values[size_t(impl.displayColorPrimvar)];
    mesh.displayColorInterpolation = impl.displayColorInterpolation;
    for (size_t i = 0; i + 2 < color.size(); i += 3)
      mesh.displayColor.push_back({color[i], color[i + 1], color[i + 2]});
    values.pop_back();
  }
  for (size_t p = 0; p < values.size(); ++p) {
    const Interpolation authored = impl.primvars[p].interpolation;
    // Evaluated vertex and varying data has one value per output point.
    mesh.primvars.push_back(
        {impl.primvars[p].name, std::move(values[p]), impl.primvars[p].width,
         authored == Interpolation::Varying ? Interpolation::Vertex : authored});
  }
  return mesh;
}

std::vector<LimitSample> LimitSurfaceTessellator::evaluate(
    const std::vector<Vec3f>& points, int face, const std::vector<Vec2f>& faceCoords) const {
  const Impl& impl = *impl_;
  if (face < 0 || size_t(face) >= impl.faceCount || !impl.hasSurface[size_t(face)])
    throw std::invalid_argument("face " + std::to_string(face) + " has no limit surface");
  const std::vector<float> refinedPoints = impl.refinePoints(points);
  const Bfr::Parameterization param = impl.parameterization(face);
  const bool triangular = param.GetType() == Bfr::Parameterization::TRI;
  std::vector<LimitSample> samples;
  for (const Vec2f& coord : faceCoords) {
    const float uv[2] = {coord.x, coord.y};
    const Impl::PatchLocation at = impl.locate(face, param, uv);
    if (!at.handle)
      throw std::invalid_argument("(" + std::to_string(coord.x) + ", " + std::to_string(coord.y) +
                                  ") lies outside face " + std::to_string(face));
    samples.push_back(impl.evaluatePoint(refinedPoints, at, triangular));
  }
  return samples;
}

int tessellationRateFor(float curvatureBound, float tolerance) {
  if (!(tolerance > 0.0f))
    throw std::invalid_argument("tessellation tolerance " + std::to_string(tolerance) +
                                " is not positive");
  const float rate = std::ceil(std::sqrt(std::max(curvatureBound, 0.0f) / (4.0f * tolerance)));
  if (!(rate < float(kMaxTessellationRate))) return kMaxTessellationRate;
  return std::max(1, int(rate));
}

TriangleMesh tessellateLimitSurface(const MeshData& cage, SubdivisionScheme scheme,
                                    const SubdivisionTags& tags, const std::vector<int>& rates) {
  return LimitSurfaceTessellator(cage, scheme, tags).tessellate(cage.points, rates);
}

}  // namespace penumbra
