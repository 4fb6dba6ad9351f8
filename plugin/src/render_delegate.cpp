#include "penumbra/plugin/render_delegate.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace penumbra::plugin {

namespace {

/// A setting: an int or a float field, and its range.
struct SettingField {
  int RenderSettingsMap::*intField = nullptr;
  float RenderSettingsMap::*floatField = nullptr;
  double minimum = 0;
  double maximum = std::numeric_limits<int>::max();
};

SettingField intSetting(int RenderSettingsMap::*field, int minimum,
                        int maximum = std::numeric_limits<int>::max()) {
  return {field, nullptr, double(minimum), double(maximum)};
}

const std::map<std::string, SettingField>& settingFields() {
  static const std::map<std::string, SettingField> fields = {
      {"samples", intSetting(&RenderSettingsMap::samples, 1)},
      {"seed", intSetting(&RenderSettingsMap::seed, 0)},
      {"threads", intSetting(&RenderSettingsMap::threads, 0)},
      {"maxPathDepth", intSetting(&RenderSettingsMap::maxPathDepth, 0)},
      {"maxDiffuseDepth", intSetting(&RenderSettingsMap::maxDiffuseDepth, 0)},
      {"maxGlossyDepth", intSetting(&RenderSettingsMap::maxGlossyDepth, 0)},
      {"maxTransmissionDepth", intSetting(&RenderSettingsMap::maxTransmissionDepth, 0)},
      {"complexity", intSetting(&RenderSettingsMap::complexity, 0, 3)},
      {"directLighting", intSetting(&RenderSettingsMap::directLighting, 0, 2)},
      {"adaptiveThreshold", {nullptr, &RenderSettingsMap::adaptiveThreshold, 0, 1}},
      {"adaptiveMinSamples", intSetting(&RenderSettingsMap::adaptiveMinSamples, 2)},
      {"indirectClamp",
       {nullptr, &RenderSettingsMap::indirectClamp, 0, std::numeric_limits<float>::max()}},
      {"textureCacheMB", intSetting(&RenderSettingsMap::textureCacheMB, 16)}};
  return fields;
}

std::string formatValue(double value) {
  std::string text = std::to_string(value);
  text.erase(text.find_last_not_of('0') + 1);
  if (text.back() == '.') text.pop_back();
  return text;
}

}  // namespace

void RenderSettingsMap::set(const std::string& key, double value) {
  const auto found = settingFields().find(key);
  if (found == settingFields().end()) {
    std::string known;
    for (const auto& entry : settingFields()) known += (known.empty() ? "" : ", ") + entry.first;
    throw std::invalid_argument("unknown render setting '" + key + "' (known: " + known + ")");
  }
  const SettingField& setting = found->second;
  if (!(value >= setting.minimum && value <= setting.maximum))
    throw std::invalid_argument("render setting " + key + " must be in [" +
                                formatValue(setting.minimum) + ", " + formatValue(setting.maximum) +
                                "], got " + formatValue(value));
  if (setting.intField) {
    if (value != std::floor(value))
      throw std::invalid_argument("render setting " + key + " must be an integer, got " +
                                  formatValue(value));
    this->*(setting.intField) = int(value);
  } else {
    this->*(setting.floatField) = float(value);
  }
}

std::map<std::string, double> RenderSettingsMap::asMap() const {
  std::map<std::string, double> values;
  for (const auto& [key, entry] : settingFields())
    values[key] = entry.intField ? double(this->*(entry.intField)) : this->*(entry.floatField);
  return values;
}

RenderDelegate::RenderDelegate(const std::string& colorConfig)
    : scene_(std::make_unique<Scene>(device_, colorConfig)) {}

// The scene (and its Embree objects) must go before the device.
RenderDelegate::~RenderDelegate() {
  prims_.clear();
  scene_.reset();
}

void RenderDelegate::insertRprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type == "mesh")
    prims_[id] = std::make_unique<Mesh>(id, scene_->addMesh());
  else if (type == "instancer")
    prims_[id] = std::make_unique<Instancer>(id, scene_->addInstancer());
  else
    throw std::invalid_argument(id + ": unsupported rprim type '" + type + "'");
  meshesStructureChanged_ = true;
}

