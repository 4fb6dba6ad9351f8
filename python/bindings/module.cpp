// penumbra._core: Python bindings of the render delegate (plugin/) and the image I/O.
// See docs/core-api.md. Heavy data crosses as numpy buffers; errors map to ValueError
// (bad values), KeyError (unknown prim ids) and RuntimeError (files, Embree).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <exception>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>

#include "penumbra/image_io.h"
#include "penumbra/plugin/render_delegate.h"
#include "penumbra/plugin/render_pass.h"
#include "penumbra/texture.h"

namespace py = pybind11;
using penumbra::CameraParams;
using penumbra::ColorCorrection;
using penumbra::DisplaySettings;
using penumbra::ExpressionOp;
using penumbra::ImageData;
using penumbra::Interpolation;
using penumbra::Matrix44;
using penumbra::Metadata;
using penumbra::MotionTransform;
using penumbra::PixelRect;
using penumbra::Projection;
using penumbra::Transform;
using penumbra::Vec3f;
using namespace penumbra::plugin;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using IntArray = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// How often a render looks for Python signals (Ctrl-C) while it runs.
constexpr std::chrono::milliseconds kSignalPollInterval{50};

// Runs `pass.execute(samples)` on a worker thread while the calling thread, without the GIL,
// runs Python's signal handlers every kSignalPollInterval (they run only in the main thread,
// between bytecodes, so a render holding that thread would never see Ctrl-C). A handler that
// raises (SIGINT: KeyboardInterrupt) cancels the render, which drops its samples, and the
// exception propagates.
void executeInterruptibly(RenderPass& pass, int samples) {
  std::atomic<bool> cancel{false};
  std::exception_ptr failure;
  std::promise<void> finished;
  std::future<void> done = finished.get_future();
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    std::thread worker([&] {
      try {
        pass.execute(samples, &cancel);
      } catch (...) {
        failure = std::current_exception();
      }
      finished.set_value();
    });
    while (done.wait_for(kSignalPollInterval) != std::future_status::ready) {
      py::gil_scoped_acquire acquire;
      if (PyErr_CheckSignals() != 0) {
        interrupted = true;
        cancel = true;
        break;
      }
    }
    worker.join();
  }
  if (interrupted) throw py::error_already_set();
  if (failure) std::rethrow_exception(failure);
}

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

/// (4, 4) → a static transform; (K, 4, 4) → K samples uniformly spaced over the shutter.
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

