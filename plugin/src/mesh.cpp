#include "penumbra/plugin/mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "penumbra/mesh_shape.h"
#include "penumbra/plugin/instancer.h"

namespace penumbra::plugin {

void Mesh::setTopology(std::vector<int> counts, std::vector<int> indices, bool leftHanded,
                       std::string subdivisionScheme) {
  data_.faceVertexCounts = std::move(counts);
  data_.faceVertexIndices = std::move(indices);
  data_.leftHanded = leftHanded;
  subdivisionScheme_ = std::move(subdivisionScheme);
  tessellator_.reset();
  markDirty(DirtyTopology);
}

void Mesh::setLight(bool enabled, const std::vector<std::pair<std::string, ParamValue>>& params) {
  if (!enabled) {
    if (!light_) return;  // nothing changes: no sync needed
    light_.reset();
  } else {
    auto light = std::make_unique<Light>(id(), LightType::Mesh, handle());
    for (const auto& [name, value] : params) light->setParam(name, value);
    light_ = std::move(light);
  }
  markDirty(DirtyParams);
}

void Mesh::setSubdivisionTags(SubdivisionTags tags) {
  tags_ = std::move(tags);
  tessellator_.reset();
  markDirty(DirtyTopology);
}

const LimitSurfaceTessellator* Mesh::tessellator(SubdivisionScheme scheme, SyncContext& context) {
  if (tessellator_) return tessellator_.get();
  std::vector<std::string> dropped;
  const SubdivisionTags usable = usableSubdivisionTags(data_, tags_, &dropped);
  // Built before warning: a cage that cannot be subdivided at all says so instead.
  tessellator_ = std::make_unique<LimitSurfaceTessellator>(data_, scheme, usable);
  if (!dropped.empty()) {
    constexpr size_t kNamed = 4;
    std::string list;
    for (size_t i = 0; i < dropped.size() && i < kNamed; ++i) list += (i ? "; " : "") + dropped[i];
    if (dropped.size() > kNamed)
      list += "; and " + std::to_string(dropped.size() - kNamed) + " more";
    context.warn(id() + ": subdivision tags that do not fit the mesh are left out (" + list +
                 "); the rest of the surface is subdivided");
  }
  return tessellator_.get();
}

void Mesh::setPoints(std::vector<Vec3f> points, std::vector<std::vector<Vec3f>> pointMotion) {
  data_.points = std::move(points);
  data_.pointMotion = std::move(pointMotion);
  markDirty(DirtyPoints);
}

void Mesh::setDoubleSided(bool doubleSided) {
  data_.doubleSided = doubleSided;
  markDirty(DirtyDoubleSided);
}

void Mesh::setDisplayColor(std::vector<Vec3f> colors, Interpolation interpolation) {
  data_.displayColor = std::move(colors);
  data_.displayColorInterpolation = interpolation;
  tessellator_.reset();  // it carries displayColor
  markDirty(DirtyPrimvar);
}

void Mesh::setPrimvars(std::vector<Primvar> primvars) {
  data_.primvars = std::move(primvars);
  tessellator_.reset();  // it carries the primvars
  markDirty(DirtyPrimvar);
}

std::vector<std::string> Mesh::dropInvalidPrimvars() {
  std::vector<std::string> problems;
  std::vector<Primvar>& primvars = data_.primvars;
  for (auto it = primvars.begin(); it != primvars.end();) {
    try {
      validatePrimvar(*it, data_);
      ++it;
    } catch (const std::invalid_argument& error) {
      problems.emplace_back(error.what());
      it = primvars.erase(it);
      tessellator_.reset();
    }
  }
  return problems;
}

void Mesh::setNormals(std::vector<Vec3f> normals, Interpolation interpolation) {
  data_.normals = std::move(normals);
  data_.normalsInterpolation = interpolation;
  markDirty(DirtyPrimvar);
}

void Mesh::sync(SyncContext& context, uint32_t bits) {
  context.sceneChanged = true;
  Scene& scene = context.scene;
  const bool reshaped = bits & (DirtyTopology | DirtyPoints | DirtyPrimvar | DirtyDoubleSided);
  std::optional<std::vector<int>> newRates;
  if (!reshaped && (bits & DirtyTransform)) newRates = changedDicingRates(context);
  if (reshaped || newRates) {
    for (const std::string& problem : dropInvalidPrimvars())
      context.warn(id() + ": " + problem + "; materials reading it use their fallback");
    ++context.counters.meshGeometrySyncs;
    try {
      const auto started = std::chrono::steady_clock::now();
      TriangleMesh surface = triangles(context, std::move(newRates));
      context.counters.tessellationSeconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      scene.geometry().setMeshGeometry(handle(), std::move(surface));
    } catch (const std::invalid_argument& error) {
      context.warn(id() + ": " + error.what() + "; the mesh is skipped");
      scene.geometry().clearMeshGeometry(handle());
    }
  }
  syncPlacement(context, bits);
  // Subsets may bind faces the new topology has, or no longer has.
  if ((bits & DirtyTopology) && !(bits & DirtyMaterialId) && !subsetMaterials().empty())
    bindFaces(context);
  if (bits & kLightDirtyBits) syncLight(context);
}

void Mesh::finalize(SyncContext& context) {
  context.sceneChanged = true;
  // An entry may be stale: an instancer removed, or now copying another mesh.
  for (const PrimId& instancerId : instancers_)
    if (Instancer* copies = context.instancers.find(instancerId);
        copies && copies->prototype() == id())
      copies->dropCopies(context);
  context.lights.remove(id());
  context.scene.geometry().removeMesh(handle());
}

size_t Mesh::estimatedSyncBytes() const {
  return visible() ? estimatedBuildBytes(data_, subdivisionScheme_ != "none") : 0;
}

void Mesh::syncLight(SyncContext& context) {
  if (!light_) {
    context.lights.synced(id(), std::nullopt, context.scene, handle());
    return;
  }
  // It emits from the triangles the mesh is traced as (a subdivision surface's limit surface,
  // not its cage): next-event estimation draws the points rays meet.
  const auto* traced =
      visible() ? dynamic_cast<const MeshShape*>(context.scene.geometry().shape(handle()))
                : nullptr;
  std::shared_ptr<std::vector<Vec3f>> corners;
  std::shared_ptr<MovingMeshLight> moving;
  if (traced && !traced->triangles().triangles.empty()) {
    const TriangleMesh& surface = traced->triangles();
    const MotionTransform& motion = transform();
    std::vector<uint32_t> triangles = surface.triangles;
    // A mirroring transform keeps the surface's front where it was (its normals transform by
    // sign(det) · cofactor, as the geometry's do), but reverses its corners' winding.
    if (motion.first().linearDeterminant() < 0)
      for (size_t first = 0; first + 2 < triangles.size(); first += 3)
        std::swap(triangles[first + 1], triangles[first + 2]);
    corners = std::make_shared<std::vector<Vec3f>>();
    corners->reserve(triangles.size());
    for (const uint32_t point : triangles)
      corners->push_back(motion.first().applyToPoint(surface.points[point]));
    if (motion.isAnimated() || !surface.pointMotion.empty()) {
      moving = std::make_shared<MovingMeshLight>();
      moving->triangles.points = surface.points;
      moving->triangles.pointMotion = surface.pointMotion;
      moving->triangles.triangles = std::move(triangles);
      moving->objectToWorld = motion;
    }
  }
  light_->setVisible(corners != nullptr);
  light_->setMeshTriangles(std::move(corners), std::move(moving));
  light_->setTransform(transform());  // the light's frame: ShapingAPI shapes about its -Z
  light_->setLinkSlot(lightLinkSlot_);
  light_->syncDirty(context);
}

namespace {

/// The most `transform` lengthens a vector: what it scales a surface's curvature by, at most.
float largestStretch(const Transform& transform) {
  return std::max({length(transform.applyToVector({1, 0, 0})),
                   length(transform.applyToVector({0, 1, 0})),
                   length(transform.applyToVector({0, 0, 1}))});
}

/// How closely diced facets follow a primvar that varies over the limit surface: this fraction
/// of the primvar's range (halved per complexity level, as the positions' tolerance is).
constexpr float kPrimvarTolerance = 1.0f / 64;

/// The cage's vertex-interpolated data (primvars and displayColor) as points of up to three
/// components each (a fourth is left out), with each one's tolerance: kPrimvarTolerance of its
/// values' range. A face diced into facets across which such data varies non-linearly (a flat
/// face carries no curvature, yet its colours are bicubic on the limit surface) shows the
/// facets' linear interpolation instead.
std::vector<std::pair<std::vector<Vec3f>, float>> vertexData(const MeshData& cage) {
  std::vector<std::pair<std::vector<Vec3f>, float>> result;
  const auto add = [&](std::vector<Vec3f> values) {
    if (values.size() != cage.points.size()) return;  // the tessellator reports it
    Bounds3f bounds;
    for (const Vec3f& value : values) bounds.extend(value);
    const Vec3f range = bounds.upper - bounds.lower;
    const float tolerance = kPrimvarTolerance * std::max({range.x, range.y, range.z});
    if (tolerance > 0 && std::isfinite(tolerance))
      result.emplace_back(std::move(values), tolerance);
  };
  if (cage.displayColorInterpolation == Interpolation::Vertex && !cage.displayColor.empty())
    add(cage.displayColor);
  for (const Primvar& primvar : cage.primvars) {
    if (primvar.interpolation != Interpolation::Vertex || primvar.width < 1) continue;
    const size_t width = size_t(primvar.width), count = primvar.values.size() / width;
    std::vector<Vec3f> values(count);
    for (size_t i = 0; i < count; ++i) {
      float value[3] = {0, 0, 0};
      for (size_t c = 0; c < std::min<size_t>(width, 3); ++c)
        value[c] = primvar.values[i * width + c];
      values[i] = Vec3f(value[0], value[1], value[2]);
    }
    add(std::move(values));
  }
  return result;
}

/// Segments per edge that keep the cage's face-varying data (primvars and displayColor, one
/// value per face corner) within kPrimvarTolerance of its range where two triangles would
/// interpolate it linearly across a quad: the bilinear twist |f0 - f1 + f2 - f3| of a quad's
/// corners shrinks as 1/N² over N segments, and a triangle misses a quarter of it.
std::vector<int> faceVaryingRates(const MeshData& cage, float fraction) {
  std::vector<int> rates(cage.faceVertexCounts.size(), 1);
  const size_t corners = cage.faceVertexIndices.size();
  const auto add = [&](const float* values, size_t width) {
    float lower = kInfinity, upper = -kInfinity;
    for (size_t i = 0; i < corners * width; ++i) {
      lower = std::min(lower, values[i]);
      upper = std::max(upper, values[i]);
    }
    const float tolerance = fraction * kPrimvarTolerance * (upper - lower);
    if (!(tolerance > 0) || !std::isfinite(tolerance)) return;
    size_t start = 0;
    for (size_t face = 0; face < rates.size(); ++face) {
      const int count = cage.faceVertexCounts[face];
      if (count == 4) {
        float twist = 0;
        for (size_t c = 0; c < width; ++c) {
          const auto at = [&](size_t k) { return values[(start + k) * width + c]; };
          twist = std::max(twist, std::abs(at(0) - at(1) + at(2) - at(3)));
        }
        rates[face] = std::max(rates[face], tessellationRateFor(twist, tolerance));
      }
      start += size_t(std::max(count, 0));
    }
  };
  if (cage.displayColorInterpolation == Interpolation::FaceVarying && corners > 0 &&
      cage.displayColor.size() == corners) {
    std::vector<float> flat;
    for (const Vec3f& colour : cage.displayColor)
      flat.insert(flat.end(), {colour.x, colour.y, colour.z});
    add(flat.data(), 3);
  }
  for (const Primvar& primvar : cage.primvars)
    if (primvar.interpolation == Interpolation::FaceVarying && primvar.width >= 1 && corners > 0 &&
        primvar.values.size() == corners * size_t(primvar.width))
      add(primvar.values.data(), size_t(primvar.width));
  return rates;
}

}  // namespace

std::vector<int> Mesh::dicingRates(const LimitSurfaceTessellator& limit,
                                   const SyncContext& context) const {
  const MeshData& cage = data_;
  // Dice each base face finely enough that its facets stay within a fraction of a pixel of
  // the limit surface at its distance from the camera (halved per complexity level).
  const CameraParams& camera = context.dicing.camera;
  const Vec3f eye = camera.cameraToWorld.first().applyToPoint({0, 0, 0});
  const float pixelAngle =
      camera.projection == Projection::Perspective
          ? camera.horizontalAperture / camera.focalLength / float(context.dicing.imageWidth)
          : 0.0f;
  const float pixelWidth = 0.1f * camera.horizontalAperture / float(context.dicing.imageWidth);
  const float fraction = std::ldexp(1.0f, -context.complexity);
  // Its own placement and its copies' most demanding ones: each face is diced for the finest.
  std::vector<Transform> placements = {transform().first()};
  placements.insert(placements.end(), copyPlacements_.begin(), copyPlacements_.end());
  std::vector<int> rates(limit.faceCount(), 1);
  std::vector<const std::vector<Vec3f>*> samples = {&cage.points};
  for (const std::vector<Vec3f>& step : cage.pointMotion) samples.push_back(&step);
  size_t faceStart = 0;
  std::vector<size_t> faceStarts;
  for (const int count : cage.faceVertexCounts)
    faceStarts.push_back(faceStart), faceStart += size_t(count);
  std::vector<float> pixelsAcross(rates.size(), 0.0f);  // each face's longest edge, at open
  for (const std::vector<Vec3f>* points : samples) {
    const std::vector<float> bounds = limit.curvatureBounds(*points);
    for (const Transform& objectToWorld : placements) {
      // World-space curvature bounds: the transform's largest stretch scales them.
      const float stretch = largestStretch(objectToWorld);
      for (size_t face = 0; face < rates.size() && face < cage.faceVertexCounts.size(); ++face) {
        float nearest = kInfinity, longest = 0;
        const int count = cage.faceVertexCounts[face];
        for (int k = 0; k < count; ++k) {
          const auto corner = [&](int j) {
            return objectToWorld.applyToPoint(
                (*points)[size_t(cage.faceVertexIndices[faceStarts[face] + size_t(j % count)])]);
          };
          const Vec3f p = corner(k);
          nearest = std::min(nearest, length(p - eye));
          longest = std::max(longest, length(corner(k + 1) - p));
        }
        const float footprint =
            pixelAngle > 0 ? std::max(nearest, camera.nearClip) * pixelAngle : pixelWidth;
        rates[face] = std::max(rates[face],
                               tessellationRateFor(bounds[face] * stretch, fraction * footprint));
        if (points == &cage.points)
          pixelsAcross[face] = std::max(pixelsAcross[face], longest / footprint);
      }
    }
  }
  // Primvars vary over the limit surface as the positions do (a flat face carries no
  // curvature, yet its colours are bicubic or bilinear there): its facets must follow them
  // within a fraction of their range, though no finer than the face's pixels can show.
  std::vector<int> dataRates = faceVaryingRates(cage, fraction);
  for (const auto& [values, tolerance] : vertexData(cage)) {
    const std::vector<float> bounds = limit.curvatureBounds(values);
    for (size_t face = 0; face < dataRates.size() && face < bounds.size(); ++face)
      dataRates[face] =
          std::max(dataRates[face], tessellationRateFor(bounds[face], fraction * tolerance));
  }
  for (size_t face = 0; face < rates.size() && face < dataRates.size(); ++face) {
    const int visible = int(std::min(std::ceil(pixelsAcross[face]), float(kMaxTessellationRate)));
    rates[face] = std::max(rates[face], std::min(dataRates[face], std::max(visible, 1)));
  }
  return rates;
}

void Mesh::setCopyPlacements(const std::vector<const std::vector<MotionTransform>*>& copies,
                             const SyncContext& context) {
  std::vector<Transform> demanding;
  if (subdivisionScheme_ != "none" && !data_.points.empty()) {
    // The cage's bounding sphere, and each copy's distance from the dicing camera over its
    // size: the smallest ratios see the cage largest.
    Bounds3f bounds;
    for (const Vec3f& p : data_.points) bounds.extend(p);
    const Vec3f centre = (bounds.lower + bounds.upper) * 0.5f;
    const float radius = length(bounds.upper - bounds.lower) * 0.5f;
    const Vec3f eye = context.dicing.camera.cameraToWorld.first().applyToPoint({0, 0, 0});
    std::vector<std::pair<float, const Transform*>> ranked;
    for (const std::vector<MotionTransform>* transforms : copies)
      for (const MotionTransform& copy : *transforms) {
        const Transform& placed = copy.first();
        const float stretch = largestStretch(placed);
        if (!(stretch > 0) || !std::isfinite(stretch)) continue;
        const float distance = length(placed.applyToPoint(centre) - eye) - stretch * radius;
        ranked.emplace_back(distance / stretch, &placed);
      }
    const size_t kept = std::min(ranked.size(), kDicingCopies);
    std::partial_sort(ranked.begin(), ranked.begin() + long(kept), ranked.end(),
                      [](const auto& a, const auto& b) { return a.first < b.first; });
    for (size_t i = 0; i < kept; ++i) demanding.push_back(*ranked[i].second);
  }
  if (demanding.size() == copyPlacements_.size() &&
      std::equal(demanding.begin(), demanding.end(), copyPlacements_.begin(),
                 [](const Transform& a, const Transform& b) { return a.m == b.m; }))
    return;
  copyPlacements_ = std::move(demanding);
  markDirty(DirtyTransform);  // re-diced if its rates change (changedDicingRates)
}

std::optional<std::vector<int>> Mesh::changedDicingRates(const SyncContext& context) const {
  if (!tessellator_ || dicedRates_.empty()) return std::nullopt;
  std::vector<int> rates = dicingRates(*tessellator_, context);
  if (rates == dicedRates_) return std::nullopt;
  return rates;
}

TriangleMesh Mesh::triangles(SyncContext& context, std::optional<std::vector<int>> rates) {
  const std::optional<SubdivisionScheme> scheme = parseSubdivisionScheme(subdivisionScheme_);
  if (!scheme) return triangulate(data_);
  const MeshData& cage = data_;
  ++context.counters.subdivisionDicings;
  try {
    const LimitSurfaceTessellator& limit = *tessellator(*scheme, context);
    if (!rates) rates = dicingRates(limit, context);
    TriangleMesh result = limit.tessellate(cage.points, *rates);
    for (const std::vector<Vec3f>& step : cage.pointMotion)
      result.pointMotion.push_back(limit.tessellate(step, *rates).points);
    result.doubleSided = cage.doubleSided;
    result.closed = isClosedSurface(cage.points, cage.faceVertexCounts, cage.faceVertexIndices,
                                    tags_.holeIndices);
    dicedRates_ = std::move(*rates);
    return result;
  } catch (const std::invalid_argument& error) {
    // A cage that cannot be rendered either (bad indices, points that are not finite) throws
    // here: the mesh is then skipped with that one warning, not also told it renders its cage.
    TriangleMesh polygons = triangulate(cage);
    context.warn(id() + ": cannot subdivide (" + error.what() + "); rendering the control cage");
    return polygons;
  }
}

}  // namespace penumbra::plugin
