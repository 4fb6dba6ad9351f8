// UsdUVTexture lookups over a private OpenImageIO TextureSystem.
//
// Coordinates: USD's st has its origin at the image's bottom-left corner with t up; OIIO's st has
// its origin at the top-left corner with t down. A lookup passes t' = 1 - t and negates the t
// derivatives. The substitution commutes with every wrap mode (black/clamp: [0,1] maps to itself;
// periodic and mirror: 1 - t shifts by a whole period and reflects about an integer), so wrapping
// happens in OIIO.
//
// Files: each is made ready for OIIO once, when opened (texture_files.h): tiled and MIP-mapped,
// so that lookups take no more memory than the bounded cache (setCacheSize), and converted to
// scene_linear before any filtering (texture_color.h).
//
// Alpha: values come back as stored in the file (PNG colour not premultiplied by alpha: the
// ImageCache's "unassociatedalpha"), except for textures whose alpha is coverage
// (TextureAlpha::Coverage): their colour is stored premultiplied, so that filtering weighs each
// texel's colour by its alpha, and each lookup divides by the filtered alpha. A cut-out's edge
// then keeps the colour of its covered texels instead of fading to the transparent ones'.
//
// UDIM: tiles 1001–1100 are found when the texture is opened (each one converted on its own by
// the colour-space rule); tile = 1001 + floor(s) + 10 floor(t) in USD st, and the lookup inside
// the tile uses the fractional parts, clamped to the tile.
#include "penumbra/texture.h"

#include <OpenImageIO/imagecache.h>
#include <OpenImageIO/texture.h>
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <tuple>
#include <vector>

#include "penumbra/file_stamp.h"
#include "texture_files.h"

namespace fs = std::filesystem;

namespace penumbra {

namespace {

using detail::TextureFile;
using detail::TextureTile;
using Wrap = OIIO::TextureOpt::Wrap;

constexpr const char* kUdimToken = "<UDIM>";
constexpr int kUdimFirst = 1001;
constexpr int kUdimTiles = 100;  // 1001–1100: 10 tiles across (s), 10 rows up (t)

std::string replaceAll(std::string text, const std::string& token, const std::string& value) {
  for (size_t at = text.find(token); at != std::string::npos;
       at = text.find(token, at + value.size()))
    text.replace(at, token.size(), value);
  return text;
}

Wrap toOiio(TextureWrap wrap) {
  switch (wrap) {
    case TextureWrap::Black:
      return Wrap::WrapBlack;
    case TextureWrap::Clamp:
      return Wrap::WrapClamp;
    case TextureWrap::Repeat:
      return Wrap::WrapPeriodic;
    case TextureWrap::Mirror:
      return Wrap::WrapMirror;
    case TextureWrap::UseMetadata:
      break;
  }
  return Wrap::WrapBlack;
}

// Colour from a filtered texel of a tile whose colour is stored premultiplied by its alpha (the
// last of 2 or 4 channels); where alpha is 0 there is no colour to recover, and it stays as
// stored.
void divideByCoverage(const TextureTile& tile, float* value) {
  if (!tile.coverageAlpha) return;
  const int alpha = tile.channels - 1;
  if (!(value[alpha] > 0.0f)) return;
  for (int c = 0; c < alpha; ++c) value[c] /= value[alpha];
}

// rgb from a texel of `channels` values, by USD's channel rules.
Vec3f toRgb(const float* value, int channels) {
  return channels >= 3 ? Vec3f(value[0], value[1], value[2]) : Vec3f(value[0]);
}

struct Texture {
  bool udim = false;
  int channels = 0;
  Wrap metadataS = Wrap::WrapBlack, metadataT = Wrap::WrapBlack;
  TextureTile single;
  std::array<TextureTile, kUdimTiles> tiles{};
  StampedFiles files;  // as each was read
};

}  // namespace

struct TextureSystem::Impl {
  OIIO::TextureSystem* oiio;
  detail::TextureFiles files;
  std::vector<Texture> textures;
  // How each texture was opened, in the order of `textures`: to read it again when it changes.
  struct OpenedAs {
    std::string path;
    TextureColorSpace colorSpace;
    TextureAlpha alpha;
  };
  std::vector<OpenedAs> openedAs;
  // Textures whose lookups failed (a file broken past what opening it reads: a truncated tiled
  // .tx), by handle: the first line of OIIO's first error, and whether it was reported yet.
  struct LookupFailure {
    std::string error;
    bool reported = false;
  };
  mutable std::mutex failureMutex;
  mutable std::map<Handle, LookupFailure> failures;
  std::map<std::tuple<std::string, SourceColorSpace, std::string, TextureAlpha>, Handle> handles;
  // Each thread's OIIO per-thread record for this system, made here and destroyed with it. OIIO
  // 2.4 keeps the ones it makes itself (get_perthread_info()) per thread under the address of
  // the cache: a thread pool's thread that looked textures up in a destroyed system would find
  // its stale record, holding tiles of the freed cache, in a new system allocated at that
  // address, and crash there.
  tbb::enumerable_thread_specific<OIIO::TextureSystem::Perthread*> threadInfos{nullptr};

