// Polygon meshes as the renderer receives them (plain arrays, USD conventions), and their
// triangulation.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/math.h"

namespace penumbra {

/// How a per-mesh value array maps onto the surface (UsdGeom primvar interpolation). Varying
/// and vertex differ only on subdivision surfaces (linear versus limit evaluation).
enum class Interpolation { Constant, Uniform, Varying, Vertex, FaceVarying };

/// A primvar's name and a 64-bit key (FNV-1a) computed once, where the name is set at sync, so
/// that the lookups made at every hit compare integers instead of strings. Equal keys are taken
/// as equal names: MaterialTable rejects two names of one key wherever names enter it (a chance of
/// about n²/2⁶⁵ for n distinct names).
class PrimvarName {
 public:
  PrimvarName() = default;
  // Explicit from a string, so that a hot path cannot hash a name on every call unawares.
  explicit PrimvarName(std::string name);
  PrimvarName(const char* name) : PrimvarName(std::string(name)) {}  // NOLINT: literals in code

  const std::string& str() const { return name_; }
  uint64_t key() const { return key_; }
  bool empty() const { return name_.empty(); }
  bool operator==(const PrimvarName& other) const { return key_ == other.key_; }
  bool operator!=(const PrimvarName& other) const { return key_ != other.key_; }

 private:
  std::string name_;
  uint64_t key_ = kEmptyKey;
  static constexpr uint64_t kEmptyKey = 14695981039346656037ull;  // FNV-1a of no bytes
};

/// The name primvar lookups know a mesh's displayColor by (it is kept apart from its primvars).
inline const PrimvarName& displayColorName() {
  static const PrimvarName name("displayColor");
  return name;
}

/// A named per-mesh value array besides points, normals and displayColor (e.g. `st`, or any
/// primvar a material reads): `width` floats per element, as many elements as `interpolation`
/// says. Indexed primvars arrive flattened.
struct Primvar {
  PrimvarName name;
  std::vector<float> values;
  int width = 1;  // 1 to 4
  Interpolation interpolation = Interpolation::Vertex;
};

struct MeshData {
  std::vector<Vec3f> points;
  /// Deformation motion: the points at later, uniformly spaced shutter times (steps 1..K-1;
  /// `points` is step 0). Empty for static meshes.
  std::vector<std::vector<Vec3f>> pointMotion;
  std::vector<int> faceVertexCounts;
  std::vector<int> faceVertexIndices;
  bool leftHanded = false;  // orientation: leftHanded reverses the winding that faces front
  bool doubleSided = false;
  std::vector<Vec3f> displayColor;  // empty: none authored
  Interpolation displayColorInterpolation = Interpolation::Constant;
  std::vector<Vec3f> normals;  // authored shading normals; empty: flat shading
  Interpolation normalsInterpolation = Interpolation::Vertex;
  std::vector<Primvar> primvars;
};

/// A triangulated mesh ready for Embree. Triangles are fans of each polygon, wound so that the
/// front face is counter-clockwise in a right-handed frame.
struct TriangleMesh {
  std::vector<Vec3f> points;
  std::vector<std::vector<Vec3f>> pointMotion;  // as in MeshData
  std::vector<uint32_t> triangles;              // 3 point indices per triangle
  // Per triangle: the polygon it came from and the face-vertex positions of its 3 corners (for
  // uniform and faceVarying data).
  std::vector<uint32_t> sourceFace;
  std::vector<uint32_t> cornerFaceVertex;
  bool doubleSided = false;
  /// The mesh bounds a solid (isClosedSurface): translucent materials refract into it unless
  /// they say they are thin-walled; open meshes are thin sheets unless their material says
  /// otherwise.
  bool closed = false;
  /// Shading normals (authored, or subdivision limit normals per point); empty: flat.
  std::vector<Vec3f> normals;
  Interpolation normalsInterpolation = Interpolation::Vertex;
  std::vector<Vec3f> displayColor;
  Interpolation displayColorInterpolation = Interpolation::Constant;
  /// The cage's primvars, their values mapped onto the triangles as for displayColor.
  std::vector<Primvar> primvars;

