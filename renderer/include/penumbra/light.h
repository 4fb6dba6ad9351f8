// UsdLux lights (docs/design.md §3): radiance = color · intensity · 2^exposure · blackbody
// [· texture] [/ world-space area if normalize]. Rect and disk lights lie in their local XY plane
// and emit along -Z; sphere lights emit outward; cylinder lights lie along local X and emit from
// their side; a distant light's light travels along -Z; the dome surrounds the scene (lat-long
// texture, +Y up, OpenEXR's orientation).
//
// Shadow rays are distributed over each light's area or solid angle (soft shadows); every
// sampling routine returns its density in solid angle so that the integrator can combine it with
// BSDF sampling by multiple importance sampling.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/distribution.h"
#include "penumbra/ies_profile.h"
#include "penumbra/math.h"
#include "penumbra/mesh.h"
#include "penumbra/motion.h"
#include "penumbra/texture.h"
#include "penumbra/warp.h"

namespace penumbra {

enum class LightType { Rect, Disk, Sphere, Cylinder, Distant, Dome, Mesh };

/// An emission texture (scene-linear RGB, row 0 at the top) with its sampling distribution.
class LightTexture {
 public:
  /// Texels in memory. `latLong`: a dome's lat-long map, whose rows are weighted by sin(polar
  /// angle) for sampling.
  LightTexture(int width, int height, std::vector<Vec3f> texels, bool latLong);
  /// Opens `path` in `textures`, decoded as UsdUVTexture's `auto` decodes (8-bit files without
  /// colour metadata are sRGB, as Storm reads a dome's PNG; floats are linear). The sampling
  /// distribution and the average come from the finest MIP level of at most
  /// kDistributionTexels texels; a texture larger than that is looked up through the texture
  /// cache, a smaller one kept in memory, so memory does not grow with the resolution. Throws
  /// std::runtime_error naming the file.
  static std::shared_ptr<const LightTexture> load(std::shared_ptr<TextureSystem> textures,
                                                  const std::string& path, bool latLong);

  /// Cells of the sampling distribution of a loaded texture, at most (a 2048 x 1024 lat-long).
  static constexpr size_t kDistributionTexels = size_t(1) << 21;

  /// Nearest full-resolution texel at (u, v) in [0, 1)², v = 0 at the top row.
  Vec3f lookup(Vec2f uv) const;
  const Distribution2D& distribution() const { return distribution_; }
  /// Mean texel value (for latLong maps: weighted by solid angle).
  const Vec3f& average() const { return average_; }

 private:
  int width_, height_;
  std::vector<Vec3f> texels_;  // empty when looked up through textures_
  std::shared_ptr<const TextureSystem> textures_;
  TextureSystem::Handle handle_ = TextureSystem::kInvalid;
  Distribution2D distribution_;
  Vec3f average_;
};

/// A moving mesh light's triangles in object space, in meshTriangles' order (points, point
/// motion and 3 point indices per triangle), and its object-to-world motion: a triangle's
/// corners at a time are where the traced geometry has them then.
struct MovingMeshLight {
  TriangleMesh triangles;
  MotionTransform objectToWorld;
};

struct LightParams {
  LightType type = LightType::Sphere;
  Transform lightToWorld;
  Vec3f color{1.0f};
  float intensity = 1;
  float exposure = 0;
  bool normalize = false;
  bool enableColorTemperature = false;
  float colorTemperature = 6500;  // kelvin
  float width = 1, height = 1;    // rect, scene units before the transform
  float radius = 0.5f;            // disk, sphere and cylinder
  float length = 1;               // cylinder, along local X
  float angle = 0.53f;            // distant: angular diameter in degrees
  bool treatAsPoint = false;      // sphere: emit from the centre as a point (radius 0: always)
  // ShapingAPI, around the light's -Z axis.
  float coneAngle = 180;  // degrees off the axis; 180 or more means no cone
  float coneSoftness = 0;
  float focus = 0;        // off-axis emission falls off as cos^focus ...
  Vec3f focusTint{0.0f};  // ... towards this tint
  // ShapingAPI's IES profile (local lights): its candelas multiply the radiance emitted, the
  // profile's nadir along -Z and its horizontal angle 0 towards -X, 90° towards -Y (hdEmbree's
  // convention); divided by the profile's mean with iesNormalize. iesAngleScale s remaps the
  // vertical angle θ to (θ − π) / (1 + s) + π (RenderMan's and hdEmbree's; s ≤ -1: -1).
  std::shared_ptr<const IesProfile> ies;
  float iesAngleScale = 0;
  bool iesNormalize = false;
  bool shadowEnable = true;                     // ShadowAPI shadow:enable
  float diffuse = 1, specular = 1;              // multipliers of the light's effect on those lobes
  bool cameraVisible = true;                    // false: camera rays pass through the light
  std::shared_ptr<const LightTexture> texture;  // texture:file (rect, dome)
  /// UsdLuxMeshLightAPI: the emitting triangles in world space (3 points each), front side
  /// counter-clockwise. The mesh itself is traced as geometry; the light samples its surface.
  std::shared_ptr<const std::vector<Vec3f>> meshTriangles;
  /// A mesh light whose mesh moves over the shutter: where its triangles are at each time
  /// (meshTriangles then holds them at shutter open).
  std::shared_ptr<const MovingMeshLight> meshMotion;
  /// Its slot in the linking table (linking.h); -1: it lights and shadows everything.
  int linkSlot = -1;
};

/// Where light is received: a point, and the unit normal of its surface, or a zero normal for
/// points that receive from both sides (translucent surfaces).
struct Receiver {
  Vec3f position;
  Vec3f normal;
};

/// Bounds on what local lights emit, for choosing among them: positions, power and directions
/// (emission axes within thetaO of `axis`, each light emitting within thetaE of its own axis).
struct LightBounds {
  Vec3f lower{kInfinity}, upper{-kInfinity};
  float power = 0;  // grey radiance · projected area: irradiance ≈ power · cos / distance²
  Vec3f axis{0, 0, 1};
  float cosThetaO = 1;  // 1: every axis along `axis`; -1: any direction
  float cosThetaE = 0;  // 0: each light emits over the hemisphere around its axis

