// Image textures for UsdUVTexture and light textures: filtered, mip-mapped lookups through a
// private OpenImageIO TextureSystem whose tile cache is bounded, with textures in a colour space
// other than the scene-linear one (sRGB, ACEScg, …) converted through OpenColorIO before they
// are filtered.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/math.h"  // Vec2f

namespace penumbra {

/// UsdUVTexture wrapS/wrapT.
enum class TextureWrap { Black, Clamp, Repeat, Mirror, UseMetadata };

/// UsdUVTexture sourceColorSpace.
enum class SourceColorSpace { Auto, Raw, SRGB };

/// What a texture's alpha channel (the second of two channels, the fourth of four) is to the
/// materials that read it. Coverage: a material's opacity reads it, so colour is filtered weighted
/// by alpha (stored premultiplied, divided by the filtered alpha after each lookup): a cut-out's
/// edge then shows the colour of its covered texels, not that colour mixed with the transparent
/// texels' (often black). Data: values are filtered as stored (packed channels, masks).
enum class TextureAlpha { Data, Coverage };

/// How a texture's values are encoded: UsdUVTexture's sourceColorSpace, or a colour space of the
/// OCIO config by name (MaterialX's `colorspace`, USD's `colorSpace` metadata), which overrides
/// it. Named colour spaces are found as findTextureColorSpace finds them.
struct TextureColorSpace {
  // Implicit: a sourceColorSpace is a colour space.
  TextureColorSpace(SourceColorSpace sourceColorSpace = SourceColorSpace::Auto)  // NOLINT
      : source(sourceColorSpace) {}
  static TextureColorSpace named(std::string name) {
    TextureColorSpace space(SourceColorSpace::Raw);
    space.name = std::move(name);
    return space;
  }
  SourceColorSpace source;
  std::string name;  // empty: `source` decides
};

/// The name of the colour space that `name` denotes in the OCIO config at `ocioConfig` (empty:
/// $OCIO): `name` itself, an alias or a role, else, for MaterialX's colour-space names
/// (`lin_ap1`, `g22_rec709`, …), the Color Interop Forum's equivalent (`lin_ap1_scene`, …).
/// Empty when the config has none or cannot be read; *error (if given) then says why.
std::string findTextureColorSpace(const std::string& ocioConfig, const std::string& name,
                                  std::string* error = nullptr);

/// Converts `rgb` in place from colour space `name` (found as findTextureColorSpace finds it) to
/// the scene_linear role of the OCIO config at `ocioConfig` (empty: $OCIO), as textures in that
/// colour space are: for a material's constant colours. False (with *error) when the config has
/// no such colour space or cannot be read.
bool convertToSceneLinear(const std::string& ocioConfig, const std::string& name, float rgb[3],
                          std::string* error = nullptr);

/// A lookup's position and screen-space footprint in USD texture coordinates (st: origin at the
/// image's bottom-left corner, t up; one unit = one image / one UDIM tile).
struct TextureFootprint {
  Vec2f st;
  Vec2f dstdx;
  Vec2f dstdy;
};

/// The textures of one scene. Values come back as stored in the file (colour not multiplied by
/// alpha; for TextureAlpha::Coverage, colour filtered by alpha and not multiplied by it), colour
/// converted from the texture's colour space to the OCIO config's scene_linear role.
class TextureSystem {
 public:
  using Handle = int;
  static constexpr Handle kInvalid = -1;

  /// The tile cache's size unless setCacheSize says otherwise.
  static constexpr size_t kDefaultCacheBytes = size_t(256) << 20;

  /// ocioConfig: path of the OCIO config used to convert textures (empty: $OCIO).
  explicit TextureSystem(const std::string& ocioConfig = {});
  ~TextureSystem();  // also removes any converted-texture files it wrote
  TextureSystem(const TextureSystem&) = delete;
  TextureSystem& operator=(const TextureSystem&) = delete;

  /// Opens `path` (may contain the token <UDIM>) for lookups. Same (path, colorSpace, alpha) →
  /// same handle; a file read in two colour spaces is two textures. On failure (missing/unreadable
  /// file, UDIM pattern with no tiles, no sRGB or no such named colour space in the config)
  /// returns kInvalid and sets *error to a message naming the file and what is wrong. A UDIM
  /// set some of whose tiles cannot be read opens with the others: the handle is valid, *error
  /// names the unreadable tiles (theirs give the fallback, as missing tiles do). Called from
  /// one thread at a time (scene sync), never concurrently with lookup().
  Handle open(const std::string& path, const TextureColorSpace& colorSpace, std::string* error,
              TextureAlpha alpha = TextureAlpha::Data);

  /// Channels in the file (1–4); 0 for an invalid handle.
  int channels(Handle handle) const;

  /// Reads again the textures whose files changed on disk (size or modification time) since
  /// they were opened — a texture repainted between two renders — keeping their handles.
  /// Returns how many textures were read again; one that cannot be read any more gives no
  /// texel (lookups then fail, so its fallback is used) and a message in *errors naming the
  /// file. Called from one thread at a time (scene sync), never concurrently with lookup().
  size_t reloadChangedFiles(std::vector<std::string>* errors);

  /// A message naming each texture whose lookups failed since the last call and had not failed
  /// before (until its file is read again): a file broken past what opening it reads, such as
  /// a truncated tiled .tx, whose fallback value is then used. Thread-safe.
  std::vector<std::string> takeLookupFailures();

  /// Bounds the memory of the tile cache shared by every texture (at least 16 MiB). Whatever
  /// the textures' resolution, lookups then hold about this much texture data. Called between
  /// renders, never concurrently with lookup().
  void setCacheSize(size_t bytes);
  size_t cacheSize() const;

  /// The full-resolution size of a texture that is not a UDIM set; false otherwise.
  bool resolution(Handle handle, int* width, int* height) const;

  /// The finest MIP level with at most `maxTexels` texels (each the mean of the full-resolution
  /// texels it covers), as RGB with the channel rules of lookup(), rows from the top. For
  /// summaries that must not grow with the resolution (a light's sampling distribution). False
  /// for a UDIM set, an invalid handle or a read error.
  bool readLevel(Handle handle, size_t maxTexels, int* width, int* height,
                 std::vector<Vec3f>* rgb) const;

  /// The full-resolution texel nearest to uv ∈ [0, 1)² (origin at the top-left corner, v down,
  /// clamped to the image), unfiltered, as RGB with the channel rules of lookup(). Black for a
  /// UDIM set or an invalid handle. Thread-safe.
  Vec3f texel(Handle handle, Vec2f uv) const;

  /// Filtered, mip-mapped lookup. Writes rgba with USD's channel rules: 1 channel → (c,c,c,1),
  /// 2 → (c,c,c,a), 3 → (r,g,b,1), 4 → rgba. Returns false (rgba untouched) where there is no
  /// texel: a UDIM tile that does not exist (or an invalid handle, non-finite st, a read error).
  /// Thread-safe, called from many TBB threads.
  bool lookup(Handle handle, TextureWrap wrapS, TextureWrap wrapT, const TextureFootprint& at,
              float rgba[4]) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
