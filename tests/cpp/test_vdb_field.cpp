// VDB fields: trilinear sampling through the grid's transform, bounds, majorant bounds, vector
// grids, repairs of bad voxels, sparse memory, and every refused file with its message.
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "penumbra/vdb_field.h"
#include "scratch_directory.h"
#include "transforms.h"

using namespace penumbra;

namespace {

Transform rowMajor(std::initializer_list<double> values) {
  return Transform::fromRowMajor(std::data(values));
}

/// Scale 0.5 then a translation: voxel (i, j, k) at (10 + i / 2, 20 + j / 2, 30 + k / 2).
const Transform kScaleTranslate =
    rowMajor({0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 10, 20, 30, 1});
/// A quarter turn about z (x onto y), scale 2 and a translation.
const Transform kRotate = rowMajor({0, 2, 0, 0, -2, 0, 0, 0, 0, 0, 2, 0, 1, -3, 5, 1});

float sampleScalar(const VolumeField& field, const Vec3f& p) {
  float value = -1;
  field.sample(p, &value);
  return value;
}

/// The trilinear interpolation of the 2 × 2 × 2 block `v` (x fastest) at (x, y, z) in [0, 1]³.
float trilinear(const std::vector<float>& v, float x, float y, float z) {
  float result = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const float wx = corner & 1 ? x : 1 - x, wy = corner & 2 ? y : 1 - y,
                wz = corner & 4 ? z : 1 - z;
    result += wx * wy * wz * v[size_t(corner)];
  }
  return result;
}

const std::vector<float> kCube = {1, 7, 2, 5, 3, 11, 4, 0.5f};

class VdbFieldTest : public test::ScratchDirectoryTest {
 protected:
  /// Writes one grid named `name` and returns the file's path.
  std::string writeOne(const std::string& file, const VdbGridToWrite& grid) {
    writeVdbFile(path(file), {grid});
    return path(file);
  }
  /// Writes OpenVDB grids as they are (types writeVdbFile does not make).
  std::string writeRaw(const std::string& file, const openvdb::GridPtrVec& grids) {
    openvdb::initialize();
    openvdb::io::File(path(file)).write(grids);
    return path(file);
  }
  /// The message readVdbField throws, failing the test when it does not throw.
  static std::string errorOf(const std::string& file, const std::string& grid, int index = 0) {
    try {
      readVdbField(file, grid, index);
    } catch (const VolumeFieldError& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("'" + grid + "'"), std::string::npos) << e.what();
      return e.what();
    }
    ADD_FAILURE() << "reading grid " << grid << " of " << file << " did not throw";
    return {};
  }
};

TEST_F(VdbFieldTest, TrilinearAtCentresAndBetweenAndFadingOutside) {
  const VdbFieldRead read =
      readVdbField(writeOne("cube.vdb", {"density", 2, 2, 2, 1, kCube, {}}), "density");
  const VolumeField& field = *read.field;
  EXPECT_EQ(read.valueType, "float");
  EXPECT_EQ(field.components(), 1);
  EXPECT_EQ(field.activeVoxels(), 8u);
  for (int corner = 0; corner < 8; ++corner)
    EXPECT_FLOAT_EQ(sampleScalar(field, Vec3f(float(corner & 1), float((corner >> 1) & 1),
                                              float((corner >> 2) & 1))),
                    kCube[size_t(corner)]);
  for (const Vec3f& p :
       {Vec3f(0.5f, 0.5f, 0.5f), Vec3f(0.25f, 0.75f, 0.125f), Vec3f(0.9f, 0.1f, 0.6f)})
    EXPECT_NEAR(sampleScalar(field, p), trilinear(kCube, p.x, p.y, p.z), 1e-5f);
  // Half a voxel outside, halfway to the inactive (zero) neighbour; beyond the fringe, 0.
  EXPECT_NEAR(sampleScalar(field, Vec3f(-0.5f, 0, 0)), kCube[0] / 2, 1e-6f);
  EXPECT_EQ(sampleScalar(field, Vec3f(-1.5f, 0, 0)), 0.0f);
  EXPECT_EQ(sampleScalar(field, Vec3f(0, 0, 1e30f)), 0.0f);
  EXPECT_EQ(sampleScalar(field, Vec3f(NAN, 0, 0)), 0.0f);
}