  Vec3f centroid() const { return (lower + upper) * 0.5f; }
  /// The squared radius of the box's bounding sphere.
  float halfDiagonal2() const { return 0.25f * dot(upper - lower, upper - lower); }
};

/// The smallest bounds holding both (cones are merged as in Conty Estevez & Kulla 2018).
LightBounds unite(const LightBounds& a, const LightBounds& b);

/// LightBounds as the light tree evaluates them, at every level of every walk: up to kLanes side
/// by side, evaluated at once in SIMD lanes (a walk weighs a node's four children together), with
/// what importance() derives from the bounds alone computed once.
class LightClusters {
 public:
  static constexpr int kLanes = 4;

  /// Every lane empty (importance 0).
  LightClusters() = default;
  void set(int lane, const LightBounds& bounds);

  /// For each lane, an upper-bound estimate of the irradiance its lights give the receiver (0
  /// only where they cannot light it at all, and in empty lanes).
  std::array<float, kLanes> importance(const Receiver& receiver) const;
  /// importance() of clusters[0], ..., clusters[count - 1] at one receiver, into `out`. A light
  /// tree's walks weigh the nodes they stand on one level at a time: evaluated in one call
  /// rather than a call each, their chains of square roots and divisions overlap.
  static void importances(const LightClusters* const* clusters, size_t count,
                          const Receiver& receiver, std::array<float, kLanes>* out);

 private:
  // Lane-wise, as the bounds give them: the box's centre and the squared radius of its bounding
  // sphere, power, emission axis and the cosines and sine of thetaO and thetaE.
  alignas(16) float centerX_[kLanes] = {}, centerY_[kLanes] = {}, centerZ_[kLanes] = {};
  alignas(16) float halfDiagonal2_[kLanes] = {}, power_[kLanes] = {};
  alignas(16) float axisX_[kLanes] = {}, axisY_[kLanes] = {}, axisZ_[kLanes] = {1, 1, 1, 1};
  alignas(16) float cosThetaO_[kLanes] = {1, 1, 1, 1}, sinThetaO_[kLanes] = {};
  alignas(16) float cosThetaE_[kLanes] = {};
  bool omnidirectional_ = true;  // every lane with power emits every way (thetaO = π)

  /// importance()'s arithmetic, inlined into importance() and importances().
  std::array<float, kLanes> evaluate(const Receiver& receiver) const;
};

/// A light sample as seen from a shading point.
struct LightSample {
  Vec3f direction;     // unit, from the shading point towards the light
  float distance = 0;  // to the sampled point; infinity for distant and dome lights
  Vec3f radiance;      // arriving along -direction (for delta lights: irradiance / pdf scale)
  float pdf = 0;       // solid-angle density; for delta lights 1 with isDelta set
  /// Where it is not `pdf` (0 elsewhere): the density multiple importance sampling weighs the
  /// sample by, that of rays meeting the light there. A moving mesh light's hits are weighed by
  /// Light::meshPdf, which knows its triangles' areas at shutter open alone.
  float weighingPdf = 0;
  bool isDelta = false;

