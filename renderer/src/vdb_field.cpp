// OpenVDB reads and writes the files; NanoVDB holds the grid in one flat read-only buffer that
// render threads sample concurrently, each through its own accessor.
#include "penumbra/vdb_field.h"

#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/OpenToNanoVDB.h>
#include <nanovdb/util/SampleFromVoxels.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <type_traits>

namespace penumbra {
namespace {

/// Refuses transforms whose linear part is (nearly) singular or not finite, relative to its
/// scale so that tiny voxel sizes stay valid.
bool invertible(const Transform& transform) {
  double rowLengths = 1;
  for (int r = 0; r < 3; ++r)
    rowLengths *= std::sqrt(transform.at(r, 0) * transform.at(r, 0) +
                            transform.at(r, 1) * transform.at(r, 1) +
                            transform.at(r, 2) * transform.at(r, 2));
  const double det = transform.linearDeterminant();
  if (!std::isfinite(det) || !std::isfinite(rowLengths) || !(rowLengths > 0)) return false;
  for (double v : transform.m)
    if (!std::isfinite(v)) return false;
  return std::fabs(det) > 1e-9 * rowLengths;
}

// What maxIn bounds: the value of a scalar, the largest component of a vector.
float largestComponent(float value) {
  return value;
}
float largestComponent(const nanovdb::Vec3f& value) {
  return std::max(value[0], std::max(value[1], value[2]));
}

struct Repairs {
  uint64_t nonFinite = 0;
  uint64_t negative = 0;
};

/// The value the renderer keeps: non-finite and negative components read as 0 (fields are
/// densities, temperatures, colours and emission, none of which may be negative).
/// Whether a voxel's value stays finite as the float the renderer holds (a double beyond
/// FLT_MAX would become infinite).
bool finiteAsFloat(double value) {
  return std::fabs(value) <= double(std::numeric_limits<float>::max());
}

float repaired(double value, uint64_t voxels, Repairs& repairs) {
  if (!finiteAsFloat(value)) {
    repairs.nonFinite += voxels;
    return 0;
  }
  if (value < 0) {
    repairs.negative += voxels;
    return 0;
  }
  return float(value);
}
template <typename T>
openvdb::Vec3s repaired(const openvdb::math::Vec3<T>& value, uint64_t voxels, Repairs& repairs) {
  openvdb::Vec3s result;
  bool nonFinite = false, negative = false;
  for (int c = 0; c < 3; ++c) {
    nonFinite = nonFinite || !finiteAsFloat(value[c]);
    negative = negative || value[c] < 0;
    result[c] = finiteAsFloat(value[c]) && value[c] > 0 ? float(value[c]) : 0.0f;
  }
  if (nonFinite) repairs.nonFinite += voxels;
  if (negative) repairs.negative += voxels;
  return result;
}

/// A float or Vec3s copy of the active values of `source` (voxels and tiles) with every other
/// value, the background included, 0: trilinear sampling then fades to 0 outside.
template <typename TargetGrid, typename SourceGrid>
typename TargetGrid::Ptr repairedCopy(const SourceGrid& source, Repairs& repairs) {
  auto target = TargetGrid::create(typename TargetGrid::ValueType(0));
  auto& tree = target->tree();
  typename TargetGrid::Accessor accessor = target->getAccessor();
  for (auto it = source.tree().cbeginValueOn(); it; ++it) {
    const auto value = repaired(*it, it.getVoxelCount(), repairs);
    if (it.isVoxelValue())
      accessor.setValue(it.getCoord(), value);
    else
      tree.addTile(it.getLevel(), it.getBoundingBox().min(), value, true);
  }
  return target;
}

template <typename ValueT>
class VdbField final : public VolumeField {
  using NanoTree = nanovdb::NanoTree<ValueT>;
  using Upper = typename NanoTree::Node2;
  using Leaf = typename NanoTree::Node0;
  using Accessor = typename nanovdb::NanoGrid<ValueT>::AccessorType;

