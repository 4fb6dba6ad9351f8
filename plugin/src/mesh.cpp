#include "penumbra/plugin/mesh.h"

#include <stdexcept>

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
    auto light = std::make_unique<Light>(id(), LightType::Mesh);
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

const LimitSurfaceTessellator* Mesh::tessellator(SubdivisionScheme scheme) {
  if (!tessellator_) tessellator_ = std::make_unique<LimitSurfaceTessellator>(data_, scheme, tags_);
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

void Mesh::setMaterialId(PrimId materialId) {
  materialId_ = std::move(materialId);
  markDirty(DirtyMaterialId);
}

void Mesh::setTransform(const MotionTransform& objectToWorld) {
  objectToWorld_ = objectToWorld;
  markDirty(DirtyTransform);
}

void Mesh::setVisible(bool visible) {
  visible_ = visible;
  markDirty(DirtyVisibility);
}

void Mesh::setPassVisibility(PassVisibility pass) {
  pass_ = pass;
  markDirty(DirtyVisibility);
}

}  // namespace penumbra::plugin