  explicit Impl(const std::string& configPath)
      : oiio(OIIO::TextureSystem::create(/*shared=*/false)), files(oiio, configPath) {
    oiio->attribute("unassociatedalpha", 1);
    oiio->attribute("max_memory_MB", float(kDefaultCacheBytes >> 20));
  }

  ~Impl() {
    if (!oiio) return;
    for (OIIO::TextureSystem::Perthread* info : threadInfos)
      if (info) oiio->destroy_thread_info(info);
    // Tears the private ImageCache down too, so each scene's cache and its tiles end with the
    // scene. Closes the files before `files` removes them.
    OIIO::TextureSystem::destroy(oiio, /*teardown_imagecache=*/true);
  }

  /// Opens the file(s) of `path` into *texture (see TextureSystem::open).
  bool read(const std::string& path, const TextureColorSpace& colorSpace, TextureAlpha alpha,
            Texture* result, std::string* error) {
    Texture& texture = *result;
    if (path.find(kUdimToken) != std::string::npos) {
      texture.udim = true;
      int tiles = 0;
      std::string unreadable;  // one tile that cannot be read is left out, as a missing one is
      for (int i = 0; i < kUdimTiles; ++i) {
        const std::string file = replaceAll(path, kUdimToken, std::to_string(kUdimFirst + i));
        std::error_code code;
        if (!fs::exists(file, code)) continue;
        TextureFile opened;
        std::string tileError;
        if (!files.open(file, colorSpace, alpha, threadInfo(), &opened, &tileError)) {
          unreadable += (unreadable.empty() ? "" : "; ") + tileError;
          texture.files.emplace_back(file, fileStamp(file));  // read again once mended
          continue;
        }
        texture.tiles[i] = opened.tile;
        texture.files.emplace_back(file, fileStamp(file));
        texture.channels = std::max(texture.channels, opened.tile.channels);
        ++tiles;
      }
      *error = unreadable;
      if (tiles == 0) {
        if (unreadable.empty()) *error = path + ": no UDIM tiles (looked for 1001 to 1100)";
        return false;
      }
    } else {
      TextureFile opened;
      if (!files.open(path, colorSpace, alpha, threadInfo(), &opened, error)) return false;
      texture.single = opened.tile;
      texture.files.emplace_back(path, fileStamp(path));
      texture.channels = opened.tile.channels;
      texture.metadataS = opened.metadataS;
      texture.metadataT = opened.metadataT;
    }
    return true;
  }