 public:
  VdbField(nanovdb::GridHandle<nanovdb::HostBuffer> handle, const openvdb::CoordBBox& active,
           const Transform& indexToObject)
      : handle_(std::move(handle)),
        grid_(handle_.grid<ValueT>()),
        objectToIndex_(indexToObject.inverse()),
        activeVoxels_(grid_->activeVoxelCount()) {
    if (active.empty()) return;
    // The trilinear fringe: one voxel beyond the active ones.
    for (int a = 0; a < 3; ++a) {
      indexLower_[a] = active.min()[a] - 1;
      indexUpper_[a] = active.max()[a] + 1;
    }
    for (int corner = 0; corner < 8; ++corner)
      objectBounds_.extend(
          indexToObject.applyToPoint(Vec3f(float(corner & 1 ? indexUpper_[0] : indexLower_[0]),
                                           float(corner & 2 ? indexUpper_[1] : indexLower_[1]),
                                           float(corner & 4 ? indexUpper_[2] : indexLower_[2]))));
    const NanoTree& tree = grid_->tree();
    const Leaf* leaves = tree.getFirstLeaf();
    leafMaxima_.resize(tree.nodeCount(0));
    for (size_t n = 0; n < leafMaxima_.size(); ++n) {
      float maximum = 0;  // inactive values are 0
      for (uint32_t v = 0; v < Leaf::SIZE; ++v)
        maximum = std::max(maximum, largestComponent(leaves[n].getValue(v)));
      leafMaxima_[n] = maximum;
    }
  }

  int components() const override { return std::is_same_v<ValueT, float> ? 1 : 3; }

  void sample(const Vec3f& objectPoint, float* value) const override {
    const Vec3f p = objectToIndex_.applyToPoint(objectPoint);
    // Written so that NaN falls outside too.
    const bool inside = p.x > float(indexLower_[0]) && p.x < float(indexUpper_[0]) &&
                        p.y > float(indexLower_[1]) && p.y < float(indexUpper_[1]) &&
                        p.z > float(indexLower_[2]) && p.z < float(indexUpper_[2]);
    if (!inside) {
      std::fill(value, value + components(), 0.0f);
      return;
    }
    const Accessor accessor = grid_->getAccessor();
    const nanovdb::SampleFromVoxels<Accessor, 1, false> sampler(accessor);
    const ValueT result = sampler(nanovdb::Vec3f(p.x, p.y, p.z));
    if constexpr (std::is_same_v<ValueT, float>) {
      value[0] = result;
    } else {
      for (int c = 0; c < 3; ++c) value[c] = result[c];
    }
  }

  Bounds3f objectBounds() const override { return objectBounds_; }

  float maxIn(const Bounds3f& objectBox) const override {
    // Clipped first, so that unbounded boxes map to finite index coordinates.
    const Bounds3f box = intersection(objectBox, objectBounds_);
    if (box.empty()) return 0;
    Bounds3f indexBox;
    for (int corner = 0; corner < 8; ++corner)
      indexBox.extend(objectToIndex_.applyToPoint(Vec3f(corner & 1 ? box.upper.x : box.lower.x,
                                                        corner & 2 ? box.upper.y : box.lower.y,
                                                        corner & 4 ? box.upper.z : box.lower.z)));
    // Voxels floor(p) and floor(p) + 1 weigh in a sample at p; the box is widened by more than
    // the rounding of the mapping so that no voxel with a weight is missed.
    nanovdb::CoordBBox voxels;
    for (int a = 0; a < 3; ++a) {
      const double lower = indexBox.lower[a], upper = indexBox.upper[a];
      const double slack = 1e-4 * std::max(1.0, std::max(std::fabs(lower), std::fabs(upper)));
      const double clampedLower = std::max(std::floor(lower - slack), double(indexLower_[a] + 1));
      const double clampedUpper =
          std::min(std::floor(upper + slack) + 1, double(indexUpper_[a] - 1));
      if (!(clampedLower <= clampedUpper)) return 0;  // also NaN
      voxels.min()[a] = int32_t(clampedLower);
      voxels.max()[a] = int32_t(clampedUpper);
    }
    float maximum = 0;
    const auto& root = *grid_->tree().root().data();
    for (uint32_t t = 0; t < root.mTableSize; ++t) {
      const auto* tile = root.tile(t);
      if (!overlaps(tile->origin(), Upper::DIM, voxels)) continue;
      maximum = std::max(maximum, tile->isChild() ? maxIn(*root.getChild(tile), voxels)
                                                  : largestComponent(tile->value));
    }
    return maximum;
  }

