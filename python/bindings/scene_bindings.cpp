// Prims of the render index: insertion and removal, meshes (MeshRecord, set_mesh, set_meshes and
// the per-aspect setters), instancers, transforms, visibility, cameras and lights.
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "bindings.h"
#include "conversions.h"

namespace penumbra::bindings {
namespace {

using plugin::Light;
using plugin::Mesh;
using plugin::ParamValue;
using plugin::RenderDelegate;

void setMeshPoints(Mesh& mesh, const FloatArray& points) {
  auto [first, motion] = toPointSamples(mesh.id(), points);
  mesh.setPoints(std::move(first), std::move(motion));
}

/// What `set_mesh` sends for one mesh, by field name (docs/core-api.md): the scene delegate
/// builds one per mesh and sends many in one set_meshes call. The arrays stay the caller's numpy
/// buffers (not copied when their dtype is already right) until setMesh copies them into the
/// mesh.
struct MeshRecord {
  std::string id;
  IntArray faceVertexCounts, faceVertexIndices;
  bool leftHanded;
  std::string subdivisionScheme;
  FloatArray points;
  bool doubleSided;
  FloatArray displayColor;
  std::string displayColorInterpolation;
  FloatArray normals;
  std::string normalsInterpolation;
  py::dict primvars;
};

void setMesh(RenderDelegate& delegate, const MeshRecord& record) {
  Mesh& mesh = delegate.mesh(record.id);
  mesh.setTopology(toIntVector(record.faceVertexCounts, "face_vertex_counts"),
                   toIntVector(record.faceVertexIndices, "face_vertex_indices"), record.leftHanded,
                   record.subdivisionScheme);
  setMeshPoints(mesh, record.points);
  mesh.setDoubleSided(record.doubleSided);
  mesh.setDisplayColor(toVec3Array(record.displayColor, "display colour"),
                       toInterpolation(record.displayColorInterpolation));
  mesh.setNormals(toVec3Array(record.normals, "normals"),
                  toInterpolation(record.normalsInterpolation));
  mesh.setPrimvars(toPrimvars(record.id, record.primvars));
}

/// MeshRecord's fields after its id, by keyword (set_mesh's arguments), in kMeshFields' order.
enum MeshField : size_t {
  FaceVertexCounts,
  FaceVertexIndices,
  LeftHanded,
  SubdivisionScheme,
  Points,
  DoubleSided,
  DisplayColor,
  DisplayColorInterpolation,
  Normals,
  NormalsInterpolation,
  Primvars,
  MeshFieldCount
};
constexpr std::array<const char*, MeshFieldCount> kMeshFields = {"face_vertex_counts",
                                                                 "face_vertex_indices",
                                                                 "left_handed",
                                                                 "subdivision_scheme",
                                                                 "points",
                                                                 "double_sided",
                                                                 "display_color",
                                                                 "display_color_interpolation",
                                                                 "normals",
                                                                 "normals_interpolation",
                                                                 "primvars"};

/// A MeshRecord from its id and its fields by keyword, all of them and no others. The fields are
/// looked up in the keyword dict Python passes by interned names, which compare by identity
/// with Python's own keyword names: pybind11's matching of named arguments would build each
/// name again and copy the dict, which costs as much as the rest of a plain mesh's push (once
/// per mesh of a sync).
MeshRecord toMeshRecord(const std::string& id, const py::kwargs& fields) {
  static const std::array<PyObject*, MeshFieldCount> names = [] {
    std::array<PyObject*, MeshFieldCount> interned;  // kept for the life of the interpreter
    for (size_t i = 0; i < MeshFieldCount; ++i)
      interned[i] = PyUnicode_InternFromString(kMeshFields[i]);
    return interned;
  }();
  const auto field = [&](MeshField which) -> py::handle {
    if (PyObject* value = PyDict_GetItemWithError(fields.ptr(), names[which])) return value;
    if (PyErr_Occurred()) throw py::error_already_set();
    throw py::type_error(id + ": MeshRecord needs the field '" + kMeshFields[which] + "'");
  };
  MeshRecord record{id,
                    field(FaceVertexCounts).cast<IntArray>(),
                    field(FaceVertexIndices).cast<IntArray>(),
                    field(LeftHanded).cast<bool>(),
                    field(SubdivisionScheme).cast<std::string>(),
                    field(Points).cast<FloatArray>(),
                    field(DoubleSided).cast<bool>(),
                    field(DisplayColor).cast<FloatArray>(),
                    field(DisplayColorInterpolation).cast<std::string>(),
                    field(Normals).cast<FloatArray>(),
                    field(NormalsInterpolation).cast<std::string>(),
                    field(Primvars).cast<py::dict>()};
  if (size_t(PyDict_Size(fields.ptr())) != MeshFieldCount)  // all were found: one is unknown
    for (const auto& entry : fields) {
      const std::string name = py::str(entry.first);
      if (std::find(kMeshFields.begin(), kMeshFields.end(), name) == kMeshFields.end())
        throw py::type_error(id + ": MeshRecord has no field '" + name + "'");
    }
  return record;
}

void bindMeshRecord(py::module_& m) {
  py::class_<MeshRecord>(m, "MeshRecord",
                         "One mesh's data for set_meshes: MeshRecord(id, **fields), the fields "
                         "being set_mesh's keyword arguments, all required.")
      .def(py::init(&toMeshRecord), py::arg("id"))
      .def_readwrite("id", &MeshRecord::id)
      .def_readwrite("face_vertex_counts", &MeshRecord::faceVertexCounts)
      .def_readwrite("face_vertex_indices", &MeshRecord::faceVertexIndices)
      .def_readwrite("left_handed", &MeshRecord::leftHanded)
      .def_readwrite("subdivision_scheme", &MeshRecord::subdivisionScheme)
      .def_readwrite("points", &MeshRecord::points)
      .def_readwrite("double_sided", &MeshRecord::doubleSided)
      .def_readwrite("display_color", &MeshRecord::displayColor)
      .def_readwrite("display_color_interpolation", &MeshRecord::displayColorInterpolation)
      .def_readwrite("normals", &MeshRecord::normals)
      .def_readwrite("normals_interpolation", &MeshRecord::normalsInterpolation)
      .def_readwrite("primvars", &MeshRecord::primvars);
}

/// `set_transform` of one prim: a mesh, points, a camera or a light.
void setTransform(RenderDelegate& delegate, const std::string& id, const DoubleArray& matrix) {
  // The matrix first: a bad one is a ValueError even for an unknown id.
  const MotionTransform transform = toMotionTransform(matrix);
  delegate.prim(id).setTransform(transform);
}

/// `set_visible` of one prim: a mesh, points, a light or an instancer.
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

}  // namespace

void bindScene(py::module_& m, DelegateClass& delegate) {
  bindMeshRecord(m);
  delegate.def("insert_rprim", &RenderDelegate::insertRprim, py::arg("type"), py::arg("id"))
      .def(
          "insert_rprims",
          [](RenderDelegate& self, const std::string& type, const std::vector<std::string>& ids) {
            for (const std::string& id : ids) self.insertRprim(type, id);
          },
          py::arg("type"), py::arg("ids"), "insert_rprim for each of `ids`, in one call.")
      .def("insert_sprim", &RenderDelegate::insertSprim, py::arg("type"), py::arg("id"))
      .def("insert_bprim", &RenderDelegate::insertBprim, py::arg("type"), py::arg("id"));
  delegate.def("remove_prim", &RenderDelegate::removePrim, py::arg("id"))
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
            SubdivisionTags tags;
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
          [](RenderDelegate& self, const std::string& id, const py::kwargs& fields) {
            // One call per mesh for what the setters below send one by one.
            setMesh(self, toMeshRecord(id, fields));
          },
          py::arg("id"),
          "Everything the mesh setters below send, in one call: MeshRecord's fields by name.")
      .def(
          "set_meshes",
          [](RenderDelegate& self, const py::list& meshes) {
            for (const py::handle& mesh : meshes) {
              const MeshRecord* record;
              try {
                record = &mesh.cast<const MeshRecord&>();
              } catch (const py::builtin_exception&) {  // not a MeshRecord, or None
                throw py::type_error("set_meshes takes a list of MeshRecord");
              }
              setMesh(self, *record);
            }
          },
          py::arg("meshes"), "set_mesh for many meshes in one call, each a MeshRecord.")
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
            self.mesh(id).setPrimvars(toPrimvars(id, primvars));
          },
          py::arg("id"), py::arg("primvars"))
      .def(
          "set_instance_primvars",
          [](RenderDelegate& self, const std::string& id, const py::dict& primvars) {
            std::vector<Primvar> values;
            for (const auto& [key, value] : primvars)
              values.push_back(
                  toPrimvar(id, py::str(key), value.cast<FloatArray>(), Interpolation::Vertex));
            self.instancer(id).setPrimvars(std::move(values));
          },
          py::arg("id"), py::arg("primvars"))
      .def(
          "set_mesh_material",
          [](RenderDelegate& self, const std::string& id, const std::string& materialId) {
            self.prim(id).setMaterialId(materialId);
          },
          py::arg("id"), py::arg("material_id"))
      .def(
          "set_mesh_materials",
          [](RenderDelegate& self, const std::vector<std::string>& ids,
             const std::vector<std::string>& materialIds) {
            forEachPrim(ids, materialIds, [&](const std::string& id, const std::string& material) {
              self.prim(id).setMaterialId(material);
            });
          },
          py::arg("ids"), py::arg("material_ids"), "set_mesh_material for many meshes or points.")
      .def(
          "set_subset_materials",
          [](RenderDelegate& self, const std::string& id,
             const std::vector<std::pair<std::string, IntArray>>& subsets) {
            std::vector<plugin::SubsetMaterial> bindings;
            for (const auto& [material, faces] : subsets)
              bindings.push_back({material, toIntVector(faces, "faces")});
            self.mesh(id).setSubsetMaterials(std::move(bindings));
          },
          py::arg("id"), py::arg("subsets"),
          "Per-face material bindings of mesh `id` (GeomSubsets): (material id, face indices) "
          "pairs, the first subset binding a face where they overlap; an empty material id "
          "shows displayColor on its faces.")
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
          [](RenderDelegate& self, const std::string& id, bool cameraVisible, bool matte,
             bool shadow, bool diffuse, bool glossy, bool transmission) {
            self.prim(id).setPassVisibility(
                {cameraVisible, matte, shadow, diffuse, glossy, transmission});
          },
          py::arg("id"), py::arg("camera_visible") = true, py::arg("matte") = false,
          py::arg("shadow") = true, py::arg("diffuse") = true, py::arg("glossy") = true,
          py::arg("transmission") = true,
          "How camera rays treat a mesh, points or an instancer's copies (UsdRenderPass "
          "cameraVisibility and matte collections, primvars:penumbra:visibility:camera and "
          "primvars:penumbra:holdout): hidden from them, or a holdout; and which other rays see "
          "them (primvars:penumbra:visibility:shadow, :diffuse, :glossy, :transmission).")
      .def(
          "set_linking_class",
          [](RenderDelegate& self, const std::string& id, uint32_t linkingClass) {
            plugin::Prim& prim = self.prim(id);
            if (auto* placed = dynamic_cast<plugin::PlacedRprim*>(&prim))
              placed->setLinkingClass(linkingClass);
            else if (auto* volume = dynamic_cast<plugin::Volume*>(&prim))
              volume->setLinkingClass(linkingClass);
            else
              throw std::invalid_argument(id +
                                          ": only meshes, points, curves and volumes have a "
                                          "linking class (instancers: "
                                          "set_instance_linking_classes)");
          },
          py::arg("id"), py::arg("linking_class"),
          "Light and shadow linking: the class (of set_linking_classes) of a mesh, points, "
          "curves or volume; 0: linked to every light.")
      .def(
          "set_instance_linking_classes",
          [](RenderDelegate& self, const std::string& id, const std::vector<uint32_t>& classes) {
            self.instancer(id).setLinkingClasses(classes);
          },
          py::arg("id"), py::arg("classes"),
          "The linking class of each copy of an instancer, in the order of its transforms "
          "(empty: all linked to every light).")
      .def(
          "set_linking_classes",
          [](RenderDelegate& self,
             const std::vector<std::pair<std::vector<uint32_t>, std::vector<uint32_t>>>& classes) {
            std::vector<LinkingClass> table;
            table.reserve(classes.size());
            for (const auto& [unlit, unshadowed] : classes) table.push_back({unlit, unshadowed});
            self.setLinkingClasses(table);
          },
          py::arg("classes"),
          "Light and shadow linking classes: class i + 1 is classes[i], a pair (the link slots "
          "whose light link excludes it, those whose shadow link excludes it); class 0 is "
          "linked to every light.")
      .def("set_light_link_slot", &RenderDelegate::setLightLinkSlot, py::arg("id"), py::arg("slot"),
           "The light and shadow linking slot of a light or mesh light (-1: it lights and "
           "shadows everything).")
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
             const std::string& projection, float pixelAspectRatio, float exposureScale) {
            if (!(std::isfinite(exposureScale) && exposureScale >= 0))
              throw std::invalid_argument(id + ": exposure_scale must be finite and >= 0, not " +
                                          std::to_string(exposureScale));
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
            params.exposureScale = exposureScale;
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
          py::arg("projection") = "perspective", py::arg("pixel_aspect_ratio") = 1.0f,
          py::arg("exposure_scale") = 1.0f)
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
          py::arg("id"));
}

}  // namespace penumbra::bindings
