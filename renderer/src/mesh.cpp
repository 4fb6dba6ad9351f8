#include "penumbra/mesh.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "penumbra/motion.h"

namespace penumbra {

void requireFinite(const std::vector<Vec3f>& points, const std::string& name) {
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw std::invalid_argument(name + "[" + std::to_string(i) + "] is not finite");
  }
}

void requireMotionSteps(const std::vector<std::vector<Vec3f>>& steps, size_t count,
                        const std::string& stepName) {
  for (size_t step = 0; step < steps.size(); ++step) {
    const std::string name = stepName + " " + std::to_string(step + 1);
    if (steps[step].size() != count)
      throw std::invalid_argument(name + " has " + std::to_string(steps[step].size()) +
                                  " points, expected " + std::to_string(count));
    requireFinite(steps[step], name);
  }
}

size_t primvarElementCount(Interpolation interpolation, const MeshData& mesh) {
  switch (interpolation) {
    case Interpolation::Constant:
      return 1;
    case Interpolation::Uniform:
      return mesh.faceVertexCounts.size();
    case Interpolation::Varying:
    case Interpolation::Vertex:
      return mesh.points.size();
    case Interpolation::FaceVarying:
      return mesh.faceVertexIndices.size();
  }
  return 0;
}

const char* interpolationName(Interpolation interpolation) {
  switch (interpolation) {
    case Interpolation::Constant:
      return "constant";
    case Interpolation::Uniform:
      return "uniform";
    case Interpolation::Varying:
      return "varying";
    case Interpolation::Vertex:
      return "vertex";
    case Interpolation::FaceVarying:
      return "faceVarying";
  }
  return "?";
}

void validatePrimvar(const Primvar& primvar, const MeshData& mesh) {
  if (primvar.width < 1 || primvar.width > 4)
    throw std::invalid_argument("primvar " + primvar.name.str() + " has width " +
                                std::to_string(primvar.width) + "; 1 to 4 are supported");
  const size_t expected = primvarElementCount(primvar.interpolation, mesh);
  if (primvar.values.size() != expected * size_t(primvar.width))
    throw std::invalid_argument("primvar " + primvar.name.str() + " (" +
                                interpolationName(primvar.interpolation) + ", width " +
                                std::to_string(primvar.width) + ") has " +
                                std::to_string(primvar.values.size()) + " floats, expected " +
                                std::to_string(expected * size_t(primvar.width)));
}

namespace {

/// Whether every edge of the faces with keep[face] (all when `keep` is empty) is shared by an
/// even number of them, so that the surface bounds a volume; false when no face is kept. Edges
/// from a vertex to itself do not count.
bool everyEdgeIsSharedEvenly(const std::vector<int>& faceVertexCounts,
                             const std::vector<int>& faceVertexIndices,
                             const std::vector<bool>& keep) {
  std::vector<uint64_t> edges;  // each use of an edge: its two vertices, smaller first
  edges.reserve(faceVertexIndices.size());
  size_t start = 0;
  for (size_t face = 0; face < faceVertexCounts.size(); ++face) {
    const int count = faceVertexCounts[face];
    if (keep.empty() || keep[face])
      for (int k = 0; k < count; ++k) {
        const auto a = uint32_t(faceVertexIndices[start + size_t(k)]);
        const auto b = uint32_t(faceVertexIndices[start + size_t((k + 1) % count)]);
        if (a != b) edges.push_back((uint64_t(std::min(a, b)) << 32) | std::max(a, b));
      }
    start += size_t(std::max(count, 0));
  }
  if (edges.empty()) return false;
  std::sort(edges.begin(), edges.end());
  for (size_t run = 0; run < edges.size();) {
    size_t next = run + 1;
    while (next < edges.size() && edges[next] == edges[run]) ++next;
    if ((next - run) % 2 != 0) return false;
    run = next;
  }
  return true;
}

}  // namespace

std::vector<int> weldPoints(const std::vector<Vec3f>& points, float tolerance) {
  std::vector<int> representative(points.size());
  if (points.empty()) return representative;
  Vec3f lower = points[0];
  for (const Vec3f& p : points) lower = componentMin(lower, p);
  // Cells much larger than the tolerance: most points search one cell. 21 bits per axis hold
  // any mesh whose extent is below 2^21 cells, which kWeldTolerance guarantees.
  const float cell = std::max(16 * tolerance, std::numeric_limits<float>::min());
  const auto cellOf = [&](float value, float low) {
    const float index = (value - low) / cell;
    return index >= 0 ? uint64_t(std::min(index, float((1 << 21) - 1))) : 0;  // NaN: cell 0
  };
  std::unordered_map<uint64_t, std::vector<int>> cells;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    const uint64_t from[3] = {cellOf(p.x - tolerance, lower.x), cellOf(p.y - tolerance, lower.y),
                              cellOf(p.z - tolerance, lower.z)};
    const uint64_t to[3] = {cellOf(p.x + tolerance, lower.x), cellOf(p.y + tolerance, lower.y),
                            cellOf(p.z + tolerance, lower.z)};
    int found = -1;
    for (uint64_t x = from[0]; x <= to[0] && found < 0; ++x)
      for (uint64_t y = from[1]; y <= to[1] && found < 0; ++y)
        for (uint64_t z = from[2]; z <= to[2] && found < 0; ++z) {
          const auto candidates = cells.find((x << 42) | (y << 21) | z);
          if (candidates == cells.end()) continue;
          for (const int candidate : candidates->second)
            if (length(points[size_t(candidate)] - p) <= tolerance) {
              found = candidate;
              break;
            }
        }
    if (found < 0) {
      found = int(i);
      cells[(cellOf(p.x, lower.x) << 42) | (cellOf(p.y, lower.y) << 21) | cellOf(p.z, lower.z)]
          .push_back(found);
    }
    representative[i] = found;
  }
  return representative;
}

