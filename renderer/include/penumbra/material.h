// UsdPreviewSurface materials (spec 2.5/2.6): the surface's parameters with the schema's fallback
// values plus Penumbra's extensions, and the shader networks that drive them per shading point
// (UsdUVTexture, UsdPrimvarReader_*, UsdTransform2d).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/math.h"
#include "penumbra/mesh.h"
#include "penumbra/texture.h"

namespace penumbra {

/// How a roughness r and an anisotropy a in [0, 1] become the GGX α along the shading tangent
/// (αx) and bitangent (αy); a = 0 is the isotropic α = r² either way (docs/materialx.md).
enum class AnisotropyModel : uint8_t {
  /// OpenPBR's: αx = r² √(2 / (1 + (1 − a)²)), αy = (1 − a) αx.
  OpenPbr,
  /// MaterialX's standard_surface (roughness_anisotropy node): with k = √(1 − min(a, 0.98)),
  /// αx = min(r² / k, 1), αy = r² k.
  StandardSurface,
};

/// The UsdPreviewSurface parameters at one shading point.
struct MaterialParams {
  Vec3f diffuseColor{0.18f};
  Vec3f emissiveColor{0.0f};
  Vec3f specularColor{0.0f};
  bool useSpecularWorkflow = false;
  /// inputs:penumbra:specularWeight (MaterialX's `specular` / `specular_weight`): scales the
  /// dielectric specular lobe whole, its reflection at grazing angles (F90) too, and what it
  /// takes from the diffuse layer under it. 1: UsdPreviewSurface's lobe.
  float specularWeight = 1;
  float metallic = 0;
  float roughness = 0.5f;
  float clearcoat = 0;
  float clearcoatRoughness = 0.01f;
  /// inputs:penumbra:clearcoatColor: the colour of the light crossing the clearcoat; what lies
  /// under it is tinted by 1 − clearcoat + clearcoat × clearcoatColor (as MaterialX's
  /// standard_surface and open_pbr_surface do).
  Vec3f clearcoatColor{1.0f};
  /// inputs:penumbra:sheen, sheenColor, sheenRoughness: a sheen layer (fabric, dust) over the
  /// opaque part, with weight `sheen` (0: none), colour `sheenColor` and roughness
  /// `sheenRoughness`, the Charlie distribution's α (bsdf.h).
  float sheen = 0;
  Vec3f sheenColor{1.0f};
  float sheenRoughness = 0.3f;
  /// inputs:penumbra:anisotropy and penumbra:clearcoatAnisotropy (0: isotropic) stretch the
  /// specular and clearcoat lobes along the shading tangent as `anisotropyModel` says;
  /// penumbra:anisotropyRotation turns that tangent (the mesh's ∂P/∂s, see SurfaceHit::tangent)
  /// about the normal, in turns (1 = 360°), counter-clockwise seen from the normal's side.
  float anisotropy = 0;
  float clearcoatAnisotropy = 0;
  float anisotropyRotation = 0;
  AnisotropyModel anisotropyModel = AnisotropyModel::OpenPbr;
  float opacity = 1;
  float opacityThreshold = 0;
  float ior = 1.5f;
  /// inputs:penumbra:clearcoatIor: the coat's IOR; < 0: `ior`, as UsdPreviewSurface (2.4 on)
  /// says ("including the clearcoat"); MaterialX surfaces give their coat's own.
  float clearcoatIor = -1;
  /// inputs:penumbra:metalWhiteEdge: whether a metal's reflection whitens towards grazing
  /// angles (MaterialX's conductors, F90 = 1); false: its F90 is the albedo, as
  /// UsdPreviewSurface says ("both F0 and edge F90 reflectivity will simply be the Albedo").
  bool metalWhiteEdge = false;
  float transmissionRoughness = -1;  // inputs:penumbra:transmissionRoughness; < 0: roughness
  float abbeNumber = 0;              // inputs:penumbra:abbeNumber; 0: no dispersion
  /// inputs:penumbra:thinWalled: whether translucency is a thin sheet (true) or the boundary of
  /// a solid (false); unset: as the mesh's geometry says (TriangleMesh::closed).
  std::optional<bool> thinWalled;
  /// inputs:penumbra:subsurface, subsurfaceColor, subsurfaceRadius, subsurfaceAnisotropy: the
  /// share (0–1) of the diffuse layer that enters the solid and scatters through its volume
  /// (a random walk, subsurface.h) instead of reflecting at the surface, as standard_surface's
  /// and OpenPBR's subsurface: the colour the walk's multiple scattering shows (its albedo), the
  /// mean free path per channel in scene units (the authored radius times its scale) and the
  /// Henyey–Greenstein g of the interior (−1..1). Only solids (closed meshes) hold a medium: on
  /// open ones the share reflects diffusely with subsurfaceColor.
  float subsurface = 0;
  Vec3f subsurfaceColor{0.8f};
  Vec3f subsurfaceRadius{1.0f};
  float subsurfaceAnisotropy = 0;
  /// inputs:penumbra:transmissionDepth and transmissionColor: the translucent part of a solid is
  /// absorbing glass whose interior lets transmissionColor through over transmissionDepth scene
  /// units (σa = −ln(transmissionColor) / transmissionDepth); depth 0: clear glass.
  float transmissionDepth = 0;
  Vec3f transmissionColor{1.0f};