ParamValue toParamValue(const std::string& name, const py::handle& value) {
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

/// A primvar from a (K,) or (K, width) array.
penumbra::Primvar toPrimvar(const std::string& id, const std::string& name, const FloatArray& array,
                            Interpolation interpolation) {
  if (array.ndim() != 1 && array.ndim() != 2)
    throw std::invalid_argument(id + ": primvar " + name + " must have shape (N,) or (N, width)");
  penumbra::Primvar primvar;
  primvar.name = penumbra::PrimvarName(name);
  primvar.width = array.ndim() == 1 ? 1 : int(array.shape(1));
  primvar.values.assign(array.data(), array.data() + array.size());
  primvar.interpolation = interpolation;
  return primvar;
}

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

/// A UsdUVTexture's description (docs/core-api.md, set_material).
TextureNode toTextureNode(const std::string& where, const py::dict& dict) {
  TextureNode node;
  readDict(where, dict,
           {"file", "wrapS", "wrapT", "sourceColorSpace", "colorSpace", "scale", "bias", "fallback",
            "st", "transform"},
           [&](const std::string& key, const py::handle& value) {
             const std::string at = where + "." + key;
             if (key == "file") node.file = value.cast<std::string>();
             if (key == "wrapS")
               node.reader.wrapS = penumbra::plugin::parseTextureWrap(value.cast<std::string>());
             if (key == "wrapT")
               node.reader.wrapT = penumbra::plugin::parseTextureWrap(value.cast<std::string>());
             if (key == "sourceColorSpace")
               node.colorSpace.source =
                   penumbra::plugin::parseSourceColorSpace(value.cast<std::string>());
             if (key == "colorSpace") node.colorSpace.name = value.cast<std::string>();
             if (key == "scale") node.reader.scale = toFloats<4>(at, value);
             if (key == "bias") node.reader.bias = toFloats<4>(at, value);
             if (key == "fallback") node.reader.fallback = toFloats<4>(at, value);
             if (key == "st")
               readDict(at, value.cast<py::dict>(), {"primvar", "fallback"},
                        [&](const std::string& stKey, const py::handle& stValue) {
                          if (stKey == "primvar")
                            node.reader.coordinates.primvar =
                                penumbra::PrimvarName(stValue.cast<std::string>());
                          else {
                            const auto st = toFloats<2>(at + ".fallback", stValue);
                            node.reader.coordinates.fallback = {st[0], st[1]};
                          }
                        });
             if (key == "transform")
               readDict(at, value.cast<py::dict>(), {"scale", "rotation", "translation"},
                        [&](const std::string& tKey, const py::handle& tValue) {
                          if (tKey == "rotation") {
                            node.reader.coordinates.rotation = tValue.cast<float>();
                            return;
                          }
                          const auto pair = toFloats<2>(at + "." + tKey, tValue);
                          (tKey == "scale"
                               ? node.reader.coordinates.scale
                               : node.reader.coordinates.translation) = {pair[0], pair[1]};
                        });
           });
  if (node.file.empty()) throw std::invalid_argument(where + ": a texture needs a 'file'");
  return node;
}

/// Up to 4 small non-negative integers (operand indices, channels), zero-padded.
std::array<uint8_t, 4> toIndices(const std::string& where, const py::handle& value, size_t most) {
  const auto items = value.cast<std::vector<int>>();
  if (items.size() > most)
    throw std::invalid_argument(where + " takes at most " + std::to_string(most) + " entries");
  std::array<uint8_t, 4> result{0, 0, 0, 0};
  for (size_t i = 0; i < items.size(); ++i) {
    if (items[i] < 0 || items[i] > 255) throw std::invalid_argument(where + " is out of range");
    result[i] = uint8_t(items[i]);
  }
  return result;
}

/// A pattern program node (docs/core-api.md, set_material): {"op": name, "in": [operands],
/// "channels": [...], "split": n, "value": (4 floats), "texture": {...}, "primvar": name,
/// "fallback": (4 floats)}.
ProgramNode toProgramNode(const std::string& where, const py::dict& dict) {
  static const std::map<std::string, ExpressionOp> ops = {
      {"constant", ExpressionOp::Constant},
      {"texture", ExpressionOp::Texture},
      {"primvar", ExpressionOp::Primvar},
      {"swizzle", ExpressionOp::Swizzle},
      {"concatenate", ExpressionOp::Concatenate},
      {"add", ExpressionOp::Add},
      {"subtract", ExpressionOp::Subtract},
      {"multiply", ExpressionOp::Multiply},
      {"divide", ExpressionOp::Divide},
      {"mix", ExpressionOp::Mix},
      {"clamp", ExpressionOp::Clamp}};
  ProgramNode node;
  bool hasOp = false;
  readDict(where, dict,
           {"op", "in", "channels", "split", "value", "texture", "primvar", "fallback"},
           [&](const std::string& key, const py::handle& value) {
             const std::string at = where + "." + key;
             if (key == "op") {
               const auto op = ops.find(value.cast<std::string>());
               if (op == ops.end())
                 throw std::invalid_argument("unknown program operation '" +
                                             value.cast<std::string>() + "'");
               node.node.op = op->second;
               hasOp = true;
             }
             if (key == "in") {
               const std::array<uint8_t, 4> operands = toIndices(at, value, 3);
               std::copy_n(operands.begin(), 3, node.node.operands.begin());
             }
             if (key == "channels") node.node.channels = toIndices(at, value, 4);
             if (key == "split") node.node.channels[0] = toIndices(at, py::make_tuple(value), 1)[0];
             if (key == "value" || key == "fallback") node.node.value = toFloats<4>(at, value);
             if (key == "texture") node.texture = toTextureNode(at, value.cast<py::dict>());
             if (key == "primvar")
               node.node.primvar = penumbra::PrimvarName(value.cast<std::string>());
           });
  if (!hasOp) throw std::invalid_argument(where + ": a program node needs an 'op'");
  return node;
}

/// A connected input's source: {"texture": {...}, "output": "rgb"},
/// {"primvar": name, "fallback": value} or {"program": [nodes]}.
InputSource toInputSource(const std::string& where, const py::dict& dict) {
  InputSource source;
  readDict(where, dict, {"texture", "output", "primvar", "fallback", "program"},
           [&](const std::string& key, const py::handle& value) {
             if (key == "texture")
               source.texture = toTextureNode(where + ".texture", value.cast<py::dict>());
             if (key == "output") source.output = value.cast<std::string>();
             if (key == "primvar") source.primvar = value.cast<std::string>();
             if (key == "program") {
               const py::list nodes = value.cast<py::list>();
               for (size_t i = 0; i < nodes.size(); ++i)
                 source.program.push_back(toProgramNode(
                     where + ".program[" + std::to_string(i) + "]", nodes[i].cast<py::dict>()));
             }
             if (key == "fallback") {
               if (py::hasattr(value, "__len__"))
                 source.fallback = toFloats<3>(where + ".fallback", value);
               else
                 source.fallback.fill(value.cast<float>());
             }
           });
  if (int(source.texture.has_value()) + int(!source.primvar.empty()) +
          int(!source.program.empty()) !=
      1)
    throw std::invalid_argument(where +
                                ": a connection names one of a texture, a primvar or a program");
  return source;
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
      const py::array_t<float, py::array::c_style | py::array::forcecast> values(
          py::reinterpret_borrow<py::object>(value));
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

}  // namespace

/// Points of shape (N, 3), or (K, N, 3) for K samples over the shutter.
void setMeshPoints(Mesh& mesh, const FloatArray& points) {
  if (points.ndim() == 2) return mesh.setPoints(toVec3Array(points, "points"));
  if (points.ndim() != 3 || points.shape(2) != 3 || points.shape(0) < 1)
    throw std::invalid_argument(mesh.id() + ": points must have shape (N, 3) or (K, N, 3)");
  const size_t count = size_t(points.shape(1));
  std::vector<std::vector<Vec3f>> motion;
  for (py::ssize_t k = 1; k < points.shape(0); ++k)
    motion.push_back(toVec3Vector(points.data() + 3 * count * size_t(k), count));
  mesh.setPoints(toVec3Vector(points.data(), count), std::move(motion));
}

/// Primvars as {name: (values, interpolation)}.
std::vector<penumbra::Primvar> toMeshPrimvars(const std::string& id, const py::dict& primvars) {
  std::vector<penumbra::Primvar> values;
  for (const auto& [key, value] : primvars) {
    const auto [array, interpolation] = value.cast<std::pair<FloatArray, std::string>>();
    values.push_back(toPrimvar(id, py::str(key), array, toInterpolation(interpolation)));
  }
  return values;
}

/// What `set_mesh` sends, for one mesh (docs/core-api.md).
void setMesh(RenderDelegate& delegate, const std::string& id, const IntArray& counts,
             const IntArray& indices, bool leftHanded, const std::string& subdivisionScheme,
             const FloatArray& points, bool doubleSided, const FloatArray& displayColor,
             const std::string& displayColorInterpolation, const FloatArray& normals,
             const std::string& normalsInterpolation, const py::dict& primvars) {
  Mesh& mesh = delegate.mesh(id);
  mesh.setTopology(toIntVector(counts, "face_vertex_counts"),
                   toIntVector(indices, "face_vertex_indices"), leftHanded, subdivisionScheme);
  setMeshPoints(mesh, points);
  mesh.setDoubleSided(doubleSided);
  mesh.setDisplayColor(toVec3Array(displayColor, "display colour"),
                       toInterpolation(displayColorInterpolation));
  mesh.setNormals(toVec3Array(normals, "normals"), toInterpolation(normalsInterpolation));
  mesh.setPrimvars(toMeshPrimvars(id, primvars));
}

/// `set_transform` of one prim: a mesh, a camera or a light.
void setTransform(RenderDelegate& delegate, const std::string& id, const DoubleArray& matrix) {
  delegate.prim(id).setTransform(toMotionTransform(matrix));
}

/// `set_visible` of one prim: a mesh, a light or an instancer.
void setVisible(RenderDelegate& delegate, const std::string& id, bool visible) {
  delegate.prim(id).setVisible(visible);
}

/// Calls `set(ids[i], values[i])` for each i: the batched setters, one call for many prims.
template <typename Value, typename Set>
void forEachPrim(const std::vector<std::string>& ids, const std::vector<Value>& values, Set set) {
  if (ids.size() != values.size())
    throw std::invalid_argument("a batch needs as many values (" + std::to_string(values.size()) +
                                ") as prim ids (" + std::to_string(ids.size()) + ")");
  for (size_t i = 0; i < ids.size(); ++i) set(ids[i], values[i]);
}

PYBIND11_MODULE(_core, m) {
  m.doc() = "Penumbra's render delegate and image I/O (see docs/core-api.md)";
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const std::out_of_range& error) {
      PyErr_SetString(PyExc_KeyError, error.what());
    }
  });

  m.def("version", [] { return std::string(PENUMBRA_VERSION); });

  py::class_<RenderDelegate>(m, "RenderDelegate")
      .def(py::init<const std::string&>(), py::arg("ocio_config") = "")
      .def("insert_rprim", &RenderDelegate::insertRprim, py::arg("type"), py::arg("id"))
      .def(
          "insert_rprims",
          [](RenderDelegate& self, const std::string& type, const std::vector<std::string>& ids) {
            for (const std::string& id : ids) self.insertRprim(type, id);
          },
          py::arg("type"), py::arg("ids"), "insert_rprim for each of `ids`, in one call.")
      .def("insert_sprim", &RenderDelegate::insertSprim, py::arg("type"), py::arg("id"))
      .def("insert_bprim", &RenderDelegate::insertBprim, py::arg("type"), py::arg("id"))
      .def(
          "allocate_render_buffer",
          [](RenderDelegate& self, const std::string& id, int width, int height) {
            self.renderBuffer(id).allocate(width, height);
          },
          py::arg("id"), py::arg("width"), py::arg("height"))
      .def(
          "render_buffer",
          [](RenderDelegate& self, const std::string& id) {
            const RenderBuffer& buffer = self.renderBuffer(id);
            py::array_t<float> result({buffer.height(), buffer.width(), buffer.channels()});
            if (!buffer.data().empty())
              std::memcpy(result.mutable_data(), buffer.data().data(),
                          buffer.data().size() * sizeof(float));
            return py::make_tuple(result, buffer.converged());
          },
          py::arg("id"))
      .def("remove_prim", &RenderDelegate::removePrim, py::arg("id"))
      .def("has_prim", &RenderDelegate::hasPrim, py::arg("id"))
      .def("prim_ids", &RenderDelegate::primIds)
      .def(
          "set_mesh_topology",
          [](RenderDelegate& self, const std::string& id, const IntArray& counts,
             const IntArray& indices, bool leftHanded, const std::string& subdivisionScheme) {
            self.mesh(id).setTopology(toIntVector(counts, "face_vertex_counts"),
                                      toIntVector(indices, "face_vertex_indices"), leftHanded,
                                      subdivisionScheme);
          },
          py::arg("id"), py::arg("face_vertex_counts"), py::arg("face_vertex_indices"),
          py::arg("left_handed") = false, py::arg("subdivision_scheme") = "none")
      .def(
          "set_mesh_subdivision_tags",
          [](RenderDelegate& self, const std::string& id, const std::string& interpolateBoundary,
             const std::string& faceVaryingLinearInterpolation,
             const std::string& triangleSubdivisionRule, const IntArray& holeIndices,
             const IntArray& cornerIndices, const FloatArray& cornerSharpnesses,
             const IntArray& creaseIndices, const IntArray& creaseLengths,
             const FloatArray& creaseSharpnesses) {
            penumbra::SubdivisionTags tags;
            tags.interpolateBoundary = interpolateBoundary;
            tags.faceVaryingLinearInterpolation = faceVaryingLinearInterpolation;
            tags.triangleSubdivisionRule = triangleSubdivisionRule;
            tags.holeIndices = toIntVector(holeIndices, "hole_indices");
            tags.cornerIndices = toIntVector(cornerIndices, "corner_indices");
            tags.cornerSharpnesses = toFloatVector(cornerSharpnesses, "corner_sharpnesses");
            tags.creaseIndices = toIntVector(creaseIndices, "crease_indices");
            tags.creaseLengths = toIntVector(creaseLengths, "crease_lengths");
            tags.creaseSharpnesses = toFloatVector(creaseSharpnesses, "crease_sharpnesses");
            self.mesh(id).setSubdivisionTags(std::move(tags));
          },
          py::arg("id"), py::kw_only(), py::arg("interpolate_boundary") = "edgeAndCorner",
          py::arg("face_varying_linear_interpolation") = "cornersPlus1",
          py::arg("triangle_subdivision_rule") = "catmullClark",
          py::arg("hole_indices") = IntArray(), py::arg("corner_indices") = IntArray(),
          py::arg("corner_sharpnesses") = FloatArray(), py::arg("crease_indices") = IntArray(),
          py::arg("crease_lengths") = IntArray(), py::arg("crease_sharpnesses") = FloatArray())
      .def(
          "set_mesh",
          [](RenderDelegate& self, const std::string& id, const IntArray& counts,
             const IntArray& indices, bool leftHanded, const std::string& subdivisionScheme,
             const FloatArray& points, bool doubleSided, const FloatArray& displayColor,
             const std::string& displayColorInterpolation, const FloatArray& normals,
             const std::string& normalsInterpolation, const py::dict& primvars) {
            // One call per mesh for what the setters below send one by one.
            setMesh(self, id, counts, indices, leftHanded, subdivisionScheme, points, doubleSided,
                    displayColor, displayColorInterpolation, normals, normalsInterpolation,
                    primvars);
          },
          py::arg("id"), py::kw_only(), py::arg("face_vertex_counts"),
          py::arg("face_vertex_indices"), py::arg("left_handed"), py::arg("subdivision_scheme"),
          py::arg("points"), py::arg("double_sided"), py::arg("display_color"),
          py::arg("display_color_interpolation"), py::arg("normals"),
          py::arg("normals_interpolation"), py::arg("primvars"))
      .def(
          "set_meshes",
          [](RenderDelegate& self, const py::list& meshes) {
            for (const py::handle& item : meshes) {
              const auto mesh = py::reinterpret_borrow<py::tuple>(item);
              if (mesh.size() != 12)
                throw std::invalid_argument("set_meshes takes tuples of set_mesh's 12 arguments");
              setMesh(self, mesh[0].cast<std::string>(), mesh[1].cast<IntArray>(),
                      mesh[2].cast<IntArray>(), mesh[3].cast<bool>(), mesh[4].cast<std::string>(),
                      mesh[5].cast<FloatArray>(), mesh[6].cast<bool>(), mesh[7].cast<FloatArray>(),
                      mesh[8].cast<std::string>(), mesh[9].cast<FloatArray>(),
                      mesh[10].cast<std::string>(), mesh[11].cast<py::dict>());
            }
          },
          py::arg("meshes"),
          "set_mesh for many meshes in one call: tuples of its arguments in its order (id, "
          "face_vertex_counts, ..., primvars).")
      .def(
          "set_mesh_points",
          [](RenderDelegate& self, const std::string& id, const FloatArray& points) {
            setMeshPoints(self.mesh(id), points);
          },
          py::arg("id"), py::arg("points"))
      .def(
          "set_mesh_double_sided",
          [](RenderDelegate& self, const std::string& id, bool doubleSided) {
            self.mesh(id).setDoubleSided(doubleSided);
          },
          py::arg("id"), py::arg("double_sided"))
      .def(
          "set_mesh_display_color",
          [](RenderDelegate& self, const std::string& id, const FloatArray& colors,
             const std::string& interpolation) {
            self.mesh(id).setDisplayColor(toVec3Array(colors, "display colour"),
                                          toInterpolation(interpolation));
          },
          py::arg("id"), py::arg("colors"), py::arg("interpolation"))
      .def(
          "set_mesh_light",
          [](RenderDelegate& self, const std::string& id, bool enabled, const py::kwargs& params) {
            std::vector<std::pair<std::string, ParamValue>> values;
            for (const auto& [key, value] : params) {
              const std::string name = py::str(key);
              values.emplace_back(name, toParamValue(id + ": " + name, value));
            }
            self.mesh(id).setLight(enabled, values);
          },
          py::arg("id"), py::arg("enabled"))
      .def(
          "disable_mesh_lights",
          [](RenderDelegate& self, const std::vector<std::string>& ids) {
            for (const std::string& id : ids) self.mesh(id).setLight(false, {});
          },
          py::arg("ids"), "set_mesh_light(id, False) for many meshes.")
      .def(
          "set_mesh_normals",
          [](RenderDelegate& self, const std::string& id, const FloatArray& normals,
             const std::string& interpolation) {
            self.mesh(id).setNormals(toVec3Array(normals, "normals"),
                                     toInterpolation(interpolation));
          },
          py::arg("id"), py::arg("normals"), py::arg("interpolation"))
      .def(
          "set_mesh_primvars",
          [](RenderDelegate& self, const std::string& id, const py::dict& primvars) {
            self.mesh(id).setPrimvars(toMeshPrimvars(id, primvars));
          },
          py::arg("id"), py::arg("primvars"))
      .def(
          "set_instance_primvars",
          [](RenderDelegate& self, const std::string& id, const py::dict& primvars) {
            std::vector<penumbra::Primvar> values;
            for (const auto& [key, value] : primvars)
              values.push_back(
                  toPrimvar(id, py::str(key), value.cast<FloatArray>(), Interpolation::Vertex));
            self.instancer(id).setPrimvars(std::move(values));
          },
          py::arg("id"), py::arg("primvars"))
      .def(
          "set_mesh_material",
          [](RenderDelegate& self, const std::string& id, const std::string& materialId) {
            self.mesh(id).setMaterialId(materialId);
          },
          py::arg("id"), py::arg("material_id"))
      .def(
          "set_mesh_materials",
          [](RenderDelegate& self, const std::vector<std::string>& ids,
             const std::vector<std::string>& materialIds) {
            forEachPrim(ids, materialIds, [&](const std::string& id, const std::string& material) {
              self.mesh(id).setMaterialId(material);
            });
          },
          py::arg("ids"), py::arg("material_ids"), "set_mesh_material for many meshes.")
      .def(
          "set_transform",
          [](RenderDelegate& self, const std::string& id, const DoubleArray& matrix) {
            setTransform(self, id, matrix);
          },
          py::arg("id"), py::arg("matrix"))
      .def(
          "set_transforms",
          [](RenderDelegate& self, const std::vector<std::string>& ids,
             const std::vector<DoubleArray>& matrices) {
            forEachPrim(ids, matrices, [&](const std::string& id, const DoubleArray& matrix) {
              setTransform(self, id, matrix);
            });
          },
          py::arg("ids"), py::arg("matrices"), "set_transform for many prims.")
      .def(
          "set_visible",
          [](RenderDelegate& self, const std::string& id, bool visible) {
            setVisible(self, id, visible);
          },
          py::arg("id"), py::arg("visible"))
      .def(
          "set_visibilities",
          [](RenderDelegate& self, const std::vector<std::string>& ids,
             const std::vector<bool>& visible) {
            forEachPrim(ids, visible,
                        [&](const std::string& id, bool shown) { setVisible(self, id, shown); });
          },
          py::arg("ids"), py::arg("visible"), "set_visible for many prims.")
      .def(
          "set_pass_visibility",
          [](RenderDelegate& self, const std::string& id, bool cameraVisible, bool matte) {
            self.prim(id).setPassVisibility({cameraVisible, matte});
          },
          py::arg("id"), py::arg("camera_visible") = true, py::arg("matte") = false,
          "How camera rays treat a mesh or an instancer's copies (UsdRenderPass "
          "cameraVisibility and matte collections): hidden from them, or a holdout.")
      .def(
          "set_instances",
          [](RenderDelegate& self, const std::string& id, const std::string& prototype,
             const DoubleArray& matrices) {
            // (N, 4, 4): static copies; (N, K, 4, 4): K motion samples each.
            const bool animated = matrices.ndim() == 4;
            if (!(matrices.ndim() == 3 || animated) || matrices.shape(matrices.ndim() - 1) != 4 ||
                matrices.shape(matrices.ndim() - 2) != 4 || (animated && matrices.shape(1) < 1))
              throw std::invalid_argument(
                  id + ": instance transforms must have shape (N, 4, 4) or (N, K, 4, 4)");
            const py::ssize_t count = matrices.shape(0), steps = animated ? matrices.shape(1) : 1;
            std::vector<MotionTransform> transforms;
            transforms.reserve(size_t(count));
            const double* values = matrices.data();
            for (py::ssize_t i = 0; i < count; ++i) {
              std::vector<Transform> samples;
              for (py::ssize_t k = 0; k < steps; ++k, values += 16)
                samples.push_back(Transform::fromRowMajor(values));
              transforms.emplace_back(std::move(samples));
            }
            self.instancer(id).setInstances(prototype, std::move(transforms));
          },
          py::arg("id"), py::arg("prototype"), py::arg("transforms"))
      .def(
          "set_camera",
          [](RenderDelegate& self, const std::string& id, float focalLength,
             float horizontalAperture, float verticalAperture, float horizontalApertureOffset,
             float verticalApertureOffset, float fStop, float focusDistance,
             std::pair<float, float> clippingRange, float shutterOpen, float shutterClose,
             const std::string& projection, float pixelAspectRatio) {
            CameraParams params;
            params.focalLength = focalLength;
            params.horizontalAperture = horizontalAperture;
            params.verticalAperture = verticalAperture;
            params.horizontalApertureOffset = horizontalApertureOffset;
            params.verticalApertureOffset = verticalApertureOffset;
            params.fStop = fStop;
            params.focusDistance = focusDistance;
            params.nearClip = clippingRange.first;
            params.farClip = clippingRange.second;
            params.shutterOpen = shutterOpen;
            params.shutterClose = shutterClose;
            params.pixelAspectRatio = pixelAspectRatio;
            if (projection == "perspective")
              params.projection = Projection::Perspective;
            else if (projection == "orthographic")
              params.projection = Projection::Orthographic;
            else
              throw std::invalid_argument(id + ": unknown projection '" + projection + "'");
            self.camera(id).setParams(params);
          },
          py::arg("id"), py::kw_only(), py::arg("focal_length"), py::arg("horizontal_aperture"),
          py::arg("vertical_aperture"), py::arg("horizontal_aperture_offset") = 0.0f,
          py::arg("vertical_aperture_offset") = 0.0f, py::arg("f_stop") = 0.0f,
          py::arg("focus_distance") = 0.0f,
          py::arg("clipping_range") = std::pair<float, float>(0.01f, 1e6f),
          py::arg("shutter_open") = 0.0f, py::arg("shutter_close") = 0.0f,
          py::arg("projection") = "perspective", py::arg("pixel_aspect_ratio") = 1.0f)
      .def(
          "set_camera_motion",
          [](RenderDelegate& self, const std::string& id, const FloatArray& focalLengths,
             const FloatArray& focusDistances) {
            self.camera(id).setLensMotion(toFloatVector(focalLengths, "focal_lengths"),
                                          toFloatVector(focusDistances, "focus_distances"));
          },
          py::arg("id"), py::arg("focal_lengths"), py::arg("focus_distances"))
      .def(
          "set_light",
          [](RenderDelegate& self, const std::string& id, const py::kwargs& params) {
            Light& light = self.light(id);
            for (const auto& [key, value] : params) {
              const std::string name = py::str(key);
              light.setParam(name, toParamValue(id + ": " + name, value));
            }
          },
          py::arg("id"))
      .def(
          "set_material",
          [](RenderDelegate& self, const std::string& id, const py::dict& params) {
            Material& material = self.material(id);
            material.resetParams();
            for (const auto& [key, value] : params) {
              const std::string name = py::str(key);
              if (py::isinstance<py::dict>(value))
                material.connect(name, toInputSource(id + ": " + name, value.cast<py::dict>()));
              else
                material.setParam(name, toParamValue(id + ": " + name, value));
            }
          },
          py::arg("id"), py::arg("params"))
      .def(
          "set_render_setting",
          [](RenderDelegate& self, const std::string& key, double value) {
            self.settings().set(key, value);
          },
          py::arg("key"), py::arg("value"))
      .def("render_settings", [](const RenderDelegate& self) { return self.settings().asMap(); })
      .def(
          "dirty_bits",
          [](RenderDelegate& self, const std::string& id) { return self.prim(id).dirtyBits(); },
          py::arg("id"))
      .def(
          "set_dicing_camera",
          [](RenderDelegate& self, const std::string& cameraId) { self.setDicingCamera(cameraId); },
          py::arg("camera_id"))
      .def("dicing_camera", &RenderDelegate::dicingCamera)
      .def("sync_statistics",
           [](const RenderDelegate& self) {
             const RenderDelegate::SyncStatistics stats = self.syncStatistics();
             py::dict result;
             result["meshGeometrySyncs"] = stats.meshGeometrySyncs;
             result["subdivisionDicings"] = stats.subdivisionDicings;
             result["meshBvhBuilds"] = stats.meshBvhBuilds;
             result["topLevelBvhPrimitives"] = stats.topLevelBvhPrimitives;
             result["tessellationSeconds"] = stats.tessellationSeconds;
             result["bvhBuildSeconds"] = stats.bvhBuildSeconds;
             result["materialBuilds"] = stats.materialBuilds;
             result["materialTextureOpens"] = stats.materialTextureOpens;
             result["lightBuilds"] = stats.lightBuilds;
             result["lightTextureLoads"] = stats.lightTextureLoads;
             return result;
           })
      .def(
          "sync_count",
          [](RenderDelegate& self, const std::string& id) { return self.prim(id).syncCount(); },
          py::arg("id"))
      .def("estimated_sync_bytes", &RenderDelegate::estimatedSyncBytes)
      .def("take_warnings", &RenderDelegate::takeWarnings)
      .def("prim_id_manifest", &RenderDelegate::primIdManifest,
           "The mesh prims by the value the primId AOV gives them.");

  py::class_<RenderPass>(m, "RenderPass")
      .def(py::init([](RenderDelegate& delegate, std::string cameraId, int width, int height,
                       std::optional<std::array<int, 4>> crop, int margin) {
             if (!crop) return std::make_unique<RenderPass>(delegate, cameraId, width, height);
             const auto [x, y, cropWidth, cropHeight] = *crop;
             return std::make_unique<RenderPass>(delegate, cameraId, width, height,
                                                 PixelRect{x, y, cropWidth, cropHeight}, margin);
           }),
           py::arg("delegate"), py::arg("camera_id"), py::arg("width"), py::arg("height"),
           py::arg("crop") = py::none(), py::arg("margin") = 0, py::keep_alive<1, 2>())
      .def_static("adaptive_sampling_reach", &RenderPass::adaptiveSamplingReach, py::arg("samples"),
                  py::arg("min_samples"))
      .def("execute", &executeInterruptibly, py::arg("samples"))
      .def("reset", &RenderPass::reset)
      .def("set_aov_bindings", &RenderPass::setAovBindings, py::arg("bindings"))
      .def("set_aovs", &RenderPass::setAovs, py::arg("names"),
           "Accumulate these AOVs besides color, alpha, Z and sampleCount (a change restarts).")
      .def_property_readonly("samples_done", &RenderPass::samplesDone)
      .def_property_readonly("mean_samples", &RenderPass::meanSamples)
      .def_property_readonly("samples_taken", &RenderPass::samplesTaken)
      .def_property_readonly("rays_traced", &RenderPass::raysTraced)
      .def(
          "measure_raw_throughput",
          [](RenderPass& self) {
            penumbra::RawRayThroughput result;
            {
              py::gil_scoped_release release;
              result = self.measureRawThroughput();
            }
            py::dict out;
            out["primary"] = result.primary;
            out["bounce_intersect"] = result.bounceIntersect;
            out["bounce_occluded"] = result.bounceOccluded;
            out["bounce_rays"] = result.bounceRays;
            return out;
          },
          "Embree alone on this pass's scene and camera: rays per second of camera rays, "
          "cosine bounce rays (intersect) and the same rays as shadow rays (occluded).")
      .def_property_readonly("converged", &RenderPass::converged)
      .def_property_readonly("width", &RenderPass::width)
      .def_property_readonly("height", &RenderPass::height)
      .def_static("aov_names", &RenderPass::aovNames)
      .def(
          "aov",
          [](const RenderPass& self, const std::string& name) {
            const int channels = self.aovChannels(name);
            const std::vector<float> values = self.aov(name);
            py::array_t<float> result({self.height(), self.width(), channels});
            std::memcpy(result.mutable_data(), values.data(), values.size() * sizeof(float));
            return result;
          },
          py::arg("name"));

  m.def(
      "write_image",
      [](const std::string& path, const FloatArray& channels, const std::vector<std::string>& names,
         const py::dict& metadata, const std::string& colorMode, const std::string& ocioConfig,
         const std::string& display, const std::string& view,
         const std::vector<bool>& halfChannels) {
        if (channels.ndim() != 3 || channels.shape(2) != py::ssize_t(names.size()))
          throw std::invalid_argument(
              path + ": pixels must have shape (H, W, C) with one name per channel");
        ImageData image;
        image.height = int(channels.shape(0));
        image.width = int(channels.shape(1));
        image.channelNames = names;
        image.pixels.assign(channels.data(), channels.data() + channels.size());
        image.metadata = toMetadata(metadata);
        image.halfChannels.assign(halfChannels.begin(), halfChannels.end());
        DisplaySettings settings{toColorCorrection(colorMode), ocioConfig, display, view};
        py::gil_scoped_release release;
        penumbra::writeImage(path, image, settings);
      },
      py::arg("path"), py::arg("channels"), py::arg("channel_names"),
      py::arg("metadata") = py::dict(), py::arg("color_mode") = "disabled",
      py::arg("ocio_config") = "", py::arg("display") = "", py::arg("view") = "",
      py::arg("half_channels") = std::vector<bool>());

  m.def(
      "display_pixels",
      [](const FloatArray& pixels, const std::string& colorMode, const std::string& ocioConfig,
         const std::string& display, const std::string& view) {
        if (pixels.ndim() != 3 || pixels.shape(2) < 3)
          throw std::invalid_argument("pixels must have shape (H, W, C) with C >= 3");
        const int height = int(pixels.shape(0)), width = int(pixels.shape(1));
        const int channels = int(pixels.shape(2));
        std::vector<float> values(pixels.data(), pixels.data() + pixels.size());
        {
          py::gil_scoped_release release;
          penumbra::applyDisplayTransform(
              values, width, height, channels,
              {toColorCorrection(colorMode), ocioConfig, display, view});
        }
        py::array_t<float> result({pixels.shape(0), pixels.shape(1), pixels.shape(2)});
        std::memcpy(result.mutable_data(), values.data(), values.size() * sizeof(float));
        return result;
      },
      py::arg("pixels"), py::arg("color_mode") = "openColorIO", py::arg("ocio_config") = "",
      py::arg("display") = "", py::arg("view") = "",
      "Pixels with the display transform applied to their first three channels.");

  m.def(
      "read_image",
      [](const std::string& path) {
        ImageData image;
        {
          py::gil_scoped_release release;
          image = penumbra::readImage(path);
        }
        const py::ssize_t channels = py::ssize_t(image.channelNames.size());
        py::array_t<float> pixels({py::ssize_t(image.height), py::ssize_t(image.width), channels});
        std::memcpy(pixels.mutable_data(), image.pixels.data(),
                    image.pixels.size() * sizeof(float));
        return py::make_tuple(pixels, image.channelNames, toDict(image.metadata));
      },
      py::arg("path"));

  m.def(
      "read_image_header",
      [](const std::string& path) {
        ImageData image;
        {
          py::gil_scoped_release release;
          image = penumbra::readImageHeader(path);
        }
        return py::make_tuple(image.width, image.height, image.channelNames,
                              toDict(image.metadata));
      },
      py::arg("path"),
      "(width, height, channel_names, metadata) of an image file, without its pixels.");

  m.def(
      "find_texture_color_space",
      [](const std::string& name, const std::string& ocioConfig) {
        return penumbra::findTextureColorSpace(ocioConfig, name);
      },
      py::arg("name"), py::arg("ocio_config") = "",
      "The name of the colour space `name` denotes in the OCIO config (empty: $OCIO), as texture "
      "colorSpace accepts it; \"\" when the config has none.");

  m.def(
      "to_scene_linear",
      [](std::array<float, 3> rgb, const std::string& name,
         const std::string& ocioConfig) -> std::optional<std::array<float, 3>> {
        if (!penumbra::convertToSceneLinear(ocioConfig, name, rgb.data())) return std::nullopt;
        return rgb;
      },
      py::arg("rgb"), py::arg("color_space"), py::arg("ocio_config") = "",
      "`rgb` converted from the named colour space to the OCIO config's scene_linear role (as "
      "textures in that colour space are); None when the config has no such colour space.");
}
