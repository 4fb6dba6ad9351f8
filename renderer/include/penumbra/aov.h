// Arbitrary output variables (AOVs): what the film can accumulate besides colour, by name.
// docs/aovs.md lists them with their units, spaces and how samples combine into a pixel.
#pragma once

#include <string>
#include <vector>

#include "penumbra/material.h"
#include "penumbra/math.h"
#include "penumbra/mesh.h"

namespace penumbra {

class Shape;

enum class AovKind {
  Color,         // RGBA, filtered
  Alpha,         // coverage, filtered
  Depth,         // distance from the camera's centre to the first hit (nearest sample)
  Z,             // distance along the camera's view axis (nearest sample)
  Normal,        // world-space shading normal, filtered
  CameraNormal,  // camera-space shading normal (+Y up, looking down -Z), filtered
  Position,      // world-space position, filtered
  Albedo,        // the surface's reflectance colour (what a denoiser is guided by), filtered
  PrimId,        // which mesh (Geometry::MeshId) the sample nearest the pixel centre hit, -1: none
  InstanceId,    // which copy of an instancer, -1: not a copy or nothing hit
  ElementId,     // which authored face, -1: nothing hit
  Primvar,       // a primvar's value, filtered; `primvar` names it
  SampleCount,   // samples taken (fewer where adaptive sampling stopped the pixel)
  Variance,      // RGB variance of the pixel's mean colour (sample variance / samples)
  // Cryptomatte layers (cryptomatte.h): which placements the samples first hit, resolved with
  // the names of the objects, of their materials or of their assets.
  CryptoObject,
  CryptoMaterial,
  CryptoAsset,
};

/// Whether the AOV is a Cryptomatte layer.
inline bool isCryptomatte(AovKind kind) {
  return kind == AovKind::CryptoObject || kind == AovKind::CryptoMaterial ||
         kind == AovKind::CryptoAsset;
}

struct AovRequest {
  AovKind kind = AovKind::Color;
  PrimvarName primvar;  // for AovKind::Primvar

  bool operator==(const AovRequest& other) const {
    return kind == other.kind && primvar == other.primvar;
  }
  /// Read from the first hit of camera rays (everything but colour, alpha and the statistics).
  bool needsFirstHit() const;
};

/// The AOV a name stands for: color, alpha, depth, Z, normal, Neye, position, albedo, primId,
/// instanceId, elementId, primvars:NAME, sampleCount, variance, CryptoObject, CryptoMaterial,
/// CryptoAsset. Throws std::invalid_argument
/// listing the names for an unknown one.
AovRequest parseAov(const std::string& name);
/// The names parseAov knows (primvars as "primvars:NAME").
const std::vector<std::string>& aovNames();

/// The albedo AOV of a surface: its reflectance colour as a denoiser wants it (diffuse colour,
/// plus the specular colour in the specular workflow, capped at 1; translucency mixes in white
/// by 1 − opacity, since glass passes light on unchanged).
Vec3f surfaceAlbedo(const MaterialParams& material);

/// What a camera sample saw first, recorded only when the film wants first-hit AOVs. Values
/// stay at their defaults (no hit) when the camera ray met nothing, or only a light.
struct FirstHitSample {
  Vec2f filterOffset{0.0f};  // the sample's position relative to the pixel centre, in pixels
  bool hit = false;
  float distance = kInfinity;  // from the camera's centre (lights seen directly count)
  float z = kInfinity;         // along the view axis (same)
  Vec3f position, normal, cameraNormal, albedo;
  int primId = -1, instanceId = -1, elementId = -1;
  /// The per-face binding slot of the face hit (Geometry::setMeshFaceMaterials; 0: it renders
  /// with its object's material).
  uint32_t faceSlot = 0;
  /// Where primvars are looked up (valid while the scene is alive and unchanged).
  const Shape* shape = nullptr;
  uint32_t primitive = 0;
  float u = 0, v = 0;
  const std::vector<Primvar>* instancePrimvars = nullptr;
};

}  // namespace penumbra