TEST_F(VdbFieldTest, GridTransformMapsObjectPointsToIndexSpace) {
  for (const Transform& indexToObject : {kScaleTranslate, kRotate}) {
    const auto field =
        readVdbField(writeOne("cube.vdb", {"density", 2, 2, 2, 1, kCube, indexToObject}), "density")
            .field;
    for (const Vec3f& index :
         {Vec3f(0, 0, 0), Vec3f(1, 0, 1), Vec3f(0.25f, 0.75f, 0.125f), Vec3f(0.9f, 0.1f, 0.6f)})
      EXPECT_NEAR(sampleScalar(*field, indexToObject.applyToPoint(index)),
                  trilinear(kCube, index.x, index.y, index.z), 1e-5f);
    // The untransformed point of a voxel centre lies elsewhere.
    EXPECT_EQ(sampleScalar(*field, Vec3f(1, 1, 1)), 0.0f);
  }
}

TEST_F(VdbFieldTest, BoundsAreTheActiveVoxelsGrownByOneVoxelThroughTheTransform) {
  std::vector<float> values(5 * 5 * 5, 0.0f);
  values[2 + 5 * (3 + 5 * 4)] = 1;  // voxel (2, 3, 4)
  const auto scaled = denseVdbField(5, 5, 5, 1, values, kScaleTranslate);
  EXPECT_EQ(scaled->activeVoxels(), 1u);
  const Bounds3f box = scaled->objectBounds();
  EXPECT_FLOAT_EQ(box.lower.x, 10.5f);
  EXPECT_FLOAT_EQ(box.lower.y, 21.0f);
  EXPECT_FLOAT_EQ(box.lower.z, 31.5f);
  EXPECT_FLOAT_EQ(box.upper.x, 11.5f);
  EXPECT_FLOAT_EQ(box.upper.y, 22.0f);
  EXPECT_FLOAT_EQ(box.upper.z, 32.5f);
  // Rotated: index x runs along object y, index y along object -x.
  const Bounds3f rotated = denseVdbField(5, 5, 5, 1, values, kRotate)->objectBounds();
  EXPECT_FLOAT_EQ(rotated.lower.x, 1 - 2 * 4.0f);
  EXPECT_FLOAT_EQ(rotated.upper.x, 1 - 2 * 2.0f);
  EXPECT_FLOAT_EQ(rotated.lower.y, -3 + 2 * 1.0f);
  EXPECT_FLOAT_EQ(rotated.upper.y, -3 + 2 * 3.0f);
  EXPECT_FLOAT_EQ(rotated.lower.z, 5 + 2 * 3.0f);
  EXPECT_FLOAT_EQ(rotated.upper.z, 5 + 2 * 5.0f);
  EXPECT_TRUE(denseVdbField(5, 5, 5, 1, std::vector<float>(125, 0.0f), {})->objectBounds().empty());
}

TEST_F(VdbFieldTest, MaxInBoundsEverySampleInRandomBoxesAndIsTightForOneHotVoxel) {
  constexpr int kSize = 40;
  std::mt19937 random(7);
  std::uniform_real_distribution<float> unit(0, 1);
  std::vector<float> values(kSize * kSize * kSize, 0.0f);
  for (float& v : values)
    if (unit(random) < 0.2f) v = 10 * unit(random);
  const auto field = denseVdbField(kSize, kSize, kSize, 1, values, kRotate);
  for (int box = 0; box < 200; ++box) {
    Bounds3f indexBox;
    const float size = 0.5f + 12 * unit(random);
    const Vec3f corner(-3 + (kSize + 3) * unit(random), -3 + (kSize + 3) * unit(random),
                       -3 + (kSize + 3) * unit(random));
    indexBox.extend(corner);
    indexBox.extend(corner + Vec3f(size));
    Bounds3f objectBox;
    for (int c = 0; c < 8; ++c)
      objectBox.extend(kRotate.applyToPoint(Vec3f(c & 1 ? indexBox.upper.x : indexBox.lower.x,
                                                  c & 2 ? indexBox.upper.y : indexBox.lower.y,
                                                  c & 4 ? indexBox.upper.z : indexBox.lower.z)));
    const float bound = field->maxIn(objectBox);
    for (int s = 0; s < 200; ++s) {
      const Vec3f p = objectBox.lower + (objectBox.upper - objectBox.lower) *
                                            Vec3f(unit(random), unit(random), unit(random));
      ASSERT_LE(sampleScalar(*field, p), bound) << "box " << box;
    }
  }
  std::vector<float> hot(kSize * kSize * kSize, 0.0f);
  hot[17 + kSize * (3 + kSize * 29)] = 4.5f;   // voxel (17, 3, 29)
  hot[30 + kSize * (30 + kSize * 30)] = 9.0f;  // voxel (30, 30, 30), far from the box below
  const auto hotField = denseVdbField(kSize, kSize, kSize, 1, hot, kScaleTranslate);
  const Vec3f centre = kScaleTranslate.applyToPoint(Vec3f(17, 3, 29));
  Bounds3f around;
  around.extend(centre - Vec3f(0.1f));
  around.extend(centre + Vec3f(0.1f));
  EXPECT_FLOAT_EQ(hotField->maxIn(around), 4.5f);
  EXPECT_FLOAT_EQ(sampleScalar(*hotField, centre), 4.5f);
  EXPECT_FLOAT_EQ(hotField->maxIn({Vec3f(-kInfinity), Vec3f(kInfinity)}), 9.0f);
  EXPECT_EQ(hotField->maxIn({Vec3f(-100), Vec3f(-90)}), 0.0f);
  EXPECT_EQ(hotField->maxIn(Bounds3f{}), 0.0f);
}

