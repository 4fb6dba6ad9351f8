// Texture files made ready for OIIO's TextureSystem, once per (file, colour conversion).
//
// Memory: lookups read tiles of MIP levels through OIIO's cache, whose size is bounded, so
// memory does not grow with a texture's resolution. OIIO can only do that for files that are
// tiled and MIP-mapped; its on-the-fly tiling and MIP-mapping ("autotile", "automip") keep whole
// images in the cache. Every other file is prepared once when opened: read one band of scanlines
// at a time and written as a tiled, MIP-mapped half/float OpenEXR texture into a private
// temporary directory (mipmap_writer.h), and that is what OIIO reads. Files that need converting
// (texture_color.h) are prepared too; the others, if tiled and MIP-mapped already, are read from
// the original file.
#pragma once

#include <OpenImageIO/texture.h>

#include <filesystem>
#include <map>
#include <string>
#include <tuple>

#include "penumbra/texture.h"
#include "texture_color.h"

namespace penumbra::detail {

/// One image file as OIIO's TextureSystem reads it.
struct TextureTile {
  OIIO::TextureSystem::TextureHandle* handle = nullptr;
  std::string path;  // the file OIIO reads (the prepared copy, if any)
  int channels = 0;
  int x = 0, y = 0, width = 0, height = 0;  // level 0's data window
  // Alpha is coverage (TextureAlpha::Coverage) and the file has it: colour is stored multiplied
  // by alpha, and what reads it divides by alpha after filtering.
  bool coverageAlpha = false;
};

/// A file ready for lookups, with the wrap modes its metadata names (for wrap useMetadata).
struct TextureFile {
  TextureTile tile;
  OIIO::TextureOpt::Wrap metadataS = OIIO::TextureOpt::WrapBlack;
  OIIO::TextureOpt::Wrap metadataT = OIIO::TextureOpt::WrapBlack;
};

/// The files of one TextureSystem, and the temporary directory of their prepared copies (removed
/// when this is destroyed, so OIIO must have closed them by then).
class TextureFiles {
 public:
  /// `oiio` opens the files; ocioConfig: path of the OCIO config (empty: $OCIO).
  TextureFiles(OIIO::TextureSystem* oiio, std::string ocioConfig);
  ~TextureFiles();
  TextureFiles(const TextureFiles&) = delete;
  TextureFiles& operator=(const TextureFiles&) = delete;

  /// Prepares one image file for lookups (shared between handles that read it the same way).
  /// False with *error naming the file and what is wrong.
  bool open(const std::string& file, const TextureColorSpace& colorSpace, TextureAlpha alpha,
            OIIO::TextureSystem::Perthread* threadInfo, TextureFile* result, std::string* error);
  /// Drops what was read of `file` (its prepared copies and OIIO's cached tiles), so that the
  /// next open() reads it anew.
  void forget(const std::string& file);

 private:
  bool makeDirectory(std::string* error);
  /// Writes `file` as a tiled, MIP-mapped OpenEXR texture (converted from colour space `source`
  /// to scene-linear first, unless `source` is empty; then colour multiplied by alpha if
  /// `premultiply`), streaming it so that memory does not grow with its height; *texture is its
  /// path.
  bool prepare(const std::string& file, const OIIO::ImageSpec& fileSpec, const std::string& source,
               bool premultiply, std::string* texture, std::string* error);

  OIIO::TextureSystem* oiio_;
  TextureColorConversions colors_;
  // (file, the colour space it is converted from (empty: none), coverage alpha)
  std::map<std::tuple<std::string, std::string, bool>, TextureFile> files_;
  std::filesystem::path directory_;  // prepared textures; created on first need
  int preparedCount_ = 0;
};

}  // namespace penumbra::detail