  float pdfForWeights() const { return weighingPdf > 0 ? weighingPdf : pdf; }
};

/// Where a ray meets a light's emitting surface.
struct LightHit {
  float distance = 0;
  Vec3f radiance;
  float pdf = 0;  // the solid-angle density sample() would have had for this direction
};

class Light {
 public:
  /// Throws std::invalid_argument for degenerate shapes (zero area, non-finite values).
  explicit Light(const LightParams& params);

  LightType type() const { return params_.type; }
  /// True for distant and dome lights: reached by rays that escape the scene.
  bool isInfinite() const {
    return params_.type == LightType::Distant || params_.type == LightType::Dome;
  }
  /// True for lights no ray can hit (point-like sphere, zero-angle distant light).
  bool isDelta() const;
  /// True for a dome without a texture: the same radiance from every direction.
  bool isConstantDome() const { return params_.type == LightType::Dome && !params_.texture; }
  /// True for the lights rays meet as surfaces of their own (rect, disk, sphere, cylinder; not
  /// point-like): those intersect() finds. Mesh lights are met as geometry.
  bool isAreaLight() const {
    return !isInfinite() && !isDelta() && params_.type != LightType::Mesh;
  }
  /// A mesh light whose mesh moves over the shutter (LightParams::meshMotion).
  bool moves() const { return params_.meshMotion != nullptr; }
  bool castsShadows() const { return params_.shadowEnable; }
  /// False for lights camera rays do not see (they still light the scene).
  bool cameraVisible() const { return params_.cameraVisible; }
  float diffuseMultiplier() const { return params_.diffuse; }
  float specularMultiplier() const { return params_.specular; }
  /// Its light and shadow linking slot (LinkingTable), -1: it lights and shadows everything.
  int linkSlot() const { return params_.linkSlot; }

  /// A direction towards the light from `point`. An untextured dome is sampled cosine-weighted
  /// about the receiving surface's unit `normal` (uniformly over the sphere for a zero normal).
  /// A moving mesh light is where it is at normalised shutter time `time`; the other lights
  /// stay where they are at shutter open.
  std::optional<LightSample> sample(const Vec3f& point, Vec2f u, const Vec3f& normal = {},
                                    float time = 0) const;
  /// First intersection of a ray with a finite light's emitting surface closer than tMax.
  std::optional<LightHit> intersect(const Vec3f& origin, const Vec3f& direction, float tMax) const;
  /// Radiance and pdf for a ray that escaped the scene in `direction` (infinite lights), leaving
  /// a surface with `normal` (as for sample()).
  std::optional<LightHit> escaped(const Vec3f& direction, const Vec3f& normal = {}) const;
  /// Mesh lights: the solid-angle density sample() has for a point of the mesh seen from
  /// `origin` (the integrator weighs emission found by BSDF rays with it); for a moving one, by
  /// its area at shutter open (LightSample::weighingPdf).
  float meshPdf(const Vec3f& origin, const Vec3f& point, const Vec3f& normal) const;

  /// The emitted radiance before texture and shaping, after all other UsdLux factors.
  const Vec3f& radiance() const { return radiance_; }
  float area() const { return area_; }
  /// Local lights: where and how they emit, for the light tree.
  LightBounds bounds() const;
  /// Infinite lights: the irradiance on an unoccluded surface facing them, grey (the mean of
  /// its channels).
  float irradiance() const;
  /// Distant lights: the direction light arrives from (unit, towards the light) and the cosine
  /// of the cone's half-angle.
  Vec3f towardsLight() const { return -normal_; }
  float cosHalfAngle() const { return cosHalfAngle_; }
  /// The emitted radiance averaged over the texture, if any.
  Vec3f meanRadiance() const;
  /// The surface a sphere, rect or disk light emits from (world space), for finding its image:
  /// the sphere of `radius` about `centre`, or the points centre + a · axisU + b · axisV with
  /// |a|, |b| <= 1 (rect) or a² + b² <= 1 (disk).
  struct Outline {
    LightType type;
    Vec3f centre, axisU, axisV;
    float radius;
  };
  /// None for cylinder, mesh, point-like and infinite lights.
  std::optional<Outline> outline() const;
  /// Whether the light is a sphere, rect, disk, cylinder or mesh light (not point-like):
  /// sampleSurface draws the points it emits from. Light tracing (caustics.h) starts paths on
  /// such lights.
  bool emitsFromSurface() const;
  /// A point of the emitting surface of a light that emitsFromSurface(), with the unit normal of
  /// its emitting side there: uniform by area, or, on a textured rect, by the texture's
  /// distribution (as sample() draws it).
  struct SurfacePoint {
    Vec3f position, normal;
    /// The texture's value there (1 without one): the radiance's factor at this point.
    Vec3f texture;
    /// The inverse of the density by area it was drawn with: area() where uniform.
    float areaOverDensity;
  };
  /// A moving mesh light's at shutter open (light tracing leaves those to the path tracer).
  std::optional<SurfacePoint> sampleSurface(Vec2f u) const;
  /// What the light emits from a point with `texture` (SurfacePoint) in world direction
  /// `emitted` (from its emitting side): radiance() textured and shaped (ShapingAPI).
  Vec3f radianceLeaving(const Vec3f& texture, const Vec3f& emitted) const {
    return radiance_ * texture * shaping(emitted);
  }