TEST_F(VdbFieldTest, Vec3GridsSampleEachComponentAndBoundTheLargest) {
  const VdbFieldRead read = readVdbField(
      writeOne("velocity.vdb", {"vel", 2, 1, 1, 3, {1, 2, 3, 3, -2, 1}, kScaleTranslate}), "vel");
  EXPECT_EQ(read.valueType, "vec3s");
  ASSERT_EQ(read.field->components(), 3);
  float value[3];
  read.field->sample(kScaleTranslate.applyToPoint(Vec3f(0.25f, 0, 0)), value);
  EXPECT_FLOAT_EQ(value[0], 1.5f);
  // Fields are densities, colours and emission: the −2 component reads as 0, and is counted.
  EXPECT_FLOAT_EQ(value[1], 1.5f);
  EXPECT_FLOAT_EQ(value[2], 2.5f);
  EXPECT_FLOAT_EQ(read.field->maxIn(read.field->objectBounds()), 3.0f);
  EXPECT_EQ(read.negativeVoxels, 1u);
}

TEST_F(VdbFieldTest, DoubleHalfAndVec3dGridsAreRead) {
  auto doubles = openvdb::DoubleGrid::create(0.0);
  doubles->setName("density");
  doubles->tree().setValue(openvdb::Coord(1, 2, 3), 2.5);
  auto halves = openvdb::FloatGrid::create(0.0f);
  halves->setName("temperature");
  halves->setSaveFloatAsHalf(true);
  halves->tree().setValue(openvdb::Coord(1, 2, 3), 1.5f);
  auto vectors = openvdb::Vec3DGrid::create();
  vectors->setName("Cd");
  vectors->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3d(0.25, 0.5, 0.75));
  const std::string file = writeRaw("types.vdb", {doubles, halves, vectors});
  const VdbFieldRead density = readVdbField(file, "density");
  EXPECT_EQ(density.valueType, "double");
  EXPECT_FLOAT_EQ(sampleScalar(*density.field, Vec3f(1, 2, 3)), 2.5f);
  EXPECT_FLOAT_EQ(sampleScalar(*readVdbField(file, "temperature").field, Vec3f(1, 2, 3)), 1.5f);
  const VdbFieldRead colour = readVdbField(file, "Cd");
  EXPECT_EQ(colour.valueType, "vec3d");
  float value[3];
  colour.field->sample(Vec3f(1, 2, 3), value);
  EXPECT_FLOAT_EQ(value[2], 0.75f);
}

TEST_F(VdbFieldTest, AnInt32GridBesideAFloatGridDoesNotStopReadingIt) {
  auto flags = openvdb::Int32Grid::create(0);
  flags->setName("flags");
  flags->tree().setValue(openvdb::Coord(0, 0, 0), 3);
  auto density = openvdb::FloatGrid::create(0.0f);
  density->setName("density");
  density->tree().setValue(openvdb::Coord(0, 0, 0), 0.75f);
  const std::string file = writeRaw("houdini.vdb", {flags, density});
  EXPECT_FLOAT_EQ(sampleScalar(*readVdbField(file, "density").field, Vec3f(0, 0, 0)), 0.75f);
  EXPECT_NE(errorOf(file, "flags").find("int32"), std::string::npos);
}