  /// inputs:penumbra:hair: the surface scatters as a hair fibre (Chiang et al. 2016's model,
  /// HairBsdf in hair_bsdf.h) instead of as a UsdPreviewSurface; the hair* parameters below are
  /// read only then, and the ones above only for what is not scattering (emission, opacity).
  bool hair = false;
  /// penumbra:hairAbsorption: σa of the fibre's interior per unit fibre radius (0: clear;
  /// hairAbsorptionFromColor and hairAbsorptionFromMelanin derive it).
  Vec3f hairAbsorption{0.0f};
  /// penumbra:hairAbsorptionFromColor and penumbra:hairAbsorptionFromMelanin: σa is derived at
  /// each shading point (hairAbsorptionAt in hair_bsdf.h) instead of taken from hairAbsorption:
  /// from penumbra:hairColor, the fibre's multiply scattered colour, with β_n
  /// penumbra:hairColorAzimuthalRoughness (< 0: hairAzimuthalRoughness as authored, before any
  /// glossy filtering), as MaterialX's chiang_hair_absorption_from_color; or from
  /// penumbra:hairMelanin (concentration) and penumbra:hairMelaninRedness, as
  /// deon_hair_absorption_from_melanin with d'Eon's pigments. Colour wins if both are set.
  /// The colour and melanin default to MaterialX's nodes' defaults.
  bool hairAbsorptionFromColor = false;
  bool hairAbsorptionFromMelanin = false;
  Vec3f hairColor{1.0f};
  float hairColorAzimuthalRoughness = -1;
  float hairMelanin = 0.25f;
  float hairMelaninRedness = 0.5f;
  /// penumbra:hairLongitudinalRoughness and penumbra:hairAzimuthalRoughness: β_m and β_n in
  /// [0.01, 1] (pbrt-v4's parameters), the R lobe's. The TT and TRT lobes' longitudinal width
  /// (the square root of M_p's variance) is R's times penumbra:hairLongitudinalScaleTT and
  /// penumbra:hairLongitudinalScaleTRT (Marschner's 1/2 and 2 by default), their azimuthal
  /// logistic's scale R's times penumbra:hairAzimuthalScaleTT and penumbra:hairAzimuthalScaleTRT.
  float hairLongitudinalRoughness = 0.3f;
  float hairAzimuthalRoughness = 0.3f;
  float hairLongitudinalScaleTT = 0.5f;
  float hairLongitudinalScaleTRT = 2.0f;
  float hairAzimuthalScaleTT = 1.0f;
  float hairAzimuthalScaleTRT = 1.0f;
  /// penumbra:hairCuticleAngle: α, the tilt of the cuticle's scales, in degrees.
  float hairCuticleAngle = 2.0f;
  /// penumbra:hairIor: the fibre's index of refraction (keratin's by default).
  float hairIor = 1.55f;
  /// penumbra:hairTintR, hairTintTT, hairTintTRT: factors of the R, TT and TRT lobes (TRT's
  /// also of the residual lobe), as MaterialX's chiang_hair_bsdf has them.
  Vec3f hairTintR{1.0f};
  Vec3f hairTintTT{1.0f};
  Vec3f hairTintTRT{1.0f};
};

/// The surface of meshes without a material: roughness 1 and no specular colour (within 1 % of
/// Lambertian), 0.5 grey, smooth transmission; the scene sets diffuseColor and opacity from
/// displayColor and displayOpacity where they are authored.
MaterialParams fallbackSurface();

/// Shading's opacity where a threshold is set: opacity decided presence (the filter cut out
/// what is below it), and what remains is opaque, not translucent (UsdPreviewSurface spec).
inline void applyOpacityThreshold(MaterialParams& params) {
  if (params.opacityThreshold > 0) params.opacity = 1;
}

/// The inputs a shader network can drive (material_inputs.h names them). `Normal` is the
/// tangent-space normal (a normal map); the others are the MaterialParams of the same name.
enum class MaterialInput : uint8_t {
  DiffuseColor,
  EmissiveColor,
  SpecularColor,
  Metallic,
  Roughness,
  Clearcoat,
  ClearcoatRoughness,
  ClearcoatColor,
  Sheen,
  SheenColor,
  SheenRoughness,
  Anisotropy,
  ClearcoatAnisotropy,
  AnisotropyRotation,
  Opacity,
  Ior,
  HairAbsorption,
  HairLongitudinalRoughness,
  HairAzimuthalRoughness,
  HairCuticleAngle,
  HairTintR,
  HairTintTT,
  HairTintTRT,
  HairColor,
  HairMelanin,
  HairMelaninRedness,
  Subsurface,
  SubsurfaceColor,
  SubsurfaceRadius,
  Normal,
};

/// The texture coordinates a UsdUVTexture reads: a UsdPrimvarReader_float2 (its primvar where the
/// mesh has it, else its fallback), through a UsdTransform2d when one is connected.
struct TextureCoordinates {
  PrimvarName primvar;  // empty: `fallback` everywhere
  Vec2f fallback{0, 0};
  // UsdTransform2d: result = in * scale * rotate * translate (rotation in degrees,
  // counter-clockwise).
  Vec2f scale{1, 1};
  float rotation = 0;
  Vec2f translation{0, 0};

