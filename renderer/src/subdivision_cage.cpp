#include "subdivision_cage.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_set>

namespace penumbra {

namespace Sdc = OpenSubdiv::Sdc;

std::optional<SubdivisionScheme> parseSubdivisionScheme(const std::string& token) {
  if (token == "catmullClark") return SubdivisionScheme::CatmullClark;
  if (token == "loop") return SubdivisionScheme::Loop;
  if (token == "bilinear") return SubdivisionScheme::Bilinear;
  if (token == "none") return std::nullopt;
  throw std::invalid_argument("subdivisionScheme \"" + token +
                              "\" is not one of catmullClark, loop, bilinear, none");
}

namespace {

std::string elementName(const char* array, size_t index) {
  return std::string(array) + "[" + std::to_string(index) + "]";
}

uint64_t edgeKey(int a, int b) {
  return (uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b));
}

/// The cage's edges (faces whose vertex indices are in range), as edgeKey gives them.
std::unordered_set<uint64_t> cageEdges(const MeshData& cage) {
  std::unordered_set<uint64_t> edges;
  size_t faceStart = 0;
  for (const int count : cage.faceVertexCounts) {
    if (count <= 0 || faceStart + size_t(count) > cage.faceVertexIndices.size()) break;
    for (int k = 0; k < count; ++k)
      edges.insert(edgeKey(cage.faceVertexIndices[faceStart + size_t(k)],
                           cage.faceVertexIndices[faceStart + size_t((k + 1) % count)]));
    faceStart += size_t(count);
  }
  return edges;
}

}  // namespace

SubdivisionTags usableSubdivisionTags(const MeshData& cage, const SubdivisionTags& tags,
                                      std::vector<std::string>* dropped) {
  SubdivisionTags usable = tags;
  const size_t faceCount = cage.faceVertexCounts.size(), pointCount = cage.points.size();
  const auto isPoint = [&](int index) { return index >= 0 && size_t(index) < pointCount; };

  usable.holeIndices.clear();
  for (size_t i = 0; i < tags.holeIndices.size(); ++i) {
    const int face = tags.holeIndices[i];
    if (face >= 0 && size_t(face) < faceCount)
      usable.holeIndices.push_back(face);
    else
      dropped->push_back(elementName("holeIndices", i) + " = " + std::to_string(face) +
                         " is out of range for " + std::to_string(faceCount) + " faces");
  }

  usable.cornerIndices.clear();
  usable.cornerSharpnesses.clear();
  if (tags.cornerSharpnesses.size() != tags.cornerIndices.size()) {
    if (!tags.cornerIndices.empty() || !tags.cornerSharpnesses.empty())
      dropped->push_back("every corner (" + std::to_string(tags.cornerSharpnesses.size()) +
                         " cornerSharpnesses for " + std::to_string(tags.cornerIndices.size()) +
                         " cornerIndices)");
  } else {
    for (size_t i = 0; i < tags.cornerIndices.size(); ++i) {
      if (isPoint(tags.cornerIndices[i]) && std::isfinite(tags.cornerSharpnesses[i])) {
        usable.cornerIndices.push_back(tags.cornerIndices[i]);
        usable.cornerSharpnesses.push_back(tags.cornerSharpnesses[i]);
      } else {
        dropped->push_back(
            isPoint(tags.cornerIndices[i])
                ? elementName("cornerSharpnesses", i) + " is not finite"
                : elementName("cornerIndices", i) + " = " + std::to_string(tags.cornerIndices[i]) +
                      " is out of range for " + std::to_string(pointCount) + " points");
      }
    }
  }

  usable.creaseIndices.clear();
  usable.creaseLengths.clear();
  usable.creaseSharpnesses.clear();
  size_t vertexTotal = 0, edgeTotal = 0;
  bool lengthsValid = true;
  for (const int length : tags.creaseLengths) {
    lengthsValid = lengthsValid && length >= 2;
    vertexTotal += size_t(std::max(length, 0));
    edgeTotal += size_t(std::max(length - 1, 0));
  }
  const bool perCrease = tags.creaseSharpnesses.size() == tags.creaseLengths.size();
  const bool perEdge = tags.creaseSharpnesses.size() == edgeTotal;
  if (!lengthsValid || vertexTotal != tags.creaseIndices.size() || !(perCrease || perEdge)) {
    if (!tags.creaseIndices.empty() || !tags.creaseLengths.empty())
      dropped->push_back(
          "every crease (creaseLengths, creaseIndices and creaseSharpnesses do "
          "not describe the same creases)");
    return usable;
  }
  // With one sharpness per edge, a chain keeps its own edges' values.
  const std::unordered_set<uint64_t> edges = cageEdges(cage);
  size_t chainStart = 0, edgeStart = 0;
  for (size_t chain = 0; chain < tags.creaseLengths.size(); ++chain) {
    const size_t length = size_t(tags.creaseLengths[chain]);
    std::string problem;  // empty: the chain fits
    if (!perEdge && !std::isfinite(tags.creaseSharpnesses[chain]))
      problem = elementName("creaseSharpnesses", chain) + " is not finite";
    for (size_t i = chainStart; problem.empty() && i < chainStart + length; ++i) {
      const int a = tags.creaseIndices[i];
      if (!isPoint(a)) {
        problem = elementName("creaseIndices", i) + " = " + std::to_string(a) +
                  " is out of range for " + std::to_string(pointCount) + " points";
      } else if (i + 1 < chainStart + length) {
        const int b = tags.creaseIndices[i + 1];
        const size_t edge = edgeStart + (i - chainStart);
        if (isPoint(b) && !edges.count(edgeKey(a, b)))
          problem = "(" + std::to_string(a) + ", " + std::to_string(b) + ") is not an edge";
        else if (perEdge && !std::isfinite(tags.creaseSharpnesses[edge]))
          problem = elementName("creaseSharpnesses", edge) + " is not finite";
      }
    }
    if (problem.empty()) {
      usable.creaseLengths.push_back(int(length));
      usable.creaseIndices.insert(usable.creaseIndices.end(),
                                  tags.creaseIndices.begin() + long(chainStart),
                                  tags.creaseIndices.begin() + long(chainStart + length));
      if (perEdge)
        usable.creaseSharpnesses.insert(
            usable.creaseSharpnesses.end(), tags.creaseSharpnesses.begin() + long(edgeStart),
            tags.creaseSharpnesses.begin() + long(edgeStart + length - 1));
      else
        usable.creaseSharpnesses.push_back(tags.creaseSharpnesses[chain]);
    } else {
      dropped->push_back("crease " + std::to_string(chain) + ": " + problem);
    }
    chainStart += length;
    edgeStart += length - 1;
  }
  return usable;
}