TEST_F(VdbFieldTest, ActiveTilesAreSampledAndBoundedWithoutBeingSplitIntoVoxels) {
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("density");
  grid->tree().addTile(1, openvdb::Coord(0), 2.0f, true);           // 8³ voxels from the origin
  grid->tree().addTile(2, openvdb::Coord(128, 0, 0), -1.0f, true);  // 128³ negative voxels
  grid->tree().setValue(openvdb::Coord(300, 0, 0), 5.0f);
  const VdbFieldRead read = readVdbField(writeRaw("tiles.vdb", {grid}), "density");
  const VolumeField& field = *read.field;
  EXPECT_EQ(field.activeVoxels(), 512u + 128u * 128u * 128u + 1u);
  EXPECT_EQ(read.negativeVoxels, 128u * 128u * 128u);
  EXPECT_FLOAT_EQ(sampleScalar(field, Vec3f(3.5f, 7, 0.25f)), 2.0f);
  EXPECT_FLOAT_EQ(sampleScalar(field, Vec3f(7.5f, 0, 0)), 1.0f);  // fading into inactive 0
  EXPECT_EQ(sampleScalar(field, Vec3f(200, 5, 5)), 0.0f);
  EXPECT_FLOAT_EQ(field.maxIn({Vec3f(1), Vec3f(2)}), 2.0f);
  EXPECT_EQ(field.maxIn({Vec3f(150, 10, 10), Vec3f(250, 20, 20)}), 0.0f);
  EXPECT_FLOAT_EQ(field.maxIn({Vec3f(-kInfinity), Vec3f(kInfinity)}), 5.0f);
  EXPECT_LT(field.memoryBytes(), size_t(1) << 20);  // 2 million tile voxels, not stored apart
}

TEST_F(VdbFieldTest, GridsOfTheSameNameAreReadByIndex) {
  const std::string file = path("two.vdb");
  writeVdbFile(file, {{"density", 1, 1, 1, 1, {2}, {}}, {"density", 1, 1, 1, 1, {5}, {}}});
  EXPECT_FLOAT_EQ(sampleScalar(*readVdbField(file, "density", 0).field, Vec3f(0)), 2.0f);
  EXPECT_FLOAT_EQ(sampleScalar(*readVdbField(file, "density", 1).field, Vec3f(0)), 5.0f);
  const std::string message = errorOf(file, "density", 2);
  EXPECT_NE(message.find("out of range"), std::string::npos) << message;
  EXPECT_NE(message.find("2 grids"), std::string::npos) << message;
  EXPECT_NE(errorOf(file, "density", -1).find("out of range"), std::string::npos);
}

TEST_F(VdbFieldTest, RefusedFilesAndGridsSayWhatIsWrong) {
  EXPECT_NE(errorOf(path("absent.vdb"), "density").find("no such file"), std::string::npos);
  std::ofstream(path("text.vdb")) << "not a grid\n";
  EXPECT_NE(errorOf(path("text.vdb"), "density").find("not an OpenVDB file"), std::string::npos);
  const std::string cube = writeOne("cube.vdb", {"density", 2, 2, 2, 1, kCube, {}});
  const std::string missing = errorOf(cube, "smoke");
  EXPECT_NE(missing.find("no grid of that name"), std::string::npos) << missing;
  EXPECT_NE(missing.find("density"), std::string::npos) << missing;  // lists what there is

  auto flags = openvdb::BoolGrid::create(false);
  flags->setName("flags");
  flags->tree().setValue(openvdb::Coord(0), true);
  auto mask = openvdb::MaskGrid::create();
  mask->setName("mask");
  mask->tree().setValueOn(openvdb::Coord(0));
  auto indices = openvdb::Vec3IGrid::create();
  indices->setName("indices");
  const std::string types = writeRaw("types.vdb", {flags, mask, indices});
  EXPECT_NE(errorOf(types, "flags").find("'bool'"), std::string::npos);
  EXPECT_NE(errorOf(types, "mask").find("'mask'"), std::string::npos);
  EXPECT_NE(errorOf(types, "indices").find("'vec3i'"), std::string::npos);

  auto frustum = openvdb::FloatGrid::create(0.0f);
  frustum->setName("density");
  frustum->setTransform(openvdb::math::Transform::createFrustumTransform(
      openvdb::BBoxd(openvdb::Vec3d(0), openvdb::Vec3d(10)), 0.5, 2.0));
  const std::string frustumMessage = errorOf(writeRaw("frustum.vdb", {frustum}), "density");
  EXPECT_NE(frustumMessage.find("non-affine"), std::string::npos) << frustumMessage;
}