void RenderDelegate::insertBprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type != "renderBuffer")
    throw std::invalid_argument(id + ": unsupported bprim type '" + type + "'");
  prims_[id] = std::make_unique<RenderBuffer>(id);
}

void RenderDelegate::insertSprim(const std::string& type, const PrimId& id) {
  if (hasPrim(id)) throw std::invalid_argument(id + ": a prim with this id already exists");
  if (type == "camera") {
    prims_[id] = std::make_unique<Camera>(id);
  } else if (type == "material") {
    prims_[id] = std::make_unique<Material>(id);
    materialsStructureChanged_ = true;
  } else if (isLightTypeName(type)) {
    prims_[id] = std::make_unique<Light>(id, lightTypeFromName(type));
    lightsStructureChanged_ = true;
  } else {
    throw std::invalid_argument(id + ": unsupported sprim type '" + type + "'");
  }
}

void RenderDelegate::removePrim(const PrimId& id) {
  Prim& removed = prim(id);
  if (auto* mesh = dynamic_cast<Mesh*>(&removed)) {
    // Instancers of this mesh lose their copies (and get them back if it is inserted again).
    for (auto& [otherId, other] : prims_)
      if (auto* copies = dynamic_cast<Instancer*>(other.get());
          copies && copies->prototype() == id) {
        scene_->removeInstancer(copies->handle());
        copies->setHandle(scene_->addInstancer());
        copies->markDirty(DirtyTransform);
      }
    if (mesh->light()) lightsStructureChanged_ = true;
    scene_->removeMesh(mesh->handle());
    meshesStructureChanged_ = true;
  }
  if (auto* copies = dynamic_cast<Instancer*>(&removed)) {
    scene_->removeInstancer(copies->handle());
    meshesStructureChanged_ = true;
  }
  if (dynamic_cast<Material*>(&removed)) materialsStructureChanged_ = true;
  if (dynamic_cast<Light*>(&removed)) lightsStructureChanged_ = true;
  prims_.erase(id);
}

bool RenderDelegate::hasPrim(const PrimId& id) const {
  return prims_.count(id) != 0;
}

std::vector<PrimId> RenderDelegate::primIds() const {
  std::vector<PrimId> ids;
  for (const auto& entry : prims_) ids.push_back(entry.first);
  return ids;
}

Prim& RenderDelegate::prim(const PrimId& id) {
  const auto found = prims_.find(id);
  if (found == prims_.end()) throw std::out_of_range(id + ": no such prim in the render index");
  return *found->second;
}

namespace {
template <typename T>
T& primAs(Prim& prim, const char* typeName) {
  if (auto* typed = dynamic_cast<T*>(&prim)) return *typed;
  throw std::out_of_range(prim.id() + ": prim is not a " + typeName);
}
}  // namespace

Mesh& RenderDelegate::mesh(const PrimId& id) {
  return primAs<Mesh>(prim(id), "mesh");
}
RenderBuffer& RenderDelegate::renderBuffer(const PrimId& id) {
  return primAs<RenderBuffer>(prim(id), "render buffer");
}
Instancer& RenderDelegate::instancer(const PrimId& id) {
  return primAs<Instancer>(prim(id), "instancer");
}
Camera& RenderDelegate::camera(const PrimId& id) {
  return primAs<Camera>(prim(id), "camera");
}
Light& RenderDelegate::light(const PrimId& id) {
  return primAs<Light>(prim(id), "light");
}
Material& RenderDelegate::material(const PrimId& id) {
  return primAs<Material>(prim(id), "material");
}

std::vector<std::string> RenderDelegate::takeWarnings() {
  std::vector<std::string> taken;
  taken.swap(warnings_);
  return taken;
}

