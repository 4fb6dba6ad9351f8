// Light sprims: one class for the UsdLux intrinsic lights, the type fixed at insertion, and for
// the light of a mesh with UsdLuxMeshLightAPI (which its mesh owns and syncs).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/file_stamp.h"
#include "penumbra/light.h"
#include "penumbra/motion.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"
#include "penumbra/scene.h"

namespace penumbra::plugin {

class Light : public Prim {
 public:
  /// `emittingMesh`: for a mesh light (LightType::Mesh), the mesh whose surface emits.
  Light(PrimId id, LightType type, std::optional<Geometry::MeshId> emittingMesh = std::nullopt);

  /// Sets an input of lightInputs() (plugin/light_types.h) by its name: a UsdLux input without
  /// "inputs:" ("shaping:cone:angle"), or cameraVisible.
  /// Throws std::invalid_argument for an unknown name or a value of the wrong type.
  void setParam(const std::string& name, const ParamValue& value);
  /// Lights keep their transform at the start of the shutter (motion blur of lights is not
  /// supported yet): only the first sample is used. Mesh lights move with their mesh
  /// (setMeshTriangles); this is their frame for ShapingAPI.
  void setTransform(const MotionTransform& lightToWorld) override;
  void setVisible(bool visible) override;
  /// A mesh light's emitting triangles in world space (3 points each) at shutter open, and
  /// where they are over the shutter if its mesh moves (null if not), set by its mesh's sync.
  void setMeshTriangles(std::shared_ptr<const std::vector<Vec3f>> triangles,
                        std::shared_ptr<const MovingMeshLight> motion);
  /// Its light and shadow linking slot (LinkingTable; -1: it lights and shadows everything).
  void setLinkSlot(int slot) {
    params_.linkSlot = slot;
    markDirty(DirtyParams);
  }

  /// Builds its renderer light from what its dirty bits say changed (cf. HdLight::Sync):
  /// texture:file and shaping:ies:file are loaded only when they name another file or the
  /// file changed on disk (a warning names a file that cannot be read: the light then renders
  /// untextured, or unshaped by a profile), and a light whose inputs are invalid is skipped
  /// with a warning, once per change. The renderer light goes to the scene's light list
  /// (SyncContext::lights), which the light joins or where it replaces its entry; a hidden or
  /// skipped light leaves the list.
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Leaves the scene's light list.
  void finalize(SyncContext& context) override;

  const LightParams& params() const { return params_; }
  bool visible() const { return visible_; }
  /// Whether its texture or IES file was written (or made) since it was loaded: the light is
  /// then to sync again (a repainted sky between two renders).
  bool filesChanged() const { return texture_.changedOnDisk() || ies_.changedOnDisk(); }

 private:
  /// An asset input: the file it names, and the one loaded, with its stamp as it was then.
  struct AssetInput {
    std::string file, loadedFile;
    std::optional<FileStamp> loadedStamp;

    bool changedOnDisk() const {
      return !loadedFile.empty() && fileStamp(loadedFile) != loadedStamp;
    }
    /// Whether the file is to be loaded (another one named, or changed on disk); it counts as
    /// loaded from then on.
    bool takeReload() {
      if (file == loadedFile && !changedOnDisk()) return false;
      loadedFile = file;
      loadedStamp = file.empty() ? std::nullopt : fileStamp(file);
      return true;
    }
  };

  /// Loads texture:file if it changed since the last call. Throws std::runtime_error naming the
  /// file when it cannot be read.
  void loadTexture(SyncContext& context);
  /// Loads shaping:ies:file likewise, through the context's cache of profiles. Throws
  /// std::invalid_argument naming the file when it cannot be read or parsed.
  void loadIes(SyncContext& context);

  LightParams params_;
  bool visible_ = true;
  AssetInput texture_, ies_;
  std::optional<Geometry::MeshId> emittingMesh_;
};

}  // namespace penumbra::plugin
