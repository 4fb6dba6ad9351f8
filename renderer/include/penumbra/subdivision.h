// Subdivision surfaces: the limit surface of a control cage (OpenSubdiv feature-adaptive patches),
// diced into triangles at a rate chosen per face.
//
// Penumbra renders the limit surface at every complexity, as final-frame renderers do. The cage's
// topology is refined once (LimitSurfaceTessellator); each set of point positions (every motion
// sample) is then evaluated on the same patches, so deforming meshes keep one triangle topology.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/math.h"
#include "penumbra/mesh.h"

namespace penumbra {

enum class SubdivisionScheme { CatmullClark, Loop, Bilinear };

/// UsdGeomMesh's subdivision attributes, with USD's token values and defaults.
struct SubdivisionTags {
  std::string interpolateBoundary = "edgeAndCorner";  // none | edgeOnly | edgeAndCorner
  // none | cornersOnly | cornersPlus1 | cornersPlus2 | boundaries | all
  std::string faceVaryingLinearInterpolation = "cornersPlus1";
  std::string triangleSubdivisionRule = "catmullClark";  // catmullClark | smooth
  std::vector<int> holeIndices;                          // faces without a surface
  std::vector<int> cornerIndices;                        // vertices
  std::vector<float> cornerSharpnesses;                  // one per corner index
  std::vector<int> creaseIndices;                        // vertex chains, one after another
  std::vector<int> creaseLengths;                        // vertices per chain (>= 2)
  // One per crease, or one per crease edge (sum of creaseLengths[i] - 1), as USD allows.
  // Sharpness >= 10 is infinitely sharp.
  std::vector<float> creaseSharpnesses;
};

/// The tags of `tags` that fit `cage`, as Hydra's refiner factory keeps them: a hole or corner
/// out of range, a corner or crease whose sharpness is not finite, and a crease chain with a
/// vertex out of range or a pair of vertices that is not an edge of the cage are left out (every
/// crease when creaseLengths and creaseSharpnesses do not describe creaseIndices; every corner
/// when cornerSharpnesses are not one per corner). *dropped gets one phrase for each thing left
/// out, naming the attribute and the entry. The cage's own topology is not checked here.
SubdivisionTags usableSubdivisionTags(const MeshData& cage, const SubdivisionTags& tags,
                                      std::vector<std::string>* dropped);

/// Parses a UsdGeomMesh subdivisionScheme token: "catmullClark", "loop", "bilinear"; "none"
/// (a plain polygon mesh) gives nullopt. Throws std::invalid_argument for any other token.
std::optional<SubdivisionScheme> parseSubdivisionScheme(const std::string& token);

/// The limit surface at one parametric location of a base face.
struct LimitSample {
  Vec3f position;
  Vec3f dPdu, dPdv;
  Vec3f normal;  // unit, on the front side (leftHanded honoured)
};

/// Refines a cage's topology once and tessellates its limit surface for any point positions.
///
/// Output (a TriangleMesh, as triangulate() gives for polygon meshes):
/// - points: limit positions; normals: limit normals, one per point. Points are shared between
///   faces (watertight: a shared edge is diced once, at the finer of its faces' rates) except
///   along infinitely sharp creases and corners, where each face keeps its own copy (same
///   position, its own normal) so that the crease stays sharp in shading.
/// - triangles wound front = counter-clockwise in a right-handed frame (leftHanded honoured);
///   sourceFace = the base face each triangle tessellates.
/// - cornerFaceVertex: per triangle corner, an index into the output face-varying arrays, which
///   hold one value per tessellation vertex of every face (faces do not share them, so seams in
///   face-varying data stay seams).
/// - displayColor: constant as authored; uniform per base face; vertex evaluated on the limit
///   surface, one per output point; faceVarying evaluated on its own channel with
///   faceVaryingLinearInterpolation (face-vertex values that agree at a vertex are welded, so the
///   colour is smooth there; values that differ make a seam).
///
/// Hole faces and faces without a limit surface (interpolateBoundary "none" at the boundary) are
/// left out. Faces of the "wrong" shape (non-quads for Catmull-Clark and bilinear) are diced as
/// OpenSubdiv parameterises them: as quad sub-faces, so their rate is rounded up to even.
class LimitSurfaceTessellator {
 public:
  /// Validates the cage and the tags (throws std::invalid_argument saying what is wrong), builds
  /// the feature-adaptive patch table and refines the primvars (which do not vary with time).
  /// Only `cage.points` varies between motion samples; the rest is the topology.
  LimitSurfaceTessellator(const MeshData& cage, SubdivisionScheme scheme,
                          const SubdivisionTags& tags);
  ~LimitSurfaceTessellator();
  LimitSurfaceTessellator(LimitSurfaceTessellator&&) noexcept;
  LimitSurfaceTessellator& operator=(LimitSurfaceTessellator&&) noexcept;

  size_t faceCount() const;

  /// Per base face, a bound M (world units) on the limit surface's second derivative over the
  /// face's parameterisation scaled to one segment per edge, such that a tessellation at rate N
  /// deviates from the limit surface by at most M / (4 N^2) (see tessellationRateFor). Sampled
  /// on every patch of the face; 0 for faces without a surface.
  std::vector<float> curvatureBounds(const std::vector<Vec3f>& points) const;

  /// Tessellates the limit surface of the cage at `points` (same count as the cage's).
  /// `rates`: segments per edge (>= 1), one per base face or a single one for all. The same
  /// rates give the same triangles, sourceFace and cornerFaceVertex for any points, so motion
  /// samples line up. The cage's primvars come out evaluated, as displayColor does: constant and
  /// uniform as authored, vertex and varying (then marked vertex) one per output point,
  /// faceVarying one per output face-varying slot (see cornerFaceVertex).
  TriangleMesh tessellate(const std::vector<Vec3f>& points, const std::vector<int>& rates) const;

  /// The limit surface of base face `face` at `points`, at (u, v) in the face's parameterisation
  /// (OpenSubdiv Bfr: the unit square for quads, the unit triangle for Loop triangles, quad
  /// sub-faces for other polygons). Throws std::invalid_argument for a face without a surface.
  std::vector<LimitSample> evaluate(const std::vector<Vec3f>& points, int face,
                                    const std::vector<Vec2f>& faceCoords) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;  // keeps OpenSubdiv out of this header
};

/// Largest rate tessellationRateFor returns: 64 segments per edge (4096 quads' worth of
/// triangles per face) bounds memory when a face fills the screen.
constexpr int kMaxTessellationRate = 64;

/// Segments per edge that keep a face within `tolerance` (world units, > 0) of its limit
/// surface, given its curvatureBounds() value M: the linear interpolation error over a
/// right-isoceles triangle with legs h (parameter units) is at most M h^2 / 4, so
/// N = ceil(sqrt(M / (4 tolerance))), clamped to [1, kMaxTessellationRate]. The bound is
/// conservative: on a Catmull-Clark cube the measured error is a quarter of the tolerance.
int tessellationRateFor(float curvatureBound, float tolerance);

/// One-shot convenience: LimitSurfaceTessellator(cage, scheme, tags).tessellate(cage.points,
/// rates).
TriangleMesh tessellateLimitSurface(const MeshData& cage, SubdivisionScheme scheme,
                                    const SubdivisionTags& tags, const std::vector<int>& rates);

}  // namespace penumbra