penumbra::Material RenderDelegate::buildMaterial(const Material& material, bool report) {
  penumbra::Material result;
  result.constants = material.params();
  for (const auto& [input, source] : material.connections()) {
    InputConnection connection;
    connection.input = input;
    if (source.texture) {
      const TextureNode& node = *source.texture;
      TextureReader reader = node.reader;
      std::string error;
      reader.texture = scene_->textures().open(node.file, node.colorSpace, &error);
      if (reader.texture == TextureSystem::kInvalid && report)
        warn(material.id() + ": " + error + "; its fallback value is used");
      connection.texture = int(result.textures.size());
      result.textures.push_back(std::move(reader));
      std::tie(connection.firstChannel, connection.channelCount) =
          parseTextureOutput(source.output);
    } else {
      connection.primvar = source.primvar;
      connection.fallback = source.fallback;
    }
    result.connections.push_back(std::move(connection));
  }
  return result;
}

void RenderDelegate::syncMaterials() {
  std::vector<penumbra::Material> materials;
  materialIndex_.clear();
  for (auto& [id, prim] : prims_) {
    if (auto* material = dynamic_cast<Material*>(prim.get())) {
      materialIndex_[id] = int(materials.size());
      // Problems (missing textures) are reported when the material changes, not every sync.
      materials.push_back(buildMaterial(*material, material->dirtyBits() != Clean));
      if (material->dirtyBits() != Clean) material->markClean();
    }
  }
  scene_->setMaterials(std::move(materials));
}

void RenderDelegate::syncLights() {
  std::vector<penumbra::Light> lights;
  const auto add = [&](const PrimId& id, const LightParams& params) {
    try {
      lights.emplace_back(params);
      return int(lights.size()) - 1;
    } catch (const std::invalid_argument& error) {
      warn(id + ": " + error.what() + "; the light is skipped");
      return -1;
    }
  };
  for (auto& [id, prim] : prims_) {
    if (auto* light = dynamic_cast<Light*>(prim.get())) {
      if (light->dirtyBits() & DirtyParams) {
        try {
          light->loadTexture(scene_->sharedTextures());
        } catch (const std::runtime_error& error) {
          warn(id + ": " + error.what() + "; the light renders without its texture");
        }
      }
      if (light->visible()) add(id, light->params());
      if (light->dirtyBits() != Clean) light->markClean();
    } else if (auto* mesh = dynamic_cast<Mesh*>(prim.get())) {
      int index = -1;
      if (mesh->light() && mesh->visible()) {
        // The light samples the polygons (the cage of a subdivision surface) at shutter open.
        LightParams params = mesh->light()->params();
        auto corners = std::make_shared<std::vector<Vec3f>>();
        try {
          const TriangleMesh triangles = triangulate(mesh->data());
          const Transform& toWorld = mesh->transform().first();
          for (const uint32_t point : triangles.triangles)
            corners->push_back(toWorld.applyToPoint(triangles.points[point]));
          params.meshTriangles = std::move(corners);
          index = add(id, params);
        } catch (const std::invalid_argument&) {
          // The mesh itself is skipped with a warning at its sync.
        }
      }
      scene_->setMeshLight(mesh->handle(), index);
    }
  }
  scene_->setLights(std::move(lights));
}

bool DicingContext::operator==(const DicingContext& other) const {
  const CameraParams &a = camera, &b = other.camera;
  return imageWidth == other.imageWidth && a.cameraToWorld.first().m == b.cameraToWorld.first().m &&
         a.focalLength == b.focalLength && a.horizontalAperture == b.horizontalAperture &&
         a.projection == b.projection && a.nearClip == b.nearClip;
}