TEST_F(VdbFieldTest, ASingularTransformInAFileIsRefused) {
  // OpenVDB will not write a singular map: write a distinctive scale and zero it in the bytes.
  const double scale = 0.123456789;
  const std::string file = writeOne(
      "flat.vdb", {"density", 2, 2, 2, 1, kCube,
                   rowMajor({scale, 0, 0, 0, 0, scale, 0, 0, 0, 0, scale, 0, 0, 0, 0, 1})});
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  char pattern[sizeof(double)];
  std::memcpy(pattern, &scale, sizeof(double));
  const size_t at = bytes.find(std::string(pattern, sizeof(double)));
  ASSERT_NE(at, std::string::npos);
  std::memset(&bytes[at], 0, sizeof(double));  // the first scale: x collapses
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  const std::string message = errorOf(file, "density");
  EXPECT_NE(message.find("singular"), std::string::npos) << message;
}

TEST_F(VdbFieldTest, NonFiniteAndNegativeVoxelsReadAsZeroAndAreCounted) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const VdbFieldRead read = readVdbField(
      writeOne("bad.vdb", {"density", 5, 1, 1, 1, {nan, 1, -2, kInfinity, -0.5f}, {}}), "density");
  EXPECT_EQ(read.nonFiniteVoxels, 2u);
  EXPECT_EQ(read.negativeVoxels, 2u);
  for (int i : {0, 2, 3, 4}) EXPECT_EQ(sampleScalar(*read.field, Vec3f(float(i), 0, 0)), 0.0f);
  EXPECT_FLOAT_EQ(sampleScalar(*read.field, Vec3f(1, 0, 0)), 1.0f);
  EXPECT_FLOAT_EQ(sampleScalar(*read.field, Vec3f(1.5f, 0, 0)), 0.5f);
  EXPECT_FLOAT_EQ(read.field->maxIn(read.field->objectBounds()), 1.0f);
}

TEST_F(VdbFieldTest, DoublesBeyondSinglePrecisionAreNonFiniteVoxels) {
  // Held as floats, they became infinities the free flights made NaN pixels of.
  auto doubles = openvdb::DoubleGrid::create(0.0);
  doubles->setName("density");
  doubles->tree().setValue(openvdb::Coord(0, 0, 0), 1e300);
  doubles->tree().setValue(openvdb::Coord(1, 0, 0), 2.0);
  const VdbFieldRead read = readVdbField(writeRaw("huge.vdb", {doubles}), "density");
  EXPECT_EQ(read.nonFiniteVoxels, 1u);
  EXPECT_EQ(sampleScalar(*read.field, Vec3f(0, 0, 0)), 0.0f);
  EXPECT_FLOAT_EQ(sampleScalar(*read.field, Vec3f(1, 0, 0)), 2.0f);
}