namespace detail {

namespace {

Sdc::Options::VtxBoundaryInterpolation parseInterpolateBoundary(const std::string& token) {
  if (token == "none") return Sdc::Options::VTX_BOUNDARY_NONE;
  if (token == "edgeOnly") return Sdc::Options::VTX_BOUNDARY_EDGE_ONLY;
  if (token == "edgeAndCorner") return Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER;
  throw std::invalid_argument("interpolateBoundary \"" + token +
                              "\" is not one of none, edgeOnly, edgeAndCorner");
}

Sdc::Options::FVarLinearInterpolation parseFaceVaryingLinearInterpolation(
    const std::string& token) {
  if (token == "none") return Sdc::Options::FVAR_LINEAR_NONE;
  if (token == "cornersOnly") return Sdc::Options::FVAR_LINEAR_CORNERS_ONLY;
  if (token == "cornersPlus1") return Sdc::Options::FVAR_LINEAR_CORNERS_PLUS1;
  if (token == "cornersPlus2") return Sdc::Options::FVAR_LINEAR_CORNERS_PLUS2;
  if (token == "boundaries") return Sdc::Options::FVAR_LINEAR_BOUNDARIES;
  if (token == "all") return Sdc::Options::FVAR_LINEAR_ALL;
  throw std::invalid_argument(
      "faceVaryingLinearInterpolation \"" + token +
      "\" is not one of none, cornersOnly, cornersPlus1, cornersPlus2, boundaries, all");
}

Sdc::Options::TriangleSubdivision parseTriangleSubdivisionRule(const std::string& token) {
  if (token == "catmullClark") return Sdc::Options::TRI_SUB_CATMARK;
  if (token == "smooth") return Sdc::Options::TRI_SUB_SMOOTH;
  throw std::invalid_argument("triangleSubdivisionRule \"" + token +
                              "\" is not one of catmullClark, smooth");
}

}  // namespace

Sdc::SchemeType toOsdScheme(SubdivisionScheme scheme) {
  switch (scheme) {
    case SubdivisionScheme::CatmullClark:
      return Sdc::SCHEME_CATMARK;
    case SubdivisionScheme::Loop:
      return Sdc::SCHEME_LOOP;
    case SubdivisionScheme::Bilinear:
      return Sdc::SCHEME_BILINEAR;
  }
  return Sdc::SCHEME_CATMARK;
}

Sdc::Options subdivisionOptions(const SubdivisionTags& tags) {
  Sdc::Options options;
  options.SetVtxBoundaryInterpolation(parseInterpolateBoundary(tags.interpolateBoundary));
  options.SetFVarLinearInterpolation(
      parseFaceVaryingLinearInterpolation(tags.faceVaryingLinearInterpolation));
  options.SetTriangleSubdivision(parseTriangleSubdivisionRule(tags.triangleSubdivisionRule));
  options.SetCreasingMethod(Sdc::Options::CREASE_UNIFORM);
  return options;
}

void checkFinitePoints(const std::vector<Vec3f>& points) {
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw std::invalid_argument(elementName("points", i) + " is not finite");
  }
}

