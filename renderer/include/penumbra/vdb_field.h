// Volume fields from OpenVDB grids, held sparse (NanoVDB): memory grows with the active voxels,
// not with the bounding box. Voxel (i, j, k)'s centre lies at the grid's index-to-object
// transform applied to (i, j, k), as in OpenVDB's index space.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "penumbra/math.h"
#include "penumbra/volume_field.h"

namespace penumbra {

/// Why a grid cannot be read; the message names the file and the grid, and says what is wrong
/// (no such file, not an OpenVDB file, no grid of that name or index, a value type that is not
/// a scalar or a 3-vector, a singular or non-affine transform).
class VolumeFieldError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A grid read from a file, and what was repaired in it.
struct VdbFieldRead {
  std::shared_ptr<const VolumeField> field;
  std::string valueType;         // OpenVDB's name of the grid's value type ("float", "vec3s", …)
  uint64_t nonFiniteVoxels = 0;  // NaN or infinite values, read as 0
  uint64_t negativeVoxels = 0;   // voxels with a negative value or component, read as 0
};

/// Reads the `index`-th grid named `gridName` (0: the first of that name) of the OpenVDB file
/// `path`. Float, double and half grids (OpenVDB reads half as float) give scalar fields; Vec3
/// grids of float or double give 3-component fields; every other value type (int, bool, masks,
/// …) is refused. The field's
/// object space is the grid's world space (the grid's own transform is applied). Throws
/// VolumeFieldError.
VdbFieldRead readVdbField(const std::string& path, const std::string& gridName, int index = 0);

/// Bytes reading that grid (readVdbField) takes at its peak, from the metadata OpenVDB writes
/// with each grid (its size in memory when it was written: the grid read, and the float field
/// made from it beside it), without reading its voxels; twice the file's size when the file
/// has no such metadata; 0 when the file or grid cannot be read (readVdbField then says why).
uint64_t estimatedVdbFieldBytes(const std::string& path, const std::string& gridName,
                                int index = 0);

/// A dense block of nx × ny × nz voxels (x fastest, then y, then z; `components` floats each,
/// 1 or 3), voxel (i, j, k)'s centre at indexToObject applied to (i, j, k), held sparse like a
/// file's grid (zero voxels are inactive). For tests, examples and procedural fields. Throws
/// std::invalid_argument for sizes that do not match or a singular transform.
std::shared_ptr<const VolumeField> denseVdbField(int nx, int ny, int nz, int components,
                                                 const std::vector<float>& values,
                                                 const Transform& indexToObject);

/// One grid to write: a dense block as denseVdbField takes it, named `name`.
struct VdbGridToWrite {
  std::string name;
  int nx = 0, ny = 0, nz = 0, components = 1;
  std::vector<float> values;
  Transform indexToObject;
};

/// Writes the grids (zero voxels left inactive) to the OpenVDB file `path`, atomically (a
/// temporary file renamed into place). Throws VolumeFieldError naming the file on failure and
/// std::invalid_argument for grids whose sizes do not match or whose transform is singular.
void writeVdbFile(const std::string& path, const std::vector<VdbGridToWrite>& grids);

}  // namespace penumbra
