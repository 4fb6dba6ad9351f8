// Volume rprims (UsdVolVolume): set_volume, with its fields and material; and write_vdb, which
// writes dense blocks as OpenVDB grids (tests and examples author .vdb files with it). Their
// transform and visibility go through the per-prim setters of scene_bindings.cpp.
#include <string>
#include <utility>
#include <vector>

#include "bindings.h"
#include "conversions.h"
#include "penumbra/vdb_field.h"

namespace penumbra::bindings {
namespace {

using plugin::FieldRequest;
using plugin::VolumeFieldRequests;

/// {slot: (file, grid name, grid index)} → the requests; unknown slots are errors.
VolumeFieldRequests toFieldRequests(const std::string& id, const py::dict& fields) {
  VolumeFieldRequests requests;
  readDict(id + ": fields", fields, {"density", "color", "temperature", "emission"},
           [&](const std::string& slot, const py::handle& value) {
             auto [path, grid, index] = value.cast<std::tuple<std::string, std::string, int>>();
             if (index < 0) throw std::invalid_argument("the grid index must not be negative");
             FieldRequest request{std::move(path), std::move(grid), index};
             if (slot == "density") requests.density = std::move(request);
             if (slot == "color") requests.color = std::move(request);
             if (slot == "temperature") requests.temperature = std::move(request);
             if (slot == "emission") requests.emission = std::move(request);
           });
  return requests;
}

/// VolumeShading.material()'s dict → the renderer's VolumeMaterial (keys not given keep their
/// defaults).
VolumeMaterial toVolumeMaterial(const std::string& id, const py::dict& material) {
  VolumeMaterial result;
  const auto color = [](const std::string& where, const py::handle& value) {
    const auto [r, g, b] = toFloats<3>(where, value);
    return Vec3f{r, g, b};
  };
  const std::string where = id + ": material";
  readDict(where, material,
           {"density", "scattering", "absorption", "principled_absorption", "anisotropy",
            "emission", "blackbody_intensity", "blackbody_tint", "temperature"},
           [&](const std::string& key, const py::handle& value) {
             const std::string at = where + "." + key;
             if (key == "density") result.density = value.cast<float>();
             if (key == "scattering") result.scattering = color(at, value);
             if (key == "absorption") result.absorption = color(at, value);
             if (key == "principled_absorption") result.principledAbsorption = color(at, value);
             if (key == "anisotropy") result.anisotropy = value.cast<float>();
             if (key == "emission") result.emission = color(at, value);
             if (key == "blackbody_intensity") result.blackbodyIntensity = value.cast<float>();
             if (key == "blackbody_tint") result.blackbodyTint = color(at, value);
             if (key == "temperature") result.temperature = value.cast<float>();
           });
  return result;
}

/// A (nz, ny, nx) or (nz, ny, nx, 3) array named `name` → a grid to write.
VdbGridToWrite toGrid(const std::string& name, const FloatArray& values,
                      const Transform& indexToObject) {
  const bool vector = values.ndim() == 4;
  if (!(values.ndim() == 3 || (vector && values.shape(3) == 3)))
    throw std::invalid_argument("grid '" + name +
                                "' must have shape (nz, ny, nx) or (nz, ny, nx, 3)");
  VdbGridToWrite grid;
  grid.name = name;
  grid.nz = int(values.shape(0));
  grid.ny = int(values.shape(1));
  grid.nx = int(values.shape(2));
  grid.components = vector ? 3 : 1;
  grid.values.assign(values.data(), values.data() + values.size());
  grid.indexToObject = indexToObject;
  return grid;
}

}  // namespace

void bindVolumes(py::module_& m, DelegateClass& delegate) {
  delegate.def(
      "set_volume",
      [](plugin::RenderDelegate& self, const std::string& id, const py::dict& fields,
         const py::dict& material) {
        plugin::Volume& volume = self.volume(id);
        // Everything is converted first: a bad key or value changes nothing.
        VolumeFieldRequests requests = toFieldRequests(id, fields);
        const VolumeMaterial volumeMaterial = toVolumeMaterial(id, material);
        volume.setFields(std::move(requests));
        volume.setMaterial(volumeMaterial);
      },
      py::arg("id"), py::arg("fields"), py::arg("material") = py::dict(),
      "A volume prim's fields {slot: (file, grid name, grid index)} for the slots 'density', "
      "'color', 'temperature' and 'emission' (files are read at the sync, through a cache), "
      "and its material {key: value} with VolumeShading.material()'s keys (those not given "
      "keep the renderer's defaults).");

  m.def(
      "write_vdb",
      [](const std::string& path, const py::dict& grids, const DoubleArray& indexToObject) {
        if (indexToObject.ndim() != 2 || indexToObject.shape(0) != 4 || indexToObject.shape(1) != 4)
          throw std::invalid_argument("index_to_object must be a 4x4 matrix");
        const Transform transform = Transform::fromRowMajor(indexToObject.data());
        std::vector<VdbGridToWrite> toWrite;
        for (const auto& [name, values] : grids)
          toWrite.push_back(toGrid(py::str(name), values.cast<FloatArray>(), transform));
        py::gil_scoped_release release;
        try {
          writeVdbFile(path, toWrite);
        } catch (const VolumeFieldError& error) {
          throw std::runtime_error(error.what());  // a file error: RuntimeError
        }
      },
      py::arg("path"), py::arg("grids"),
      py::arg("index_to_object") =
          DoubleArray(py::array::ShapeContainer{4, 4}, Transform().m.data()),
      "Writes OpenVDB grids {name: float32 array (nz, ny, nx), or (nz, ny, nx, 3) for a "
      "vector grid} to `path`, atomically; zero voxels are left inactive. Voxel (i, j, k) "
      "(array index [k, j, i]) is centred at index_to_object applied to (i, j, k): a 4x4 "
      "row-major matrix in USD's row-vector convention (translation in the last row).");
}

}  // namespace penumbra::bindings