namespace {

void checkVertexIndex(const char* array, size_t position, int index, size_t pointCount) {
  if (index < 0 || size_t(index) >= pointCount)
    throw std::invalid_argument(elementName(array, position) + " = " + std::to_string(index) +
                                " is out of range for " + std::to_string(pointCount) + " points");
}

void checkSharpness(const char* array, size_t position, float sharpness) {
  if (!std::isfinite(sharpness))
    throw std::invalid_argument(elementName(array, position) + " is not finite");
}

}  // namespace

void validateCage(const MeshData& cage, SubdivisionScheme scheme, const SubdivisionTags& tags) {
  const size_t pointCount = cage.points.size();
  checkFinitePoints(cage.points);
  size_t indexTotal = 0;
  for (size_t face = 0; face < cage.faceVertexCounts.size(); ++face) {
    const int count = cage.faceVertexCounts[face];
    if (count < 3)
      throw std::invalid_argument(elementName("faceVertexCounts", face) + " = " +
                                  std::to_string(count) +
                                  ": a subdivision surface needs at least 3 vertices per face");
    if (scheme == SubdivisionScheme::Loop && count != 3)
      throw std::invalid_argument(elementName("faceVertexCounts", face) + " = " +
                                  std::to_string(count) + ": the loop scheme needs triangles only");
    indexTotal += size_t(count);
  }
  if (indexTotal != cage.faceVertexIndices.size())
    throw std::invalid_argument("faceVertexCounts add up to " + std::to_string(indexTotal) +
                                " but faceVertexIndices has " +
                                std::to_string(cage.faceVertexIndices.size()) + " entries");
  for (size_t i = 0; i < cage.faceVertexIndices.size(); ++i)
    checkVertexIndex("faceVertexIndices", i, cage.faceVertexIndices[i], pointCount);

  for (size_t i = 0; i < tags.holeIndices.size(); ++i) {
    const int face = tags.holeIndices[i];
    if (face < 0 || size_t(face) >= cage.faceVertexCounts.size())
      throw std::invalid_argument(elementName("holeIndices", i) + " = " + std::to_string(face) +
                                  " is out of range for " +
                                  std::to_string(cage.faceVertexCounts.size()) + " faces");
  }
  if (tags.cornerSharpnesses.size() != tags.cornerIndices.size())
    throw std::invalid_argument(
        "cornerSharpnesses has " + std::to_string(tags.cornerSharpnesses.size()) +
        " values but cornerIndices has " + std::to_string(tags.cornerIndices.size()));
  for (size_t i = 0; i < tags.cornerIndices.size(); ++i) {
    checkVertexIndex("cornerIndices", i, tags.cornerIndices[i], pointCount);
    checkSharpness("cornerSharpnesses", i, tags.cornerSharpnesses[i]);
  }

  size_t creaseVertexTotal = 0, creaseEdgeTotal = 0;
  for (size_t i = 0; i < tags.creaseLengths.size(); ++i) {
    const int length = tags.creaseLengths[i];
    if (length < 2)
      throw std::invalid_argument(elementName("creaseLengths", i) + " = " + std::to_string(length) +
                                  ": a crease needs at least 2 vertices");
    creaseVertexTotal += size_t(length);
    creaseEdgeTotal += size_t(length - 1);
  }
  if (creaseVertexTotal != tags.creaseIndices.size())
    throw std::invalid_argument("creaseLengths add up to " + std::to_string(creaseVertexTotal) +
                                " but creaseIndices has " +
                                std::to_string(tags.creaseIndices.size()) + " entries");
  if (tags.creaseSharpnesses.size() != tags.creaseLengths.size() &&
      tags.creaseSharpnesses.size() != creaseEdgeTotal)
    throw std::invalid_argument(
        "creaseSharpnesses has " + std::to_string(tags.creaseSharpnesses.size()) +
        " values, expected one per crease (" + std::to_string(tags.creaseLengths.size()) +
        ") or one per crease edge (" + std::to_string(creaseEdgeTotal) + ")");
  for (size_t i = 0; i < tags.creaseSharpnesses.size(); ++i)
    checkSharpness("creaseSharpnesses", i, tags.creaseSharpnesses[i]);
  if (!tags.creaseIndices.empty()) {
    const std::unordered_set<uint64_t> edges = cageEdges(cage);
    size_t chainStart = 0;
    for (int length : tags.creaseLengths) {
      for (size_t i = chainStart; i < chainStart + size_t(length); ++i)
        checkVertexIndex("creaseIndices", i, tags.creaseIndices[i], pointCount);
      for (size_t i = chainStart; i + 1 < chainStart + size_t(length); ++i) {
        const int a = tags.creaseIndices[i], b = tags.creaseIndices[i + 1];
        if (!edges.count(edgeKey(a, b)))
          throw std::invalid_argument("creaseIndices[" + std::to_string(i) + ".." +
                                      std::to_string(i + 1) + "] = (" + std::to_string(a) + ", " +
                                      std::to_string(b) + ") is not an edge of the mesh");
      }
      chainStart += size_t(length);
    }
  }
}

}  // namespace detail

}  // namespace penumbra