  /// The calling thread's per-thread record (OIIO still does its housekeeping on it).
  OIIO::TextureSystem::Perthread* threadInfo() {
    OIIO::TextureSystem::Perthread*& info = threadInfos.local();
    if (!info) info = oiio->create_thread_info();
    return oiio->get_perthread_info(info);
  }
};

TextureSystem::TextureSystem(const std::string& ocioConfig)
    : impl_(std::make_unique<Impl>(ocioConfig)) {}

TextureSystem::~TextureSystem() = default;

TextureSystem::Handle TextureSystem::open(const std::string& path,
                                          const TextureColorSpace& colorSpace, std::string* error,
                                          TextureAlpha alpha) {
  std::string ignored;
  if (!error) error = &ignored;
  const auto key = std::make_tuple(path, colorSpace.source, colorSpace.name, alpha);
  if (auto found = impl_->handles.find(key); found != impl_->handles.end()) return found->second;

  Texture texture;
  if (!impl_->read(path, colorSpace, alpha, &texture, error)) return kInvalid;
  const Handle handle = Handle(impl_->textures.size());
  impl_->textures.push_back(texture);
  impl_->openedAs.push_back({path, colorSpace, alpha});
  impl_->handles.emplace(key, handle);
  return handle;
}

size_t TextureSystem::reloadChangedFiles(std::vector<std::string>* errors) {
  std::set<std::string> changed;
  for (const Texture& texture : impl_->textures)
    for (const auto& [file, stamp] : texture.files)
      if (fileStamp(file) != stamp) changed.insert(file);
  if (changed.empty()) return 0;
  for (const std::string& file : changed) impl_->files.forget(file);
  size_t reloaded = 0;
  for (size_t index = 0; index < impl_->textures.size(); ++index) {
    Texture& texture = impl_->textures[index];
    if (std::none_of(texture.files.begin(), texture.files.end(),
                     [&](const auto& file) { return changed.count(file.first) > 0; }))
      continue;
    const Impl::OpenedAs& as = impl_->openedAs[index];
    Texture fresh;
    std::string error;
    if (!impl_->read(as.path, as.colorSpace, as.alpha, &fresh, &error)) {
      errors->push_back(error);
      fresh = Texture{};  // no texel; read again when the files change again
      for (const auto& [file, stamp] : texture.files)
        fresh.files.emplace_back(file, fileStamp(file));
    }
    texture = std::move(fresh);
    const std::lock_guard<std::mutex> lock(impl_->failureMutex);
    impl_->failures.erase(Handle(index));  // a file mended, or broken anew, is reported anew
    ++reloaded;
  }
  return reloaded;
}

std::vector<std::string> TextureSystem::takeLookupFailures() {
  std::vector<std::string> messages;
  std::set<std::string> named;  // a file opened in two colour spaces is two textures: one message
  const std::lock_guard<std::mutex> lock(impl_->failureMutex);
  for (auto& [handle, failure] : impl_->failures) {
    if (failure.reported) continue;
    failure.reported = true;
    const std::string& path = impl_->openedAs[size_t(handle)].path;
    if (named.insert(path).second)
      messages.push_back(path + ": the texture cannot be read (" + failure.error +
                         "); its fallback value is used where it fails");
  }
  return messages;
}

int TextureSystem::channels(Handle handle) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return 0;
  return impl_->textures[size_t(handle)].channels;
}

void TextureSystem::setCacheSize(size_t bytes) {
  constexpr size_t kMinimum = size_t(16) << 20;
  impl_->oiio->attribute("max_memory_MB", float(std::max(bytes, kMinimum) >> 20));
}

size_t TextureSystem::cacheSize() const {
  float megabytes = 0;
  impl_->oiio->getattribute("max_memory_MB", megabytes);
  return size_t(megabytes) << 20;
}

bool TextureSystem::resolution(Handle handle, int* width, int* height) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return false;
  const Texture& texture = impl_->textures[size_t(handle)];
  if (texture.udim) return false;
  *width = texture.single.width;
  *height = texture.single.height;
  return true;
}

bool TextureSystem::readLevel(Handle handle, size_t maxTexels, int* width, int* height,
                              std::vector<Vec3f>* rgb) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return false;
  const Texture& texture = impl_->textures[size_t(handle)];
  if (texture.udim || !texture.single.handle) return false;
  // The MIP levels' specs come from the cache, with a per-thread record of its own for this
  // call (see Impl::threadInfos).
  OIIO::ImageCache* cache = impl_->oiio->imagecache();
  const std::unique_ptr<OIIO::ImageCache::Perthread,
                        std::function<void(OIIO::ImageCache::Perthread*)>>
      cacheInfo(cache->create_thread_info(), [cache](OIIO::ImageCache::Perthread* record) {
        cache->destroy_thread_info(record);
      });
  OIIO::ImageCache::Perthread* info = cache->get_perthread_info(cacheInfo.get());
  OIIO::ImageCache::ImageHandle* file =
      cache->get_image_handle(OIIO::ustring(texture.single.path), info);
  OIIO::ImageSpec spec;
  int level = 0;
  if (!file || !cache->get_imagespec(file, info, spec, 0, level)) return false;
  for (OIIO::ImageSpec coarser; size_t(spec.width) * size_t(spec.height) > maxTexels &&
                                cache->get_imagespec(file, info, coarser, 0, level + 1);) {
    spec = coarser;
    ++level;
  }
  const int channels = texture.single.channels;
  std::vector<float> values(size_t(spec.width) * size_t(spec.height) * size_t(channels));
  OIIO::TextureOpt options;
  if (!impl_->oiio->get_texels(texture.single.handle, impl_->threadInfo(), options, level, spec.x,
                               spec.x + spec.width, spec.y, spec.y + spec.height, 0, 1, 0, channels,
                               OIIO::TypeFloat, values.data()))
    return false;
  rgb->resize(size_t(spec.width) * size_t(spec.height));
  for (size_t i = 0; i < rgb->size(); ++i) {
    divideByCoverage(texture.single, &values[i * size_t(channels)]);
    (*rgb)[i] = toRgb(&values[i * size_t(channels)], channels);
  }
  *width = spec.width;
  *height = spec.height;
  return true;
}