bool isClosedSurface(const std::vector<Vec3f>& points, const std::vector<int>& faceVertexCounts,
                     const std::vector<int>& faceVertexIndices, const std::vector<int>& holes) {
  std::vector<bool> surface;  // empty: every face has one
  if (!holes.empty()) {
    surface.assign(faceVertexCounts.size(), true);
    for (const int hole : holes)
      if (hole >= 0 && size_t(hole) < surface.size()) surface[size_t(hole)] = false;
  }
  if (everyEdgeIsSharedEvenly(faceVertexCounts, faceVertexIndices, surface)) return true;
  if (points.empty()) return false;
  Bounds3f bounds;
  for (const Vec3f& p : points) bounds.extend(p);
  const Vec3f size = bounds.upper - bounds.lower;
  const float tolerance = kWeldTolerance * std::max({size.x, size.y, size.z});
  const std::vector<int> representative = weldPoints(points, tolerance);
  std::vector<int> welded(faceVertexIndices.size());
  for (size_t i = 0; i < welded.size(); ++i)
    welded[i] = representative[size_t(faceVertexIndices[i])];
  // Faces thinner than the tolerance (zero area: collapsed or collinear corners) bound nothing.
  std::vector<bool> keep(faceVertexCounts.size());
  size_t start = 0;
  for (size_t face = 0; face < faceVertexCounts.size(); ++face) {
    const int count = std::max(faceVertexCounts[face], 0);
    Vec3f areaVector{0, 0, 0};  // twice the area times the unit normal (a fan about corner 0)
    float longestEdge = 0;
    for (int k = 0; k < count; ++k) {
      const Vec3f& origin = points[size_t(welded[start])];
      const Vec3f& a = points[size_t(welded[start + size_t(k)])];
      const Vec3f& b = points[size_t(welded[start + size_t((k + 1) % count)])];
      areaVector = areaVector + cross(a - origin, b - origin);
      longestEdge = std::max(longestEdge, length(b - a));
    }
    keep[face] =
        (surface.empty() || surface[face]) && length(areaVector) > 2 * tolerance * longestEdge;
    start += size_t(count);
  }
  return everyEdgeIsSharedEvenly(faceVertexCounts, welded, keep);
}

TriangleMesh triangulate(const MeshData& mesh) {
  const size_t pointCount = mesh.points.size();
  requireFinite(mesh.points, "points");
  requireMotionSteps(mesh.pointMotion, pointCount, "points at motion sample");
  size_t indexTotal = 0;
  for (size_t face = 0; face < mesh.faceVertexCounts.size(); ++face) {
    const int count = mesh.faceVertexCounts[face];
    if (count < 0)
      throw std::invalid_argument("faceVertexCounts[" + std::to_string(face) + "] is negative");
    indexTotal += size_t(count);
  }
  if (indexTotal != mesh.faceVertexIndices.size())
    throw std::invalid_argument("faceVertexCounts add up to " + std::to_string(indexTotal) +
                                " but faceVertexIndices has " +
                                std::to_string(mesh.faceVertexIndices.size()) + " entries");
  for (size_t i = 0; i < mesh.faceVertexIndices.size(); ++i) {
    const int index = mesh.faceVertexIndices[i];
    if (index < 0 || size_t(index) >= pointCount)
      throw std::invalid_argument("faceVertexIndices[" + std::to_string(i) +
                                  "] = " + std::to_string(index) + " is out of range for " +
                                  std::to_string(pointCount) + " points");
  }
  const auto checkPrimvar = [&](const char* name, const std::vector<Vec3f>& values,
                                Interpolation interpolation) {
    if (values.empty()) return;
    const size_t expected = primvarElementCount(interpolation, mesh);
    if (values.size() != expected)
      throw std::invalid_argument(std::string(name) + " (" + interpolationName(interpolation) +
                                  ") has " + std::to_string(values.size()) + " values, expected " +
                                  std::to_string(expected));
  };
  checkPrimvar("displayColor", mesh.displayColor, mesh.displayColorInterpolation);
  checkPrimvar("normals", mesh.normals, mesh.normalsInterpolation);
  for (const Primvar& primvar : mesh.primvars) validatePrimvar(primvar, mesh);

  TriangleMesh result;
  result.points = mesh.points;
  result.pointMotion = mesh.pointMotion;
  result.doubleSided = mesh.doubleSided;
  result.closed = isClosedSurface(mesh.points, mesh.faceVertexCounts, mesh.faceVertexIndices);
  result.displayColor = mesh.displayColor;
  result.displayColorInterpolation = mesh.displayColorInterpolation;
  result.normals = mesh.normals;
  result.normalsInterpolation = mesh.normalsInterpolation;
  result.primvars = mesh.primvars;
  size_t faceStart = 0;
  for (size_t face = 0; face < mesh.faceVertexCounts.size(); ++face) {
    const int count = mesh.faceVertexCounts[face];
    // Polygons with fewer than 3 vertices are skipped, as Hydra does.
    for (int k = 1; k + 1 < count; ++k) {
      uint32_t corners[3] = {uint32_t(faceStart), uint32_t(faceStart + k),
                             uint32_t(faceStart + k + 1)};
      if (mesh.leftHanded) std::swap(corners[1], corners[2]);
      for (uint32_t corner : corners) {
        result.triangles.push_back(uint32_t(mesh.faceVertexIndices[corner]));
        result.cornerFaceVertex.push_back(corner);
      }
      result.sourceFace.push_back(uint32_t(face));
    }
    faceStart += size_t(count);
  }
  return result;
}