  /// Corner `corner` (0..2) of `triangle` at normalised shutter time `time`.
  Vec3f cornerAt(uint32_t triangle, int corner, float time) const;

  /// A primvar at a point on triangle `triangle` with barycentrics (u, v) as Embree gives them
  /// (weights 1-u-v, u, v for corners 0, 1, 2); `values` must not be empty.
  Vec3f interpolate(const std::vector<Vec3f>& values, Interpolation interpolation,
                    uint32_t triangle, float u, float v) const;
  /// A primvar at a point of a triangle: writes primvar.width floats to `out`.
  void interpolate(const Primvar& primvar, uint32_t triangle, float u, float v, float* out) const;
  /// Where corner `corner` (0..2) of `triangle` finds its value in data of this interpolation.
  size_t cornerElement(Interpolation interpolation, uint32_t triangle, int corner) const;
  /// The primvar named `name`, or null.
  const Primvar* findPrimvar(const PrimvarName& name) const;
};

/// USD's token for an interpolation ("faceVarying", ...).
const char* interpolationName(Interpolation interpolation);
/// How many values a primvar of this interpolation has on `mesh`.
size_t primvarElementCount(Interpolation interpolation, const MeshData& mesh);

/// The primvar named `name` in `primvars`, or null.
const Primvar* findPrimvar(const std::vector<Primvar>& primvars, const PrimvarName& name);

/// Throws std::invalid_argument naming the primvar when its width or value count does not fit
/// `mesh`.
void validatePrimvar(const Primvar& primvar, const MeshData& mesh);

/// Throws std::invalid_argument naming `name` and the index of the first point that is not
/// finite.
void requireFinite(const std::vector<Vec3f>& points, const std::string& name);

/// Throws std::invalid_argument unless every later motion step in `steps` has `count` finite
/// points; a step is named `stepName` and its number ("points at motion sample 1").
void requireMotionSteps(const std::vector<std::vector<Vec3f>>& steps, size_t count,
                        const std::string& stepName);

/// Points closer than this fraction of a mesh's largest extent are one point when deciding
/// whether the mesh is closed.
constexpr float kWeldTolerance = 1e-5f;

/// For each point, the index of the first point within `tolerance` of it that represents its
/// group (itself when there is none before it).
std::vector<int> weldPoints(const std::vector<Vec3f>& points, float tolerance);

/// Whether the polygon mesh bounds a solid: every edge is shared by an even number of faces
/// (exactly two for a manifold surface), by its indices or, failing that, once points within
/// kWeldTolerance of the mesh's size are welded (split vertices at UV seams, hard edges or
/// poles) and faces of zero area (thinner than that tolerance) are ignored.
/// `holes`: faces that have no surface (a subdivision surface's holeIndices), left out; indices
/// out of range are ignored.
bool isClosedSurface(const std::vector<Vec3f>& points, const std::vector<int>& faceVertexCounts,
                     const std::vector<int>& faceVertexIndices, const std::vector<int>& holes = {});

/// Validates and triangulates. Throws std::invalid_argument with a message saying what is wrong
/// (counts that do not add up, indices out of range, primvar sizes, non-finite points).
TriangleMesh triangulate(const MeshData& mesh);

/// Bytes that building `mesh` for rendering allocates at its peak (triangulation, Embree's
/// buffers and BVH, the closed-surface test), estimated from its counts before anything is
/// built, for memory budgets. A subdivision surface (`subdivided`) is counted as diced once,
/// a lower bound: dicing finer multiplies its size by 4 per level.
size_t estimatedBuildBytes(const MeshData& mesh, bool subdivided);

/// Bytes of the same for `copies` instances of a prototype, with `motionKeys` transforms each.
size_t estimatedInstanceBytes(size_t copies, size_t motionKeys);

}  // namespace penumbra
