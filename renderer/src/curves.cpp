#include "penumbra/curves.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace penumbra {
namespace {

/// How many values data of each interpolation has on a prim's curves.
struct ElementCounts {
  size_t curves = 0, vertices = 0, varying = 0;

  size_t of(Interpolation interpolation) const {
    switch (interpolation) {
      case Interpolation::Constant:
        return 1;
      case Interpolation::Uniform:
        return curves;
      case Interpolation::Vertex:
        return vertices;
      case Interpolation::Varying:
      case Interpolation::FaceVarying:  // the schema's varying, on curves
        break;
    }
    return varying;
  }
};

/// Throws unless `count` values of `name` fit its interpolation.
void requireCount(const std::string& name, Interpolation interpolation, size_t count,
                  const ElementCounts& counts) {
  const size_t expected = counts.of(interpolation);
  if (count != expected)
    throw std::invalid_argument(name + " (" + interpolationName(interpolation) + ") has " +
                                std::to_string(count) + " values, expected " +
                                std::to_string(expected));
}

}  // namespace

CurveSegmentRules::CurveSegmentRules(const CurvesData& curves)
    : cubic(curves.type == CurveType::Cubic),
      basis(curves.basis),
      wrap(curves.wrap),
      vstep(cubic && curves.basis == CurveBasis::Bezier ? 3 : 1) {
  if (wrap == CurveWrap::Pinned && (!cubic || basis == CurveBasis::Bezier))
    wrap = CurveWrap::Nonperiodic;
}

bool CurveSegmentRules::fits(uint32_t vertices, std::string* expected) const {
  if (!cubic) {
    if (wrap == CurveWrap::Periodic) {
      *expected = "3 or more vertices for a periodic linear curve";
      return vertices >= 3;
    }
    *expected = "2 or more vertices for a linear curve";
    return vertices >= 2;
  }
  switch (wrap) {
    case CurveWrap::Pinned:
      *expected = "2 or more vertices for a pinned curve";
      return vertices >= 2;
    case CurveWrap::Periodic:
      *expected = vstep == 3 ? "a multiple of 3 vertices (3 or more) for a periodic Bezier curve"
                             : "3 or more vertices for a periodic curve";
      return vertices >= 3 && vertices % vstep == 0;
    case CurveWrap::Nonperiodic:
      break;
  }
  *expected = vstep == 3 ? "4, 7, 10, ... vertices for a nonperiodic Bezier curve"
                         : "4 or more vertices for a nonperiodic cubic curve";
  return vertices >= 4 && (vertices - 4) % vstep == 0;
}

uint32_t CurveSegmentRules::segments(uint32_t vertices) const {
  if (!cubic) return wrap == CurveWrap::Periodic ? vertices : vertices - 1;
  switch (wrap) {
    case CurveWrap::Periodic:
      return vertices / vstep;
    case CurveWrap::Pinned:  // a phantom vertex before the first and after the last
      return vertices - 1;
    case CurveWrap::Nonperiodic:
      break;
  }
  return (vertices - 4) / vstep + 1;
}

uint32_t CurveSegmentRules::varyingValues(uint32_t vertices) const {
  return segments(vertices) + (wrap == CurveWrap::Periodic ? 0 : 1);
}

namespace {

/// The counts of `curves`' elements, after checking its topology and positions (throws
/// std::invalid_argument naming what is wrong).
ElementCounts validatedElementCounts(const CurvesData& curves) {
  const CurveSegmentRules rules(curves);
  ElementCounts counts;
  counts.curves = curves.curveVertexCounts.size();
  size_t vertices = 0;
  for (size_t curve = 0; curve < counts.curves; ++curve) {
    const int count = curves.curveVertexCounts[curve];
    std::string expected;
    if (count < 0 || !rules.fits(uint32_t(count), &expected))
      throw std::invalid_argument("curveVertexCounts[" + std::to_string(curve) +
                                  "] = " + std::to_string(count) + "; expected " + expected);
    vertices += size_t(count);
    counts.varying += rules.varyingValues(uint32_t(count));
  }
  counts.vertices = vertices;
  if (curves.positions.size() != vertices)
    throw std::invalid_argument("curveVertexCounts sum to " + std::to_string(vertices) +
                                " vertices, but positions has " +
                                std::to_string(curves.positions.size()));
  if (vertices > UINT32_MAX / 4)
    throw std::invalid_argument("positions has " + std::to_string(vertices) +
                                " vertices; at most " + std::to_string(UINT32_MAX / 4) +
                                " are supported");
  requireFinite(curves.positions, "positions");
  requireMotionSteps(curves.positionMotion, vertices, "positions at motion step");
  return counts;
}

/// Throws unless `primvar`'s width and count fit `counts`.
void requirePrimvarFits(const Primvar& primvar, const ElementCounts& counts) {
  const std::string name = "primvar " + primvar.name.str();
  if (primvar.width < 1 || primvar.width > 4)
    throw std::invalid_argument(name + " has width " + std::to_string(primvar.width) +
                                "; 1 to 4 are supported");
  if (primvar.values.size() % size_t(primvar.width) != 0)
    throw std::invalid_argument(name + " has " + std::to_string(primvar.values.size()) +
                                " floats, not a multiple of its width " +
                                std::to_string(primvar.width));
  requireCount(name + " of width " + std::to_string(primvar.width), primvar.interpolation,
               primvar.values.size() / size_t(primvar.width), counts);
}

}  // namespace

void validateCurves(const CurvesData& curves) {
  const ElementCounts counts = validatedElementCounts(curves);
  requireCount("widths", curves.widthsInterpolation, curves.widths.size(), counts);
  for (size_t i = 0; i < curves.widths.size(); ++i)
    if (!std::isfinite(curves.widths[i]) || curves.widths[i] < 0)
      throw std::invalid_argument("widths[" + std::to_string(i) + "] = " +
                                  std::to_string(curves.widths[i]) + " is not a finite width >= 0");
  if (!curves.normals.empty()) {
    requireCount("normals", curves.normalsInterpolation, curves.normals.size(), counts);
    requireFinite(curves.normals, "normals");
    for (size_t i = 0; i < curves.normals.size(); ++i)
      if (!(length(curves.normals[i]) > 0))
        throw std::invalid_argument("normals[" + std::to_string(i) + "] has zero length");
  }
  if (!curves.displayColor.empty())
    requireCount("displayColor", curves.displayColorInterpolation, curves.displayColor.size(),
                 counts);
  for (const Primvar& primvar : curves.primvars) requirePrimvarFits(primvar, counts);
}

std::vector<std::string> dropMismatchedCurveData(CurvesData& curves) {
  std::vector<std::string> dropped;
  ElementCounts counts;
  try {
    counts = validatedElementCounts(curves);
  } catch (const std::invalid_argument&) {
    return dropped;  // validateCurves refuses the whole prim, and says why
  }
  if (!curves.displayColor.empty()) {
    try {
      requireCount("displayColor", curves.displayColorInterpolation, curves.displayColor.size(),
                   counts);
    } catch (const std::invalid_argument& error) {
      dropped.push_back(std::string(error.what()) + "; the fallback colour is used");
      curves.displayColor.clear();
    }
  }
  for (auto primvar = curves.primvars.begin(); primvar != curves.primvars.end();) {
    try {
      requirePrimvarFits(*primvar, counts);
      ++primvar;
    } catch (const std::invalid_argument& error) {
      dropped.push_back(std::string(error.what()) + "; materials reading it use their fallback");
      primvar = curves.primvars.erase(primvar);
    }
  }
  return dropped;
}

}  // namespace penumbra