Vec3f TriangleMesh::cornerAt(uint32_t triangle, int corner, float time) const {
  return pointAtTime(points, pointMotion, triangles[3 * size_t(triangle) + size_t(corner)], time);
}

size_t TriangleMesh::cornerElement(Interpolation interpolation, uint32_t triangle,
                                   int corner) const {
  const size_t at = 3 * size_t(triangle) + size_t(corner);
  switch (interpolation) {
    case Interpolation::Constant:
      return 0;
    case Interpolation::Uniform:
      return sourceFace[triangle];
    case Interpolation::Varying:
    case Interpolation::Vertex:
      return triangles[at];
    case Interpolation::FaceVarying:
      return cornerFaceVertex[at];
  }
  return 0;
}

Vec3f TriangleMesh::interpolate(const std::vector<Vec3f>& values, Interpolation interpolation,
                                uint32_t triangle, float u, float v) const {
  return values[cornerElement(interpolation, triangle, 0)] * (1 - u - v) +
         values[cornerElement(interpolation, triangle, 1)] * u +
         values[cornerElement(interpolation, triangle, 2)] * v;
}

void TriangleMesh::interpolate(const Primvar& primvar, uint32_t triangle, float u, float v,
                               float* out) const {
  const size_t width = size_t(primvar.width);
  const float weights[3] = {1 - u - v, u, v};
  std::fill(out, out + width, 0.0f);
  for (int corner = 0; corner < 3; ++corner) {
    const float* value =
        &primvar.values[cornerElement(primvar.interpolation, triangle, corner) * width];
    for (size_t c = 0; c < width; ++c) out[c] += weights[corner] * value[c];
  }
}

PrimvarName::PrimvarName(std::string name) : name_(std::move(name)) {
  for (const char c : name_) key_ = (key_ ^ uint8_t(c)) * 1099511628211ull;
}

const Primvar* findPrimvar(const std::vector<Primvar>& primvars, const PrimvarName& name) {
  for (const Primvar& primvar : primvars)
    if (primvar.name == name) return &primvar;
  return nullptr;
}

const Primvar* TriangleMesh::findPrimvar(const PrimvarName& name) const {
  return penumbra::findPrimvar(primvars, name);
}

// Measured on polygon grids of 1M and 2M triangles (half a point per triangle, no primvars,
// one motion step): the process's peak grew by 170 bytes per triangle while they were built;
// a Catmull-Clark grid diced for a 16-pixel image, by 449 bytes per cage triangle. Points are
// counted apart, per motion step, so that meshes of many points and deforming meshes are not
// underestimated.
constexpr size_t kBuildBytesPerTriangle = 140;
constexpr size_t kBuildBytesPerPointStep = 64;
// An Embree instance, its transforms and our placement record (a rounded-up estimate).
constexpr size_t kBytesPerInstance = 160;
constexpr size_t kBytesPerInstanceKey = 64;

size_t estimatedBuildBytes(const MeshData& mesh, bool subdivided) {
  size_t triangles = 0;
  for (const int count : mesh.faceVertexCounts)
    if (count >= 3) triangles += subdivided ? 2 * size_t(count) : size_t(count) - 2;
  const size_t steps = 1 + mesh.pointMotion.size();
  const size_t points = subdivided ? triangles / 2 : mesh.points.size();
  return triangles * kBuildBytesPerTriangle + points * steps * kBuildBytesPerPointStep;
}

size_t estimatedInstanceBytes(size_t copies, size_t motionKeys) {
  return copies * (kBytesPerInstance + motionKeys * kBytesPerInstanceKey);
}

}  // namespace penumbra
