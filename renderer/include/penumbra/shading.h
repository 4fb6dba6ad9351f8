// Evaluating a material's shader network at a point of a surface: primvar readers, UsdUVTexture
// lookups filtered over the ray's footprint (through UsdTransform2d), normal maps.
#pragma once

#include "penumbra/material.h"
#include "penumbra/mesh.h"
#include "penumbra/texture.h"

namespace penumbra {

class Shape;

/// A point of a surface as shading needs it. Positions and normals in world space.
struct SurfacePoint {
  const Shape* shape = nullptr;  // the kind of geometry that knows its primvars (shape.h)
  uint32_t primitive = 0;        // Embree's primID in the shape's geometry
  /// Where on the primitive: weights 1-u-v, u, v of corners 0, 1, 2 (Embree's barycentrics on
  /// a triangle).
  float u = 0, v = 0;
  /// The primitive's parametrisation at the ray's time, for texture-coordinate differentials
  /// and tangents: a triangle's corners; three times the same point where a kind has none
  /// (textures are then point-sampled).
  Vec3f corners[3];
  Vec3f normal;         // unit geometric normal
  Vec3f shadingNormal;  // unit interpolated normal, on the same side as `normal`
  /// The ray footprint: how the point moves on the surface for one pixel of image x and y
  /// (zero: point-sampled lookups).
  Vec3f dpdx{0.0f}, dpdy{0.0f};
  /// For instancer copies: the instancer's per-copy primvars (one value per copy, overriding the
  /// shape's primvars of the same name; NaN as a copy's first value: it has none, the shape's
  /// applies) and this copy's index.
  const std::vector<Primvar>* instancePrimvars = nullptr;
  uint32_t instance = 0;
};

/// Primvar `name` at `point`: the copy's own value, else the shape's (displayColor included).
/// Writes up to 4 floats and their count; false when neither has it.
bool primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4], int* width);

/// The ray footprint on a surface: a ray cone of radius `radius` at the point, arriving along
/// `direction`, laid on the plane of `normal` (stretched along the direction's projection by
/// 1/|cos θ|, capped at a grazing 1/0.05).
void footprintOnSurface(const Vec3f& direction, const Vec3f& normal, float radius, Vec3f* dpdx,
                        Vec3f* dpdy);

/// The material's parameters at `point`: its constants with every connected input replaced by
/// the value of its network there. A normal map bends `*shadingNormal` (unit, kept on the side of
/// the geometric normal).
MaterialParams evaluateMaterial(const Material& material, const TextureSystem& textures,
                                const SurfacePoint& point, Vec3f* shadingNormal);

/// The direction anisotropic lobes stretch along at `point` (world space, not normalised): the
/// mesh's `tangent` primvar (object space, mapped by `objectToWorld`) where it has one, else
/// ∂P/∂s of its `st` texture coordinates, else zero (the BSDF then picks a fixed tangent).
/// Needs point.corners.
Vec3f surfaceTangent(const SurfacePoint& point, const Transform& objectToWorld);

/// Just the opacity at `point` (for cut-outs, decided while tracing; point-sampled).
float evaluateOpacity(const Material& material, const TextureSystem& textures,
                      const SurfacePoint& point);

}  // namespace penumbra