TriangleMesh RenderDelegate::meshTriangles(Mesh& mesh, const DicingContext& dicing) {
  const std::optional<SubdivisionScheme> scheme = parseSubdivisionScheme(mesh.subdivisionScheme());
  if (!scheme) return triangulate(mesh.data());
  const MeshData& cage = mesh.data();
  try {
    const LimitSurfaceTessellator& tessellator = *mesh.tessellator(*scheme);
    // Dice each base face finely enough that its facets stay within a fraction of a pixel of
    // the limit surface at its distance from the camera (halved per complexity level).
    const CameraParams& camera = dicing.camera;
    const Transform& objectToWorld = mesh.transform().first();
    const Vec3f eye = camera.cameraToWorld.first().applyToPoint({0, 0, 0});
    const float pixelAngle =
        camera.projection == Projection::Perspective
            ? camera.horizontalAperture / camera.focalLength / float(dicing.imageWidth)
            : 0.0f;
    const float pixelWidth = 0.1f * camera.horizontalAperture / float(dicing.imageWidth);
    const float fraction = std::ldexp(1.0f, -settings_.complexity);
    // World-space curvature bounds: the transform's largest stretch scales them.
    const float stretch = std::max({length(objectToWorld.applyToVector({1, 0, 0})),
                                    length(objectToWorld.applyToVector({0, 1, 0})),
                                    length(objectToWorld.applyToVector({0, 0, 1}))});
    std::vector<int> rates(tessellator.faceCount(), 1);
    std::vector<const std::vector<Vec3f>*> samples = {&cage.points};
    for (const std::vector<Vec3f>& step : cage.pointMotion) samples.push_back(&step);
    size_t faceStart = 0;
    std::vector<size_t> faceStarts;
    for (const int count : cage.faceVertexCounts)
      faceStarts.push_back(faceStart), faceStart += size_t(count);
    for (const std::vector<Vec3f>* points : samples) {
      const std::vector<float> bounds = tessellator.curvatureBounds(*points);
      for (size_t face = 0; face < rates.size() && face < cage.faceVertexCounts.size(); ++face) {
        float nearest = kInfinity;
        for (int k = 0; k < cage.faceVertexCounts[face]; ++k) {
          const Vec3f p = objectToWorld.applyToPoint(
              (*points)[size_t(cage.faceVertexIndices[faceStarts[face] + size_t(k)])]);
          nearest = std::min(nearest, length(p - eye));
        }
        const float footprint =
            pixelAngle > 0 ? std::max(nearest, camera.nearClip) * pixelAngle : pixelWidth;
        rates[face] = std::max(rates[face],
                               tessellationRateFor(bounds[face] * stretch, fraction * footprint));
      }
    }
    TriangleMesh result = tessellator.tessellate(cage.points, rates);
    for (const std::vector<Vec3f>& step : cage.pointMotion)
      result.pointMotion.push_back(tessellator.tessellate(step, rates).points);
    result.doubleSided = cage.doubleSided;
    result.closed = isClosedSurface(cage.points, cage.faceVertexCounts, cage.faceVertexIndices);
    return result;
  } catch (const std::invalid_argument& error) {
    warn(mesh.id() + ": cannot subdivide (" + error.what() + "); rendering the control cage");
    return triangulate(cage);
  }
}

void RenderDelegate::syncMesh(Mesh& mesh, bool materialsChanged, const DicingContext& dicing) {
  const uint32_t bits = mesh.dirtyBits();
  if (bits & (DirtyTopology | DirtyPoints | DirtyPrimvar | DirtyDoubleSided)) {
    for (const std::string& problem : mesh.dropInvalidPrimvars())
      warn(mesh.id() + ": " + problem + "; materials reading it use their fallback");
    try {
      scene_->setMeshGeometry(mesh.handle(), meshTriangles(mesh, dicing));
    } catch (const std::invalid_argument& error) {
      warn(mesh.id() + ": " + error.what() + "; the mesh is skipped");
      scene_->clearMeshGeometry(mesh.handle());
    }
  }
  int materialIndex = Scene::kNoMaterial;
  if (!mesh.materialId().empty()) {
    const auto found = materialIndex_.find(mesh.materialId());
    if (found != materialIndex_.end())
      materialIndex = found->second;
    else if (bits & DirtyMaterialId)
      warn(mesh.id() + ": bound material " + mesh.materialId() +
           " is not in the render index; displayColor is used");
  }
  if (bits != Clean || materialsChanged)
    scene_->setMeshInstance(mesh.handle(), mesh.transform(), materialIndex, mesh.visible());
  if (bits != Clean) mesh.markClean();
}