  uint64_t activeVoxels() const override { return activeVoxels_; }
  size_t memoryBytes() const override {
    return sizeof(*this) + handle_.size() + leafMaxima_.capacity() * sizeof(float);
  }

 private:
  static bool overlaps(const nanovdb::Coord& origin, uint32_t dim, const nanovdb::CoordBBox& box) {
    for (int a = 0; a < 3; ++a)
      if (int64_t(origin[a]) + dim <= box.min()[a] || origin[a] > box.max()[a]) return false;
    return true;
  }

  /// The largest value of the internal node's tiles and children that overlap `box`.
  template <typename Node>
  float maxIn(const Node& node, const nanovdb::CoordBBox& box) const {
    using Child = typename Node::ChildNodeType;
    const nanovdb::Coord origin = node.origin();
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      first[a] = (std::max(box.min()[a], origin[a]) - origin[a]) >> Child::TOTAL;
      last[a] =
          int((std::min(int64_t(box.max()[a]), int64_t(origin[a]) + Node::DIM - 1) - origin[a]) >>
              Child::TOTAL);
    }
    const auto& data = *node.data();
    float maximum = 0;
    for (int i = first[0]; i <= last[0]; ++i)
      for (int j = first[1]; j <= last[1]; ++j)
        for (int k = first[2]; k <= last[2]; ++k) {
          const uint32_t n =
              (uint32_t(i) << (2 * Node::LOG2DIM)) | (uint32_t(j) << Node::LOG2DIM) | uint32_t(k);
          float childMaximum;
          if (!data.mChildMask.isOn(n))
            childMaximum = largestComponent(data.getValue(n));
          else if constexpr (std::is_same_v<Child, Leaf>)
            childMaximum = leafMaxima_[size_t(data.getChild(n) - grid_->tree().getFirstLeaf())];
          else
            childMaximum = maxIn(*data.getChild(n), box);
          maximum = std::max(maximum, childMaximum);
        }
    return maximum;
  }

  nanovdb::GridHandle<nanovdb::HostBuffer> handle_;
  const nanovdb::NanoGrid<ValueT>* grid_;
  Transform objectToIndex_;
  uint64_t activeVoxels_;
  // Where sample() may be non-zero, exclusive: the active voxels' box grown by one voxel.
  int32_t indexLower_[3] = {0, 0, 0};
  int32_t indexUpper_[3] = {0, 0, 0};
  Bounds3f objectBounds_;
  std::vector<float> leafMaxima_;  // per NanoVDB leaf, in their order in the buffer
};

/// The field of a repaired float or Vec3s grid.
template <typename Grid>
std::shared_ptr<const VolumeField> fieldOf(const Grid& grid, const Transform& indexToObject) {
  using NanoValue =
      std::conditional_t<std::is_same_v<Grid, openvdb::FloatGrid>, float, nanovdb::Vec3f>;
  auto handle = nanovdb::openToNanoVDB<nanovdb::HostBuffer, typename Grid::TreeType>(
      grid, nanovdb::StatsMode::BBox, nanovdb::ChecksumMode::Disable);
  return std::make_shared<VdbField<NanoValue>>(std::move(handle), grid.evalActiveVoxelBoundingBox(),
                                               indexToObject);
}

void requireDenseSizes(int nx, int ny, int nz, int components, size_t values) {
  if (nx < 0 || ny < 0 || nz < 0)
    throw std::invalid_argument("a dense grid's sizes must not be negative");
  if (components != 1 && components != 3)
    throw std::invalid_argument("a dense grid has 1 or 3 components, not " +
                                std::to_string(components));
  if (uint64_t(nx) * uint64_t(ny) * uint64_t(nz) * uint64_t(components) != values)
    throw std::invalid_argument("a dense grid of " + std::to_string(nx) + " x " +
                                std::to_string(ny) + " x " + std::to_string(nz) + " x " +
                                std::to_string(components) + " values was given " +
                                std::to_string(values));
}

openvdb::Mat4d toOpenVdb(const Transform& transform) {
  return openvdb::Mat4d(transform.m.data());  // both row-vector, row-major
}

/// The dense block as an OpenVDB grid: non-zero voxels active, the rest inactive and 0.
template <typename Grid>
typename Grid::Ptr sparseGridOf(int nx, int ny, int nz, const std::vector<float>& values) {
  constexpr int kComponents = std::is_same_v<Grid, openvdb::FloatGrid> ? 1 : 3;
  auto grid = Grid::create(typename Grid::ValueType(0));
  auto accessor = grid->getAccessor();
  size_t at = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i, at += kComponents) {
        typename Grid::ValueType value;
        if constexpr (kComponents == 1)
          value = values[at];
        else
          value = openvdb::Vec3s(values[at], values[at + 1], values[at + 2]);
        if (value != typename Grid::ValueType(0)) accessor.setValue(openvdb::Coord(i, j, k), value);
      }
  return grid;
}

