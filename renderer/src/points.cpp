#include "penumbra/points.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace penumbra {
namespace {

/// How many values data of this interpolation has on `count` points, or throws for one points
/// cannot have.
size_t elementCount(const std::string& name, Interpolation interpolation, size_t count) {
  switch (interpolation) {
    case Interpolation::Constant:
      return 1;
    case Interpolation::Vertex:
    case Interpolation::Varying:
      return count;
    default:
      throw std::invalid_argument(name + " is " + interpolationName(interpolation) +
                                  "; points take constant, vertex or varying");
  }
}

}  // namespace

void validatePoints(const PointsData& points) {
  const size_t count = points.positions.size();
  requireFinite(points.positions, "positions");
  requireMotionSteps(points.positionMotion, count, "positions at motion step");
  if (points.widths.size() != count)
    throw std::invalid_argument("widths has " + std::to_string(points.widths.size()) +
                                " values, expected " + std::to_string(count) + " (one per point)");
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(points.widths[i]) || points.widths[i] < 0)
      throw std::invalid_argument("widths[" + std::to_string(i) + "] = " +
                                  std::to_string(points.widths[i]) + " is not a finite width >= 0");
  if (!points.normals.empty()) {
    if (points.normals.size() != count)
      throw std::invalid_argument("normals has " + std::to_string(points.normals.size()) +
                                  " values, expected " + std::to_string(count) +
                                  " (one per point)");
    requireFinite(points.normals, "normals");
    for (size_t i = 0; i < count; ++i)
      if (!(length(points.normals[i]) > 0))
        throw std::invalid_argument("normals[" + std::to_string(i) + "] has zero length");
  }
  if (!points.displayColor.empty()) {
    const size_t expected = elementCount("displayColor", points.displayColorInterpolation, count);
    if (points.displayColor.size() != expected)
      throw std::invalid_argument("displayColor (" +
                                  std::string(interpolationName(points.displayColorInterpolation)) +
                                  ") has " + std::to_string(points.displayColor.size()) +
                                  " values, expected " + std::to_string(expected));
  }
  for (const Primvar& primvar : points.primvars) {
    const std::string name = "primvar " + primvar.name.str();
    if (primvar.width < 1 || primvar.width > 4)
      throw std::invalid_argument(name + " has width " + std::to_string(primvar.width) +
                                  "; 1 to 4 are supported");
    const size_t expected =
        elementCount(name, primvar.interpolation, count) * size_t(primvar.width);
    if (primvar.values.size() != expected)
      throw std::invalid_argument(name + " (" + interpolationName(primvar.interpolation) +
                                  ", width " + std::to_string(primvar.width) + ") has " +
                                  std::to_string(primvar.values.size()) + " floats, expected " +
                                  std::to_string(expected));
  }
}

}  // namespace penumbra