void RenderDelegate::syncInstancer(Instancer& copies) {
  const auto found = prims_.find(copies.prototype());
  auto* prototype = found == prims_.end() ? nullptr : dynamic_cast<Mesh*>(found->second.get());
  if (!prototype) {
    warn(copies.id() + ": prototype " + copies.prototype() +
         " is not a mesh in the render index; the instances are skipped");
    scene_->removeInstancer(copies.handle());
    copies.setHandle(scene_->addInstancer());
  } else {
    scene_->setInstances(copies.handle(), prototype->handle(), copies.transforms(),
                         copies.visible());
    try {
      scene_->setInstancePrimvars(copies.handle(), copies.primvars());
    } catch (const std::invalid_argument& error) {
      warn(copies.id() + ": " + error.what() + "; the per-instance primvars are ignored");
      scene_->setInstancePrimvars(copies.handle(), {});
    }
  }
  copies.markClean();
}

size_t RenderDelegate::estimatedSyncBytes() const {
  size_t bytes = 0;
  for (const auto& [id, prim] : prims_) {
    if (prim->dirtyBits() == Clean) continue;
    if (const auto* mesh = dynamic_cast<const Mesh*>(prim.get()); mesh && mesh->visible())
      bytes += estimatedBuildBytes(mesh->data(), mesh->subdivisionScheme() != "none");
    else if (const auto* copies = dynamic_cast<const Instancer*>(prim.get());
             copies && copies->visible())
      bytes += estimatedInstanceBytes(
          copies->transforms().size(),
          copies->transforms().empty() ? 1 : copies->transforms()[0].steps().size());
  }
  return bytes;
}

bool RenderDelegate::sync(const DicingContext& dicing) {
  scene_->textures().setCacheSize(size_t(settings_.textureCacheMB) << 20);
  // A new dicing camera or complexity re-dices every subdivision surface.
  if (dicedFor_ != dicing || dicedComplexity_ != settings_.complexity) {
    for (auto& [id, prim] : prims_)
      if (auto* mesh = dynamic_cast<Mesh*>(prim.get()); mesh && mesh->subdivisionScheme() != "none")
        mesh->markDirty(DirtyPoints);
    dicedFor_ = dicing;
    dicedComplexity_ = settings_.complexity;
  }
  bool materialsDirty = materialsStructureChanged_, lightsDirty = lightsStructureChanged_;
  bool meshesDirty = meshesStructureChanged_, camerasDirty = false;
  for (const auto& [id, prim] : prims_) {
    if (prim->dirtyBits() == Clean) continue;
    if (dynamic_cast<Material*>(prim.get()))
      materialsDirty = true;
    else if (dynamic_cast<Light*>(prim.get()))
      lightsDirty = true;
    else if (dynamic_cast<Mesh*>(prim.get()) || dynamic_cast<Instancer*>(prim.get()))
      meshesDirty = true;
    else if (dynamic_cast<Camera*>(prim.get()))
      camerasDirty = true;
  }
  // Mesh lights follow their meshes' geometry, transform and light inputs.
  for (const auto& [id, prim] : prims_)
    if (auto* mesh = dynamic_cast<Mesh*>(prim.get());
        mesh && mesh->dirtyBits() != Clean && (mesh->light() || (mesh->dirtyBits() & DirtyParams)))
      lightsDirty = true;
  if (materialsDirty) syncMaterials();
  if (lightsDirty) syncLights();
  if (meshesDirty || materialsDirty) {
    for (auto& [id, prim] : prims_)
      if (auto* mesh = dynamic_cast<Mesh*>(prim.get())) syncMesh(*mesh, materialsDirty, dicing);
    // After the meshes: copies follow their prototype's geometry, placed by the scene.
    for (auto& [id, prim] : prims_)
      if (auto* copies = dynamic_cast<Instancer*>(prim.get());
          copies && copies->dirtyBits() != Clean)
        syncInstancer(*copies);
  }
  for (auto& [id, prim] : prims_)
    if ((dynamic_cast<Camera*>(prim.get()) || dynamic_cast<RenderBuffer*>(prim.get())) &&
        prim->dirtyBits() != Clean)
      prim->markClean();
  materialsStructureChanged_ = lightsStructureChanged_ = meshesStructureChanged_ = false;
  const bool sceneChanged = materialsDirty || lightsDirty || meshesDirty;
  if (sceneChanged) {
    scene_->commit();
    ++sceneVersion_;
  }
  return sceneChanged || camerasDirty;
}

}  // namespace penumbra::plugin
