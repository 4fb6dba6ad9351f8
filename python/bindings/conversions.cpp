#include "conversions.h"

#include <limits>
#include <stdexcept>

namespace penumbra::bindings {

std::vector<Vec3f> toVec3Vector(const float* xyz, size_t count) {
  std::vector<Vec3f> result;
  result.reserve(count);
  for (size_t i = 0; i < count; ++i, xyz += 3) result.emplace_back(xyz[0], xyz[1], xyz[2]);
  return result;
}

std::vector<Vec3f> toVec3Array(const FloatArray& array, const char* what) {
  if (array.ndim() != 2 || array.shape(1) != 3)
    throw std::invalid_argument(std::string(what) + " must have shape (N, 3)");
  return toVec3Vector(array.data(), size_t(array.shape(0)));
}

std::vector<int> toIntVector(const IntArray& array, const char* what) {
  if (array.ndim() != 1) throw std::invalid_argument(std::string(what) + " must be 1-dimensional");
  return std::vector<int>(array.data(), array.data() + array.shape(0));
}

MotionTransform toMotionTransform(const DoubleArray& matrices) {
  const bool single = matrices.ndim() == 2;
  if (!(single || matrices.ndim() == 3) || matrices.shape(matrices.ndim() - 2) != 4 ||
      matrices.shape(matrices.ndim() - 1) != 4 || (!single && matrices.shape(0) < 1))
    throw std::invalid_argument("a transform must have shape (4, 4) or (K, 4, 4) with K >= 1");
  std::vector<Transform> steps;
  const py::ssize_t count = single ? 1 : matrices.shape(0);
  for (py::ssize_t k = 0; k < count; ++k)
    steps.push_back(Transform::fromRowMajor(matrices.data() + 16 * k));
  return MotionTransform(std::move(steps));
}

std::vector<float> toFloatVector(const FloatArray& array, const char* what) {
  if (array.ndim() != 1) throw std::invalid_argument(std::string(what) + " must be 1-dimensional");
  return std::vector<float>(array.data(), array.data() + array.shape(0));
}

Interpolation toInterpolation(const std::string& name) {
  if (name == "constant") return Interpolation::Constant;
  if (name == "uniform") return Interpolation::Uniform;
  if (name == "varying") return Interpolation::Varying;
  if (name == "vertex") return Interpolation::Vertex;
  if (name == "faceVarying") return Interpolation::FaceVarying;
  throw std::invalid_argument("unknown primvar interpolation '" + name + "'");
}

plugin::ParamValue toParamValue(const std::string& name, const py::handle& value) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::int_>(value)) return value.cast<int>();
  if (py::isinstance<py::float_>(value)) return value.cast<float>();
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::hasattr(value, "__len__") && py::len(value) == 3) {
    const py::sequence items = py::reinterpret_borrow<py::sequence>(value);
    return Vec3f(items[0].cast<float>(), items[1].cast<float>(), items[2].cast<float>());
  }
  try {
    return py::float_(py::reinterpret_borrow<py::object>(value)).cast<float>();  // numpy scalars
  } catch (const py::error_already_set&) {
    throw std::invalid_argument(name +
                                ": expected a number, a bool, a string or a 3-component colour");
  }
}

std::vector<Primvar> toPrimvars(const std::string& id, const py::dict& primvars) {
  std::vector<Primvar> values;
  for (const auto& [key, value] : primvars) {
    const auto [array, interpolation] = value.cast<std::pair<FloatArray, std::string>>();
    values.push_back(toPrimvar(id, py::str(key), array, toInterpolation(interpolation)));
  }
  return values;
}

std::pair<std::vector<Vec3f>, std::vector<std::vector<Vec3f>>> toPointSamples(
    const std::string& id, const FloatArray& points) {
  if (points.ndim() == 2) return {toVec3Array(points, "points"), {}};
  if (points.ndim() != 3 || points.shape(2) != 3 || points.shape(0) < 1)
    throw std::invalid_argument(id + ": points must have shape (N, 3) or (K, N, 3)");
  const size_t count = size_t(points.shape(1));
  std::vector<std::vector<Vec3f>> motion;
  for (py::ssize_t k = 1; k < points.shape(0); ++k)
    motion.push_back(toVec3Vector(points.data() + 3 * count * size_t(k), count));
  return {toVec3Vector(points.data(), count), std::move(motion)};
}

Primvar toPrimvar(const std::string& id, const std::string& name, const FloatArray& array,
                  Interpolation interpolation) {
  if (array.ndim() != 1 && array.ndim() != 2)
    throw std::invalid_argument(id + ": primvar " + name + " must have shape (N,) or (N, width)");
  Primvar primvar;
  primvar.name = PrimvarName(name);
  primvar.width = array.ndim() == 1 ? 1 : int(array.shape(1));
  primvar.values.assign(array.data(), array.data() + array.size());
  primvar.interpolation = interpolation;
  return primvar;
}

Metadata toMetadata(const py::dict& metadata) {
  Metadata result;
  for (const auto& [key, value] : metadata) {
    const std::string name = py::str(key);
    if (py::isinstance<py::bool_>(value) || py::isinstance<py::int_>(value)) {
      int overflow = 0;
      const long long number = PyLong_AsLongLongAndOverflow(value.ptr(), &overflow);
      if (!overflow && number >= std::numeric_limits<int>::min() &&
          number <= std::numeric_limits<int>::max())
        result[name] = int(number);
      else  // past int32 (ray counts): exact as text
        result[name] = std::string(py::str(value));
    } else if (py::isinstance<py::float_>(value)) {
      result[name] = value.cast<float>();
    } else if (py::isinstance<py::array>(value) || py::isinstance<py::list>(value) ||
               py::isinstance<py::tuple>(value)) {
      // A 4x4 matrix (OIIO's worldtocamera, worldtoscreen), row-major.
      const FloatArray values(py::reinterpret_borrow<py::object>(value));
      if (values.size() != 16)
        throw std::invalid_argument("metadata " + name + ": a 4x4 matrix needs 16 numbers");
      Matrix44 matrix;
      std::copy_n(values.data(), 16, matrix.begin());
      result[name] = matrix;
    } else {
      result[name] = std::string(py::str(value));
    }
  }
  return result;
}

py::dict toDict(const Metadata& metadata) {
  py::dict result;
  for (const auto& [key, value] : metadata)
    std::visit([&, name = key](const auto& v) { result[py::str(name)] = v; }, value);
  return result;
}

ColorCorrection toColorCorrection(const std::string& mode) {
  if (mode == "disabled") return ColorCorrection::Disabled;
  if (mode == "sRGB") return ColorCorrection::SRGB;
  if (mode == "openColorIO") return ColorCorrection::OpenColorIO;
  throw std::invalid_argument(
      "colour correction mode must be disabled, sRGB or openColorIO, got '" + mode + "'");
}

}  // namespace penumbra::bindings