TEST_F(VdbFieldTest, MemoryGrowsWithActiveVoxelsNotWithTheBoundingBox) {
  auto sparseGrid = [&](const openvdb::Coord& second) {
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->tree().setValue(openvdb::Coord(0), 1.0f);
    grid->tree().setValue(second, 1.0f);
    return readVdbField(writeRaw("pair.vdb", {grid}), "density").field;
  };
  const auto adjacent = sparseGrid(openvdb::Coord(1, 0, 0));
  const auto farApart = sparseGrid(openvdb::Coord(3000, -2000, 5000));
  EXPECT_EQ(farApart->activeVoxels(), 2u);
  EXPECT_LT(farApart->objectBounds().upper.z, 5001.5f);
  EXPECT_GT(farApart->objectBounds().upper.z, 5000.5f);
  // Two voxels apart need their own leaves and internal nodes, still far below one byte per
  // voxel of the ~3e10-voxel box.
  EXPECT_LT(farApart->memoryBytes(), 5 * adjacent->memoryBytes());
  EXPECT_LT(farApart->memoryBytes(), size_t(1) << 20);
  EXPECT_FLOAT_EQ(sampleScalar(*farApart, Vec3f(3000, -2000, 5000)), 1.0f);

  constexpr int kDense = 64;
  const auto dense = denseVdbField(kDense, kDense, kDense, 1,
                                   std::vector<float>(kDense * kDense * kDense, 1.0f), {});
  ASSERT_EQ(dense->activeVoxels(), uint64_t(kDense) * kDense * kDense);
  const double bytesPerVoxel = double(dense->memoryBytes()) / double(dense->activeVoxels());
  std::cout << "dense 64^3 float block: " << dense->memoryBytes() << " bytes, " << bytesPerVoxel
            << " bytes per active voxel\n";
  RecordProperty("bytes_per_voxel_dense_64", std::to_string(bytesPerVoxel));
  EXPECT_LT(bytesPerVoxel, 6.0);  // 4 bytes a value plus leaf masks and internal nodes
  EXPECT_GT(bytesPerVoxel, 4.0);
}

TEST_F(VdbFieldTest, ThreadsSampleConcurrentlyAlike) {
  const auto field = denseVdbField(2, 2, 2, 1, kCube, kRotate);
  std::vector<float> results(4 * 1000);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int s = 0; s < 1000; ++s)
        field->sample(kRotate.applyToPoint(Vec3f(s / 1000.0f, 0.5f, 0.25f)),
                      &results[size_t(t * 1000 + s)]);
    });
  for (std::thread& thread : threads) thread.join();
  for (int s = 0; s < 1000; ++s) {
    EXPECT_NEAR(results[size_t(s)], trilinear(kCube, s / 1000.0f, 0.5f, 0.25f), 1e-5f);
    for (int t = 1; t < 4; ++t) ASSERT_EQ(results[size_t(t * 1000 + s)], results[size_t(s)]);
  }
}

TEST_F(VdbFieldTest, WritingIsAtomicAndRefusesMismatchedGrids) {
  const std::string file = writeOne("cube.vdb", {"density", 2, 2, 2, 1, kCube, {}});
  EXPECT_THROW(writeVdbFile(file, {{"density", 2, 2, 2, 1, {1, 2, 3}, {}}}), std::invalid_argument);
  EXPECT_THROW(writeVdbFile(file, {{"density", 1, 1, 1, 2, {1, 2}, {}}}), std::invalid_argument);
  EXPECT_THROW(writeVdbFile(file, {{"density",
                                    1,
                                    1,
                                    1,
                                    1,
                                    {1},
                                    rowMajor({1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1})}}),
               std::invalid_argument);
  EXPECT_THROW(writeVdbFile(path("absent/cube.vdb"), {{"density", 1, 1, 1, 1, {1}, {}}}),
               VolumeFieldError);
  // The file written first is untouched, and nothing else is left in the directory.
  EXPECT_FLOAT_EQ(sampleScalar(*readVdbField(file, "density").field, Vec3f(1, 1, 1)), kCube[7]);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(directory_),
                          std::filesystem::directory_iterator()),
            1);
  EXPECT_THROW(denseVdbField(2, 2, 1, 1, kCube, {}), std::invalid_argument);
}

TEST_F(VdbFieldTest, TheReadEstimateCoversWhatAConstantGridHolds) {
  // A dense 64³ block of one value compresses to a small file but holds every voxel once read:
  // the estimate comes from the grid's size in memory (OpenVDB's metadata), not the file's.
  const int n = 64;
  const std::string file = writeOne(
      "constant.vdb", {"density", n, n, n, 1, std::vector<float>(size_t(n * n * n), 0.5f), {}});
  const uint64_t estimate = estimatedVdbFieldBytes(file, "density");
  const size_t held = readVdbField(file, "density").field->memoryBytes();
  EXPECT_GE(estimate, uint64_t(held));
  EXPECT_LE(estimate, uint64_t(4 * held));
  EXPECT_GT(estimate, 2 * std::filesystem::file_size(file));
  EXPECT_EQ(estimatedVdbFieldBytes(file, "temperature"), 0u);  // no such grid
  EXPECT_EQ(estimatedVdbFieldBytes(path("absent.vdb"), "density"), 0u);
}

}  // namespace
