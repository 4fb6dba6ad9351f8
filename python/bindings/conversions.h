// Conversions between Python values and the plugin's, shared by the binding files: numpy
// arrays (copied once into C++ vectors), tokens, parameter values, dictionaries read against
// their known keys, image metadata. Bad values throw std::invalid_argument (ValueError).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/image_io.h"
#include "penumbra/mesh.h"
#include "penumbra/motion.h"
#include "penumbra/plugin/prim.h"

namespace penumbra::bindings {

namespace py = pybind11;

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using IntArray = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::vector<Vec3f> toVec3Vector(const float* xyz, size_t count);
/// An (N, 3) array; throws naming `what` for another shape.
std::vector<Vec3f> toVec3Array(const FloatArray& array, const char* what);
std::vector<int> toIntVector(const IntArray& array, const char* what);
/// (4, 4) → a static transform; (K, 4, 4) → K samples uniformly spaced over the shutter.
MotionTransform toMotionTransform(const DoubleArray& matrices);
std::vector<float> toFloatVector(const FloatArray& array, const char* what);
/// A primvar interpolation token ("constant", "uniform", "varying", "vertex", "faceVarying").
Interpolation toInterpolation(const std::string& name);
/// A light or material input's value: a bool, int, float, string or 3-component colour.
plugin::ParamValue toParamValue(const std::string& name, const py::handle& value);
/// A primvar from a (K,) or (K, width) array.
Primvar toPrimvar(const std::string& id, const std::string& name, const FloatArray& array,
                  Interpolation interpolation);
/// Primvars as {name: (values, interpolation token)}.
std::vector<Primvar> toPrimvars(const std::string& id, const py::dict& primvars);
/// Points of shape (N, 3), or (K, N, 3) for K samples over the shutter: the first sample and
/// the later ones. Throws naming prim `id` for another shape.
std::pair<std::vector<Vec3f>, std::vector<std::vector<Vec3f>>> toPointSamples(
    const std::string& id, const FloatArray& points);
/// Image metadata from a dict: ints (past int32 as text), floats, 4x4 matrices, strings.
Metadata toMetadata(const py::dict& metadata);
py::dict toDict(const Metadata& metadata);
/// A colour correction mode token ("disabled", "sRGB", "openColorIO").
ColorCorrection toColorCorrection(const std::string& mode);

/// A sequence of exactly N floats; throws naming `where` otherwise.
template <size_t N>
std::array<float, N> toFloats(const std::string& where, const py::handle& value) {
  const auto items = value.cast<std::vector<float>>();
  if (items.size() != N)
    throw std::invalid_argument(where + " must have " + std::to_string(N) + " components");
  std::array<float, N> result;
  std::copy(items.begin(), items.end(), result.begin());
  return result;
}

/// Calls `read(key, value)` for each entry of `dict`; unknown keys are errors, so that typos in
/// the scene delegate surface.
template <typename Read>
void readDict(const std::string& where, const py::dict& dict,
              std::initializer_list<const char*> keys, Read read) {
  for (const auto& [key, value] : dict) {
    const std::string name = py::str(key);
    if (std::none_of(keys.begin(), keys.end(), [&](const char* k) { return name == k; }))
      throw std::invalid_argument(where + ": unknown key '" + name + "'");
    try {
      read(name, value);
    } catch (const py::cast_error&) {
      throw std::invalid_argument(where + "." + name + " has the wrong type");
    } catch (const std::invalid_argument& error) {
      const std::string message = error.what();
      // Token parsers do not know where they are; say it.
      if (message.rfind(where, 0) == 0) throw;
      throw std::invalid_argument(where + "." + name + ": " + message);
    }
  }
}

}  // namespace penumbra::bindings
