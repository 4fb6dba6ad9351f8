// The areas of penumbra._core, each bound by its own file; module.cpp calls them in order.
#pragma once

#include <pybind11/pybind11.h>

#include "penumbra/plugin/render_delegate.h"

namespace penumbra::bindings {

using DelegateClass = pybind11::class_<plugin::RenderDelegate>;

/// Prims: insertion and removal, meshes (MeshRecord, set_mesh, set_meshes and the per-aspect
/// setters), instancers, transforms, visibility, cameras and lights (scene_bindings.cpp).
void bindScene(pybind11::module_& m, DelegateClass& delegate);
/// Points rprims: set_points (points.cpp).
void bindPoints(pybind11::module_& m, DelegateClass& delegate);
/// Curves rprims: set_curves (curves.cpp).
void bindCurves(pybind11::module_& m, DelegateClass& delegate);
/// Volume rprims: set_volume; and write_vdb (volumes.cpp).
void bindVolumes(pybind11::module_& m, DelegateClass& delegate);
/// Materials: set_material and the dict schemas of its networks (materials.cpp).
void bindMaterials(pybind11::module_& m, DelegateClass& delegate);
/// The delegate's sync state (render settings, dicing camera, statistics, warnings), render
/// buffers and RenderPass (render.cpp).
void bindRender(pybind11::module_& m, DelegateClass& delegate);
/// Image files and colour management (images.cpp).
void bindImages(pybind11::module_& m);
/// The vocabulary tables (render options, light types, material inputs), from which the front
/// ends derive their spellings (vocabularies.cpp).
void bindVocabularies(pybind11::module_& m);

}  // namespace penumbra::bindings
