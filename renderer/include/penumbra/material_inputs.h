// The material inputs the renderer understands, defined once: UsdPreviewSurface's (spec 2.5/2.6),
// whose names are the renderer's parameter vocabulary, and Penumbra's `penumbra:` extensions.
// The render delegate parses materials by this table and the Python scene delegate derives from
// it what it reads from a shader.
#pragma once

#include <optional>
#include <string_view>
#include <variant>
#include <vector>

#include "penumbra/material.h"

namespace penumbra {

/// The value an input takes.
enum class MaterialInputKind : uint8_t {
  Float,
  Vector,  // three floats: a colour, or the tangent-space normal
  Bool,
  Token,  // a name among fixed ones (penumbra:anisotropyModel)
};

/// Where a scene delegate finds an input.
enum class MaterialInputOrigin : uint8_t {
  /// UsdPreviewSurface's own input.
  PreviewSurface,
  /// Penumbra's extension, read from a UsdPreviewSurface shader where authored
  /// (inputs:penumbra:…).
  PreviewSurfaceExtension,
  /// Penumbra's extension for what UsdPreviewSurface lacks (a sheen layer, a coat colour,
  /// anisotropy along a tangent): set from MaterialX surfaces, or by callers directly.
  Extension,
};

/// The MaterialParams member an input's constant value sets; none for `normal`, which bends the
/// shading normal and has no constant.
using MaterialParamMember =
    std::variant<std::monostate, float MaterialParams::*, Vec3f MaterialParams::*,
                 bool MaterialParams::*, std::optional<bool> MaterialParams::*,
                 AnisotropyModel MaterialParams::*>;

/// One input of the table.
struct MaterialInputInfo {
  std::string_view name;  // as set_material takes it ("diffuseColor", "penumbra:sheen")
  MaterialInputKind kind;
  MaterialInputOrigin origin;
  MaterialParamMember member;
  /// The input a shader network drives; empty: the input takes constants only.
  std::optional<MaterialInput> connectable;
  /// Whether a non-finite value is refused. The sheen, coat colour, anisotropy and hair inputs
  /// must be finite (the BSDFs clamp them to their ranges), as must the subsurface and
  /// transmission depth/colour inputs (subsurfaceMedium and transmissionAbsorption clamp them)
  /// and emissiveColor (added to the image as it is); the others are taken as given (the BSDF
  /// reads NaN as 0).
  bool mustBeFinite;
};

/// Every input: UsdPreviewSurface's, then the extensions read from it, then the other extensions.
const std::vector<MaterialInputInfo>& materialInputs();
/// The input named `name`; nullptr for another name.
const MaterialInputInfo* findMaterialInput(std::string_view name);
/// The table's entry of a connectable input.
const MaterialInputInfo& materialInputInfo(MaterialInput input);
/// Whether the input takes a colour/vector (3 values) rather than one float.
bool isVectorInput(MaterialInput input);

}  // namespace penumbra
