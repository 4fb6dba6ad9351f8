// Material sprim: a UsdPreviewSurface's inputs, constant or connected to a shader network
// (UsdUVTexture with its coordinates, UsdPrimvarReader_*).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/file_stamp.h"
#include "penumbra/material.h"
#include "penumbra/plugin/prim.h"
#include "penumbra/plugin/sync_context.h"

namespace penumbra::plugin {

/// A UsdUVTexture (or MaterialX image) as the scene delegate describes it: the file by path
/// (resolved; may hold <UDIM>) and colour space, and the node's other inputs (`reader.texture`
/// is set at sync, when the file is opened).
struct TextureNode {
  std::string file;
  TextureColorSpace colorSpace;
  TextureReader reader;
};

/// A node of a pattern program as the scene delegate describes it: Texture nodes name their
/// texture by description (`node.texture` is set at sync, when the file is opened).
struct ProgramNode {
  ExpressionNode node;
  std::optional<TextureNode> texture;
};

/// What a connected input reads: a texture's output ("rgb", "r", "g", "b", "a"), a primvar
/// (with the value used where a mesh lacks it), or a program (ExpressionProgram: its last node's
/// first three channels, or first channel for a float input).
struct InputSource {
  std::optional<TextureNode> texture;
  std::string output = "rgb";
  std::string primvar;
  std::array<float, 3> fallback{0, 0, 0};
  std::vector<ProgramNode> program;
};

/// UsdUVTexture token parsers; they throw std::invalid_argument naming the token.
TextureWrap parseTextureWrap(const std::string& token);
SourceColorSpace parseSourceColorSpace(const std::string& token);
/// The channels a UsdUVTexture output token names: {first channel, channel count}.
std::pair<int, int> parseTextureOutput(const std::string& token);

class Material : public Prim {
 public:
  using Prim::Prim;

  /// Sets a constant input by name (materialInputs(), material_inputs.h, except `normal`; a
  /// token input takes one of its names: penumbra:anisotropyModel "openPBR" or
  /// "standardSurface"). Throws std::invalid_argument for an unknown name, a value of the wrong
  /// type, a non-finite value where the input must be finite or an unknown token.
  void setParam(const std::string& name, const ParamValue& value);
  /// Connects an input (those of materialInputs() that are connectable) to a source; throws
  /// std::invalid_argument for an input that cannot be connected, an unknown output or a
  /// program with a problem (ExpressionProgram::problem).
  void connect(const std::string& input, InputSource source);
  /// Back to the schema's fallback values, unconnected.
  void resetParams();

  /// Builds its renderer material, opening its textures (a warning names each that cannot be
  /// read: once per change, since only a dirty material syncs), into its own index of the
  /// scene's material list (SyncContext::materials, given at its insertion; cf.
  /// HdMaterial::Sync). The other materials stay as they are; the meshes bound to it follow its
  /// cut-outs (Scene::setMaterial).
  void sync(SyncContext& context, uint32_t dirtyBits) override;
  /// Frees its index: its entry is emptied, and the meshes bound to it are placed again with
  /// their displayColor at the next sync.
  void finalize(SyncContext& context) override;

  /// Whether a texture file it could not read at its last sync has changed (been written,
  /// mended, or made) since: it then syncs again (a lookdev loop: fix the file, render).
  bool unreadableFilesChanged() const;

  const MaterialParams& params() const { return params_; }
  /// The connected inputs, in the order they were connected.
  const std::vector<std::pair<MaterialInput, InputSource>>& connections() const {
    return connections_;
  }

 private:
  MaterialParams params_;
  std::vector<std::pair<MaterialInput, InputSource>> connections_;
  // The texture files its last sync could not read, as they were then (none: missing).
  StampedFiles unreadableStamps_;
};

}  // namespace penumbra::plugin