Vec3f TextureSystem::texel(Handle handle, Vec2f uv) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return Vec3f(0.0f);
  const Texture& texture = impl_->textures[size_t(handle)];
  if (texture.udim) return Vec3f(0.0f);
  const TextureTile& tile = texture.single;
  if (!tile.handle) return Vec3f(0.0f);
  const int x = tile.x + std::clamp(int(uv.x * float(tile.width)), 0, tile.width - 1);
  const int y = tile.y + std::clamp(int(uv.y * float(tile.height)), 0, tile.height - 1);
  float value[4] = {0, 0, 0, 0};
  OIIO::TextureOpt options;
  OIIO::TextureSystem* oiio = impl_->oiio;
  if (!oiio->get_texels(tile.handle, impl_->threadInfo(), options, 0, x, x + 1, y, y + 1, 0, 1, 0,
                        tile.channels, OIIO::TypeFloat, value))
    return Vec3f(0.0f);
  divideByCoverage(tile, value);
  return toRgb(value, tile.channels);
}

bool TextureSystem::lookup(Handle handle, TextureWrap wrapS, TextureWrap wrapT,
                           const TextureFootprint& at, float rgba[4]) const {
  if (handle < 0 || size_t(handle) >= impl_->textures.size()) return false;
  const Texture& texture = impl_->textures[size_t(handle)];
  float s = at.st.x, t = at.st.y;
  if (!std::isfinite(s) || !std::isfinite(t)) return false;

  OIIO::TextureOpt options;
  options.mipmode = OIIO::TextureOpt::MipModeAniso;
  // Bilinear within a level: interpolating (texel centres give texel values, as in USD's own
  // Storm), where OIIO's bicubic is an approximating B-spline that blurs under magnification.
  options.interpmode = OIIO::TextureOpt::InterpBilinear;
  const TextureTile* tile = &texture.single;
  if (texture.udim) {
    const float tileS = std::floor(s), tileT = std::floor(t);
    if (tileS < 0.0f || tileS > 9.0f || tileT < 0.0f || tileT > 9.0f) return false;
    tile = &texture.tiles[size_t(tileS) + 10 * size_t(tileT)];
    if (!tile->handle) return false;
    s -= tileS;
    t -= tileT;
    options.swrap = options.twrap = Wrap::WrapClamp;  // no bleeding across tile borders
  } else {
    if (!tile->handle) return false;  // a file that could not be read again
    options.swrap = wrapS == TextureWrap::UseMetadata ? texture.metadataS : toOiio(wrapS);
    options.twrap = wrapT == TextureWrap::UseMetadata ? texture.metadataT : toOiio(wrapT);
  }
  auto finite = [](float value) { return std::isfinite(value) ? value : 0.0f; };
  const float dsdx = finite(at.dstdx.x), dtdx = -finite(at.dstdx.y);
  const float dsdy = finite(at.dstdy.x), dtdy = -finite(at.dstdy.y);

  OIIO::TextureSystem* oiio = impl_->oiio;
  float value[4];
  if (!oiio->texture(tile->handle, impl_->threadInfo(), options, s, 1.0f - t, dsdx, dtdx, dsdy,
                     dtdy, tile->channels, value)) {
    // Taken, not left to pile up in OIIO's per-thread error text, lookup after lookup.
    const std::string error = oiio->geterror();
    const std::lock_guard<std::mutex> lock(impl_->failureMutex);
    impl_->failures.try_emplace(handle, Impl::LookupFailure{error.substr(0, error.find('\n'))});
    return false;
  }
  divideByCoverage(*tile, value);
  switch (tile->channels) {
    case 1:
      rgba[0] = rgba[1] = rgba[2] = value[0];
      rgba[3] = 1.0f;
      break;
    case 2:
      rgba[0] = rgba[1] = rgba[2] = value[0];
      rgba[3] = value[1];
      break;
    case 3:
      rgba[0] = value[0];
      rgba[1] = value[1];
      rgba[2] = value[2];
      rgba[3] = 1.0f;
      break;
    default:
      std::copy(value, value + 4, rgba);
      break;
  }
  return true;
}

}  // namespace penumbra
