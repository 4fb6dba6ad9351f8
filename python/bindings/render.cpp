// Rendering: the delegate's sync state (render settings, dicing camera, statistics, warnings),
// render buffers and RenderPass, whose execute() a Ctrl-C stops.
#include <pybind11/stl.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <exception>
#include <future>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "bindings.h"
#include "conversions.h"
#include "penumbra/plugin/render_pass.h"

namespace penumbra::bindings {
namespace {

using plugin::RenderBuffer;
using plugin::RenderDelegate;
using plugin::RenderPass;

// How often a render looks for Python signals (Ctrl-C) while it runs.
constexpr std::chrono::milliseconds kSignalPollInterval{50};

// Runs `pass.execute(samples)` on a worker thread while the calling thread, without the GIL,
// runs Python's signal handlers every kSignalPollInterval (they run only in the main thread,
// between bytecodes, so a render holding that thread would never see Ctrl-C). A handler that
// raises (SIGINT: KeyboardInterrupt) cancels the render, which drops its samples, and the
// exception propagates.
void executeInterruptibly(RenderPass& pass, int samples) {
  std::atomic<bool> cancel{false};
  std::exception_ptr failure;
  std::promise<void> finished;
  std::future<void> done = finished.get_future();
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    std::thread worker([&] {
      try {
        pass.execute(samples, &cancel);
      } catch (...) {
        failure = std::current_exception();
      }
      finished.set_value();
    });
    while (done.wait_for(kSignalPollInterval) != std::future_status::ready) {
      py::gil_scoped_acquire acquire;
      if (PyErr_CheckSignals() != 0) {
        interrupted = true;
        cancel = true;
        break;
      }
    }
    worker.join();
  }
  if (interrupted) throw py::error_already_set();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace

void bindRender(py::module_& m, DelegateClass& delegate) {
  delegate
      .def(
          "allocate_render_buffer",
          [](RenderDelegate& self, const std::string& id, int width, int height) {
            self.renderBuffer(id).allocate(width, height);
          },
          py::arg("id"), py::arg("width"), py::arg("height"))
      .def(
          "render_buffer",
          [](RenderDelegate& self, const std::string& id) {
            const RenderBuffer& buffer = self.renderBuffer(id);
            py::array_t<float> result({buffer.height(), buffer.width(), buffer.channels()});
            if (!buffer.data().empty())
              std::memcpy(result.mutable_data(), buffer.data().data(),
                          buffer.data().size() * sizeof(float));
            return py::make_tuple(result, buffer.converged());
          },
          py::arg("id"));
  delegate
      .def(
          "set_render_setting",
          [](RenderDelegate& self, const std::string& key, double value) {
            self.settings().set(key, value);
          },
          py::arg("key"), py::arg("value"))
      .def("render_settings", [](const RenderDelegate& self) { return self.settings().asMap(); })
      .def(
          "dirty_bits",
          [](RenderDelegate& self, const std::string& id) { return self.prim(id).dirtyBits(); },
          py::arg("id"))
      .def(
          "set_dicing_camera",
          [](RenderDelegate& self, const std::string& cameraId) { self.setDicingCamera(cameraId); },
          py::arg("camera_id"))
      .def("dicing_camera", &RenderDelegate::dicingCamera)
      .def("sync_statistics",
           [](const RenderDelegate& self) {
             const RenderDelegate::SyncStatistics stats = self.syncStatistics();
             py::dict result;
             result["meshGeometrySyncs"] = stats.meshGeometrySyncs;
             result["subdivisionDicings"] = stats.subdivisionDicings;
             result["meshBvhBuilds"] = stats.meshBvhBuilds;
             result["topLevelBvhPrimitives"] = stats.topLevelBvhPrimitives;
             result["tessellationSeconds"] = stats.tessellationSeconds;
             result["bvhBuildSeconds"] = stats.bvhBuildSeconds;
             result["materialBuilds"] = stats.materialBuilds;
             result["materialTextureOpens"] = stats.materialTextureOpens;
             result["lightBuilds"] = stats.lightBuilds;
             result["lightTextureLoads"] = stats.lightTextureLoads;
             result["volumeFieldReads"] = stats.volumeFieldReads;
             result["volumeBytes"] = stats.volumeBytes;
             return result;
           })
      .def(
          "sync_count",
          [](RenderDelegate& self, const std::string& id) { return self.prim(id).syncCount(); },
          py::arg("id"))
      .def("estimated_sync_bytes", &RenderDelegate::estimatedSyncBytes)
      .def("take_warnings", &RenderDelegate::takeWarnings)
      .def("prim_id_manifest", &RenderDelegate::primIdManifest,
           "The mesh prims by the value the primId AOV gives them.");

  py::class_<RenderPass>(m, "RenderPass")
      .def(py::init([](RenderDelegate& renderDelegate, std::string cameraId, int width, int height,
                       std::optional<std::array<int, 4>> crop, int margin) {
             if (!crop)
               return std::make_unique<RenderPass>(renderDelegate, cameraId, width, height);
             const auto [x, y, cropWidth, cropHeight] = *crop;
             return std::make_unique<RenderPass>(renderDelegate, cameraId, width, height,
                                                 PixelRect{x, y, cropWidth, cropHeight}, margin);
           }),
           py::arg("delegate"), py::arg("camera_id"), py::arg("width"), py::arg("height"),
           py::arg("crop") = py::none(), py::arg("margin") = 0, py::keep_alive<1, 2>())
      .def_static("adaptive_sampling_reach", &RenderPass::adaptiveSamplingReach, py::arg("samples"),
                  py::arg("min_samples"))
      .def("execute", &executeInterruptibly, py::arg("samples"))
      .def("reset", &RenderPass::reset)
      .def("set_aov_bindings", &RenderPass::setAovBindings, py::arg("bindings"))
      .def("set_aovs", &RenderPass::setAovs, py::arg("names"),
           "Accumulate these AOVs besides color, alpha, Z and sampleCount (a change restarts).")
      .def(
          "save_state",
          [](const RenderPass& self, const std::string& renderKey) {
            const std::vector<uint8_t> state = self.saveState(renderKey);
            return py::bytes(reinterpret_cast<const char*>(state.data()), state.size());
          },
          py::arg("render_key"),
          "The pass's exact state (samples done, accumulators) under render_key, as bytes.")
      .def(
          "load_state",
          [](RenderPass& self, const py::bytes& state, const std::string& renderKey) {
            const std::string bytes = state;
            self.loadState(std::vector<uint8_t>(bytes.begin(), bytes.end()), renderKey);
          },
          py::arg("state"), py::arg("render_key"),
          "Continue from save_state's bytes (after execute(0)); ValueError for a state of "
          "another render key, size, crop, AOV set or settings.")
      .def_property_readonly("samples_done", &RenderPass::samplesDone)
      .def_property_readonly("mean_samples", &RenderPass::meanSamples)
      .def_property_readonly("samples_taken", &RenderPass::samplesTaken)
      .def_property_readonly("rays_traced", &RenderPass::raysTraced)
      .def_property_readonly("light_paths_traced", &RenderPass::lightPathsTraced,
                             "Light paths traced for caustics so far (docs/caustics.md): 0 "
                             "where the light tracer took nothing")
      .def_property_readonly("constant_dome_share", &RenderPass::constantDomeShareUsed,
                             "The share of an untextured dome's light the shadow ray takes at "
                             "the first surfaces: the dome_sampling setting's, or the pilot's "
                             "choice (docs/dome-sampling.md)")
      .def_property_readonly("indirect_samples", &RenderPass::indirectSamplesUsed,
                             "The paths that go on from each camera ray's first surface: the "
                             "indirect_samples setting's, or (0) the mean over the image's "
                             "pixels of the pilot's counts per region (docs/branching.md)")
      .def_property_readonly("light_samples", &RenderPass::lightSamplesUsed,
                             "The estimates of the direct light at each camera ray's first "
                             "surface: the light_samples setting's, or (0) the pilot's choice "
                             "(docs/branching.md)")
      .def(
          "measure_raw_throughput",
          [](RenderPass& self) {
            penumbra::RawRayThroughput result;
            {
              py::gil_scoped_release release;
              result = self.measureRawThroughput();
            }
            py::dict out;
            out["primary"] = result.primary;
            out["bounce_intersect"] = result.bounceIntersect;
            out["bounce_occluded"] = result.bounceOccluded;
            out["bounce_rays"] = result.bounceRays;
            out["path"] = result.pathRays;
            out["path_rays"] = result.pathRayCount;
            return out;
          },
          "Embree alone on this pass's scene and camera: rays per second of camera rays, "
          "cosine bounce rays (intersect), the same rays as shadow rays (occluded), and the "
          "rays that one sample per pixel traces with the render settings ('path': its paths' "
          "rays and their shadow rays, each intersected or tested as traced).")
      .def_property_readonly("converged", &RenderPass::converged)
      .def_property_readonly("width", &RenderPass::width)
      .def_property_readonly("height", &RenderPass::height)
      .def_static("aov_names", &RenderPass::aovNames)
      .def(
          "aov",
          [](const RenderPass& self, const std::string& name) {
            const int channels = self.aovChannels(name);
            const std::vector<float> values = self.aov(name);
            py::array_t<float> result({self.height(), self.width(), channels});
            std::memcpy(result.mutable_data(), values.data(), values.size() * sizeof(float));
            return result;
          },
          py::arg("name"))
      .def(
          "cryptomatte",
          [](const RenderPass& self, const std::map<std::string, std::vector<std::string>>& names,
             const std::map<std::string, std::vector<std::string>>& subsetNames) {
            const std::vector<float> values = self.cryptomatte(names, subsetNames);
            const int channels =
                int(values.size() / (size_t(self.width()) * size_t(self.height())));
            py::array_t<float> result({self.height(), self.width(), channels});
            std::memcpy(result.mutable_data(), values.data(), values.size() * sizeof(float));
            return result;
          },
          py::arg("names"),
          py::arg("subset_names") = std::map<std::string, std::vector<std::string>>{},
          "A Cryptomatte AOV (H, W, 4 per two ranks): (id, coverage) pairs by coverage, ids "
          "from `names` (delegate prim id -> its placement's name, or an instancer's copies'); "
          "a material layer's `subset_names` (mesh id -> the name of each of its subsets' "
          "materials, in set_subset_materials' order) name the faces those subsets bind.");
  m.def(
      "murmur_hash3", [](const std::string& bytes) { return murmurHash3(bytes); }, py::arg("name"),
      "MurmurHash3_x86_32 (seed 0) of the UTF-8 bytes of a name.");
  m.def("cryptomatte_bits", &cryptomatteBits, py::arg("hash"),
        "The bits of the float a Cryptomatte image stores for a hash (as a manifest names it).");
}

}  // namespace penumbra::bindings
