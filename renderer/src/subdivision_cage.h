// Subdivision cages: UsdGeomMesh's subdivision tokens in OpenSubdiv's terms, and the checks a
// cage and its tags pass before OpenSubdiv refines them.
#pragma once

#include <opensubdiv/sdc/options.h>
#include <opensubdiv/sdc/types.h>

#include <vector>

#include "penumbra/subdivision.h"

namespace penumbra::detail {

OpenSubdiv::Sdc::SchemeType toOsdScheme(SubdivisionScheme scheme);

/// OpenSubdiv's options for the tags' interpolateBoundary, faceVaryingLinearInterpolation and
/// triangleSubdivisionRule; throws std::invalid_argument for a token USD does not define.
OpenSubdiv::Sdc::Options subdivisionOptions(const SubdivisionTags& tags);

/// Throws std::invalid_argument naming the first point that is not finite.
void checkFinitePoints(const std::vector<Vec3f>& points);

/// Throws std::invalid_argument saying what is wrong with the cage's topology or the tags
/// (face sizes and counts, indices out of range, non-finite sharpness, creases along non-edges).
void validateCage(const MeshData& cage, SubdivisionScheme scheme, const SubdivisionTags& tags);

}  // namespace penumbra::detail