 private:
  /// The mean of meanRadiance()'s channels (never negative): what lights are weighed by when one
  /// is chosen, so that each channel's noise counts alike (pbrt-v4 averages over wavelengths;
  /// luminance would sample blue lights too rarely for their share of the blue channel).
  float meanRadianceGrey() const;
  /// A mesh light's point at normalised shutter time `time`: a triangle by its area (at
  /// shutter open), then a point of it, uniform by area.
  SurfacePoint meshPoint(Vec2f u, float time) const;
  /// Rect lights are sampled uniformly in the solid angle they subtend where that is at least
  /// this (steradians), and by area elsewhere.
  static constexpr double kMinSphericalSolidAngle = 1e-4;
  /// The rect as seen from `point` when it is sampled by solid angle there.
  std::optional<SphericalRectangle> sphericalRect(const Vec3f& point) const;
  float solidAnglePdfFromArea(const Vec3f& point, const Vec3f& lightPoint, const Vec3f& lightNormal,
                              float areaDensity) const;
  std::optional<float> intersectSphere(const Vec3f& origin, const Vec3f& direction) const;
  /// Cylinder: the half-width (radians) of the arc of the side visible from `point`, and the
  /// angle of its middle; false from inside.
  bool visibleArc(const Vec3f& point, float* middle, float* halfWidth) const;
  std::optional<float> intersectCylinder(const Vec3f& origin, const Vec3f& direction,
                                         Vec3f* normal) const;
  /// ShapingAPI factor for light leaving the light in world direction `emitted`.
  Vec3f shaping(const Vec3f& emitted) const;
  /// The IES profile's factor (LightParams::ies) on radiance emitted along `emitted`.
  float iesFactor(const Vec3f& emitted) const;
  /// Rect and disk: (a, b) of a point centre + a · edgeU + b · edgeV of the light's plane.
  Vec2f edgeCoordinates(const Vec3f& point) const;
  /// Rect texture coordinates of a point in the light's plane.
  Vec2f rectUV(const Vec3f& point) const;
  /// Dome: lat-long coordinates of a world direction and back.
  Vec2f domeUV(const Vec3f& direction, float* sinPolar) const;
  Vec3f domeDirection(Vec2f uv, float* sinPolar) const;

  LightParams params_;
  Vec3f radiance_;
  // Rect: centre + edges; disk: centre + semi-axes; sphere: centre + radius; cylinder: centre +
  // axis (full length) + radius.
  Vec3f center_, edgeU_, edgeV_, normal_;
  float radius_ = 0;
  float area_ = 0;
  bool pointOnly_ = false;          // sphere of radius 0: a point light whatever treatAsPoint says
  float pointProjectedArea_ = 0;    // point-like sphere: radiant intensity over radiance_
  float cosHalfAngle_ = 1;          // distant light cone
  float oneMinusCosHalfAngle_ = 0;  // kept separately for precision at small angles
  // Distant lights that are not delta: the frame of the cone about the direction to the light
  // and the cone's uniform density, made once.
  std::optional<Frame> coneFrame_;
  float conePdf_ = 0;
  Vec3f axis_;  // shaping axis: the light's -Z in world space
  bool shaped_ = false;
  Transform iesWorldToLight_;     // with an IES profile: world directions into the light's frame
  float iesDivisor_ = 1;          // 1, or the profile's mean with iesNormalize
  bool orthogonalEdges_ = false;  // rect, disk: not sheared by its transform
  Vec3f dualU_, dualV_;  // sheared rect, disk: edgeCoordinates' dual axes of edgeU_, edgeV_
  SphericalRectangle::Rectangle rectangle_;  // rect with orthogonalEdges_: for sphericalRect
  // ShapingAPI's cone: full emission up to smoothStart off the axis, none past cutoff, a
  // smoothstep over the angle between (radians, and their cosines).
  float coneSmoothStart_ = kPi, coneCutoff_ = kPi;
  float coneCosSmoothStart_ = -1, coneCosCutoff_ = -1;
  Transform worldToLight_;
  std::optional<Distribution1D> triangleChoice_;  // mesh lights: triangles by area
  // Mesh lights: the box of their triangles, found once (the light tree asks for it whenever
  // any light changes).
  Vec3f meshLower_{kInfinity}, meshUpper_{-kInfinity};
};

}  // namespace penumbra