std::string describe(const std::string& path, const std::string& gridName, int index) {
  return "OpenVDB file '" + path + "', grid '" + gridName + "'" +
         (index == 0 ? "" : " (index " + std::to_string(index) + ")");
}

/// The names under which OpenVDB finds the grids named `gridName` in `file`: the name itself
/// for one grid, "name[0]", "name[1]", … for several (asking for the bare name then warns).
std::vector<std::string> gridsNamed(const openvdb::io::File& file, const std::string& gridName) {
  std::vector<std::string> names;
  auto indexed = [&] { return gridName + "[" + std::to_string(names.size()) + "]"; };
  while (file.hasGrid(indexed())) names.push_back(indexed());
  if (names.empty() && file.hasGrid(gridName)) names.push_back(gridName);
  return names;
}

}  // namespace

uint64_t estimatedVdbFieldBytes(const std::string& path, const std::string& gridName, int index) {
  openvdb::initialize();
  std::error_code error;
  const uintmax_t fileBytes = std::filesystem::file_size(path, error);
  if (error) return 0;
  try {
    openvdb::io::File file(path);
    file.open(false);
    const std::vector<std::string> names = gridsNamed(file, gridName);
    if (index < 0 || size_t(index) >= names.size()) return 0;
    const openvdb::GridBase::ConstPtr grid = file.readGridMetadata(names[size_t(index)]);
    const auto memory =
        grid->getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_MEM_BYTES);
    if (memory && memory->value() > 0) return 2 * uint64_t(memory->value());
  } catch (const std::exception&) {
    return 0;
  }
  return 2 * uint64_t(fileBytes);
}

VdbFieldRead readVdbField(const std::string& path, const std::string& gridName, int index) {
  openvdb::initialize();
  const std::string what = describe(path, gridName, index);
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw VolumeFieldError(what + ": no such file");
  openvdb::io::File file(path);
  try {
    file.open(false);
  } catch (const std::exception& e) {
    throw VolumeFieldError(what + ": not an OpenVDB file (" + e.what() + ")");
  }
  const std::vector<std::string> names = gridsNamed(file, gridName);
  const int count = int(names.size());
  if (count == 0) {
    std::string others;
    for (auto name = file.beginName(); name != file.endName(); ++name)
      others += (others.empty() ? "" : ", ") + name.gridName();
    throw VolumeFieldError(what + ": no grid of that name (the file has " +
                           (others.empty() ? "no grids" : others) + ")");
  }
  if (index < 0 || index >= count)
    throw VolumeFieldError(what + ": index out of range, the file has " + std::to_string(count) +
                           " grid" + (count == 1 ? "" : "s") + " of that name");

  openvdb::GridBase::Ptr grid;
  try {
    grid = file.readGrid(names[size_t(index)]);
  } catch (const openvdb::ArithmeticError& e) {
    throw VolumeFieldError(what + ": singular transform (" + e.what() + ")");
  } catch (const std::exception& e) {
    throw VolumeFieldError(what + ": cannot be read (" + e.what() + ")");
  }
  VdbFieldRead read;
  read.valueType = grid->valueType();

  const openvdb::math::Transform& transform = grid->transform();
  if (!transform.isLinear())
    throw VolumeFieldError(what + ": non-affine transform (" + transform.mapType() + ")");
  Transform indexToObject;
  try {
    indexToObject =
        Transform::fromRowMajor(transform.baseMap()->getAffineMap()->getMat4().asPointer());
  } catch (const openvdb::ArithmeticError& e) {  // OpenVDB could not invert it
    throw VolumeFieldError(what + ": singular transform (" + e.what() + ")");
  }
  if (!invertible(indexToObject)) throw VolumeFieldError(what + ": singular transform");

  Repairs repairs;
  if (auto floats = openvdb::GridBase::grid<openvdb::FloatGrid>(grid))
    read.field = fieldOf(*repairedCopy<openvdb::FloatGrid>(*floats, repairs), indexToObject);
  else if (auto doubles = openvdb::GridBase::grid<openvdb::DoubleGrid>(grid))
    read.field = fieldOf(*repairedCopy<openvdb::FloatGrid>(*doubles, repairs), indexToObject);
  else if (auto vec3s = openvdb::GridBase::grid<openvdb::Vec3SGrid>(grid))
    read.field = fieldOf(*repairedCopy<openvdb::Vec3SGrid>(*vec3s, repairs), indexToObject);
  else if (auto vec3d = openvdb::GridBase::grid<openvdb::Vec3DGrid>(grid))
    read.field = fieldOf(*repairedCopy<openvdb::Vec3SGrid>(*vec3d, repairs), indexToObject);
  else
    throw VolumeFieldError(what + ": value type '" + read.valueType +
                           "' is neither a float scalar nor a float 3-vector");
  read.nonFiniteVoxels = repairs.nonFinite;
  read.negativeVoxels = repairs.negative;
  return read;
}

