#include "penumbra/scene.h"

#include <chrono>

namespace penumbra {

Scene::Scene(const Device& device, const std::string& colorConfig)
    : materials_(colorConfig), geometry_(device, materials_), lights_(device) {}

void Scene::setMaterial(size_t index, Material material) {
  geometry_.followMaterial(index, materials_.replace(index, std::move(material)));
}

void Scene::commit() {
  const auto started = std::chrono::steady_clock::now();
  geometry_.commit();
  lights_.commit();
  volumes_.commit();
  commitSeconds_ +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  materials_.commit();
}

}  // namespace penumbra