  /// The transform applied to a coordinate.
  Vec2f apply(Vec2f st) const;
  /// Its linear part applied to a coordinate difference (derivatives).
  Vec2f applyLinear(Vec2f dst) const;
};

/// A UsdUVTexture node.
struct TextureReader {
  TextureSystem::Handle texture = TextureSystem::kInvalid;  // invalid: the file is missing
  TextureWrap wrapS = TextureWrap::UseMetadata;
  TextureWrap wrapT = TextureWrap::UseMetadata;
  std::array<float, 4> scale{1, 1, 1, 1};
  std::array<float, 4> bias{0, 0, 0, 0};
  std::array<float, 4> fallback{0, 0, 0, 1};
  TextureCoordinates coordinates;
};

/// The operations of an ExpressionProgram. Every value has four channels; arithmetic is
/// component-wise.
enum class ExpressionOp : uint8_t {
  Constant,     // `value`
  Texture,      // Material::textures[texture]'s output (texel × scale + bias, or its fallback)
  Primvar,      // primvar `primvar` at the point, zero-padded; `value` where the mesh lacks it
  Swizzle,      // out[k] = a[channels[k]]
  Concatenate,  // a's first channels[0] channels, then b's first ones
  Add,          // a + b
  Subtract,     // a − b
  Multiply,     // a × b
  Divide,       // a / b, 0 where b is 0
  Mix,          // b + (a − b) × c (MaterialX mix: a foreground, b background, c amount)
  Clamp,        // min(max(a, b), c)
};

/// One node of an ExpressionProgram; a, b and c are its operands, earlier nodes of the program.
struct ExpressionNode {
  ExpressionOp op = ExpressionOp::Constant;
  std::array<uint8_t, 3> operands{0, 0, 0};
  std::array<uint8_t, 4> channels{0, 1, 2, 3};
  std::array<float, 4> value{0, 0, 0, 0};
  int texture = -1;  // index into Material::textures
  PrimvarName primvar;
};

/// A pattern network that does not reduce to one texture lookup or primvar (a product of two
/// textures, a texture mixed with a primvar by a mask, …): its nodes in evaluation order, the
/// last one giving the input's value. Evaluated at each shading point without allocation.
struct ExpressionProgram {
  static constexpr size_t kMaxNodes = 64;
  std::vector<ExpressionNode> nodes;

  /// What makes the program unusable (empty: nothing): no nodes or more than kMaxNodes, an
  /// operand that is not an earlier node, a channel outside 0..3, a non-finite constant or
  /// fallback, a texture index outside [0, textureCount).
  std::string problem(size_t textureCount) const;
};

/// What drives one input: channels of a texture reader's output, a mesh primvar, or a program.
struct InputConnection {
  MaterialInput input = MaterialInput::DiffuseColor;
  int program = -1;  // index into Material::programs; -1: a texture or primvar reader
  int texture = -1;  // index into Material::textures; -1: a primvar reader
  /// The output read: its first channel (r 0, g 1, b 2, a 3) and channel count (1, or 3 for
  /// rgb). A one-channel output feeding a colour input is broadcast to grey.
  int firstChannel = 0;
  int channelCount = 3;
  PrimvarName primvar;                     // primvar readers: the primvar's name
  std::array<float, 3> fallback{0, 0, 0};  // primvar readers: where the mesh lacks the primvar
};

/// A UsdPreviewSurface: constant inputs, and the connections that override some of them per
/// shading point.
struct Material {
  MaterialParams constants;
  std::vector<TextureReader> textures;
  std::vector<ExpressionProgram> programs;
  std::vector<InputConnection> connections;

  /// Whether any input varies over the surface.
  bool varies() const { return !connections.empty(); }
  /// Whether opacity varies over the surface (cut-outs are then decided per hit).
  bool opacityVaries() const;
  /// Whether any lobe may be anisotropic (shading points then need a tangent).
  bool mayBeAnisotropic() const;
};

}  // namespace penumbra