std::shared_ptr<const VolumeField> denseVdbField(int nx, int ny, int nz, int components,
                                                 const std::vector<float>& values,
                                                 const Transform& indexToObject) {
  requireDenseSizes(nx, ny, nz, components, values.size());
  if (!invertible(indexToObject))
    throw std::invalid_argument("a dense grid's index-to-object transform is singular");
  openvdb::initialize();
  Repairs repairs;
  if (components == 1)
    return fieldOf(*repairedCopy<openvdb::FloatGrid>(
                       *sparseGridOf<openvdb::FloatGrid>(nx, ny, nz, values), repairs),
                   indexToObject);
  return fieldOf(*repairedCopy<openvdb::Vec3SGrid>(
                     *sparseGridOf<openvdb::Vec3SGrid>(nx, ny, nz, values), repairs),
                 indexToObject);
}

void writeVdbFile(const std::string& path, const std::vector<VdbGridToWrite>& grids) {
  openvdb::initialize();
  openvdb::GridPtrVec vdbGrids;
  for (const VdbGridToWrite& grid : grids) {
    requireDenseSizes(grid.nx, grid.ny, grid.nz, grid.components, grid.values.size());
    if (!invertible(grid.indexToObject))
      throw std::invalid_argument("grid '" + grid.name + "' has a singular transform");
    openvdb::GridBase::Ptr vdbGrid;
    if (grid.components == 1)
      vdbGrid = sparseGridOf<openvdb::FloatGrid>(grid.nx, grid.ny, grid.nz, grid.values);
    else
      vdbGrid = sparseGridOf<openvdb::Vec3SGrid>(grid.nx, grid.ny, grid.nz, grid.values);
    vdbGrid->setName(grid.name);
    try {
      vdbGrid->setTransform(
          openvdb::math::Transform::createLinearTransform(toOpenVdb(grid.indexToObject)));
    } catch (const openvdb::ArithmeticError& e) {  // nearly singular by OpenVDB's measure
      throw std::invalid_argument("grid '" + grid.name + "' has a singular transform (" + e.what() +
                                  ")");
    }
    vdbGrids.push_back(vdbGrid);
  }
  // A uniquely named sibling, so that a reader never sees a half-written file.
  std::string temporary = path + ".partial-XXXXXX";
  const int descriptor = mkstemp(temporary.data());
  if (descriptor < 0)
    throw VolumeFieldError("OpenVDB file '" + path + "': cannot create a temporary file beside it");
  close(descriptor);
  try {
    openvdb::io::File(temporary).write(vdbGrids);
    std::filesystem::rename(temporary, path);
  } catch (const std::exception& e) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw VolumeFieldError("OpenVDB file '" + path + "': cannot be written (" + e.what() + ")");
  }
}

}  // namespace penumbra
