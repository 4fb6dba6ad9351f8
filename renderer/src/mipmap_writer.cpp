#include "mipmap_writer.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <vector>

namespace penumbra::detail {

namespace {

// The input cells under one output cell and the share of the output cell each one covers.
struct Footprint {
  int first = 0;
  std::vector<float> weights;
};

// Box filtering of `from` cells onto `to` <= `from` cells: output cell i covers the input
// interval [i from / to, (i + 1) from / to). Computed in integers (an input cell is `to` units
// long, an output cell `from` units), so the weights are exact and deterministic.
std::vector<Footprint> boxFootprints(int from, int to) {
  std::vector<Footprint> footprints(static_cast<size_t>(to));
  for (int i = 0; i < to; ++i) {
    const int64_t begin = int64_t(i) * from, end = int64_t(i + 1) * from;
    Footprint& footprint = footprints[size_t(i)];
    footprint.first = int(begin / to);
    const int last = int((end - 1) / to);
    for (int k = footprint.first; k <= last; ++k) {
      const int64_t overlap = std::min(end, int64_t(k + 1) * to) - std::max(begin, int64_t(k) * to);
      footprint.weights.push_back(float(double(overlap) / double(from)));
    }
  }
  return footprints;
}

int halved(int size) {
  return std::max(1, size / 2);
}

// Rows [first, last) of the image's level 0 (relative to its data window), `channels` floats a
// texel, into `rows`. A tiled file is read as the whole tiles that cover them (OIIO 2.4's
// read_scanlines stops with a division by zero on tiled files, e.g. maketx's).
bool readRows(OIIO::ImageInput& input, int first, int last, int channels,
              std::vector<float>* tileRows, float* rows) {
  const OIIO::ImageSpec& spec = input.spec();
  if (spec.tile_width <= 0 || spec.tile_height <= 0)
    return input.read_scanlines(0, 0, spec.y + first, spec.y + last, 0, 0, channels,
                                OIIO::TypeFloat, rows);
  const int tileFirst = first / spec.tile_height * spec.tile_height;
  const int tileLast =
      std::min(spec.height, (last + spec.tile_height - 1) / spec.tile_height * spec.tile_height);
  const size_t rowValues = size_t(spec.width) * size_t(channels);
  tileRows->resize(rowValues * size_t(tileLast - tileFirst));
  if (!input.read_tiles(0, 0, spec.x, spec.x + spec.width, spec.y + tileFirst, spec.y + tileLast,
                        spec.z, spec.z + std::max(1, spec.depth), 0, channels, OIIO::TypeFloat,
                        tileRows->data()))
    return false;
  std::copy(tileRows->begin() + std::ptrdiff_t(rowValues * size_t(first - tileFirst)),
            tileRows->begin() + std::ptrdiff_t(rowValues * size_t(last - tileFirst)), rows);
  return true;
}

// Builds the next MIP level from the rows of one level, streamed from top to bottom: each
// output row is emitted as soon as the last input row under it has been added.
class LevelReducer {
 public:
  LevelReducer(int width, int height, int channels)
      : channels_(channels),
        outWidth_(halved(width)),
        columns_(boxFootprints(width, outWidth_)),
        rows_(boxFootprints(height, halved(height))),
        reduced_(size_t(outWidth_) * size_t(channels)),
        current_(reduced_.size(), 0.0f),
        next_(reduced_.size(), 0.0f) {}

  int width() const { return outWidth_; }
  int height() const { return int(rows_.size()); }

  template <class Emit>
  void addRow(int y, const float* row, Emit&& emit) {
    for (int x = 0; x < outWidth_; ++x) {
      const Footprint& column = columns_[size_t(x)];
      float* out = &reduced_[size_t(x) * size_t(channels_)];
      std::fill(out, out + channels_, 0.0f);
      for (size_t k = 0; k < column.weights.size(); ++k) {
        const float* in = row + size_t(column.first + int(k)) * size_t(channels_);
        for (int c = 0; c < channels_; ++c) out[c] += column.weights[k] * in[c];
      }
    }
    accumulate(nextRow_, y, current_);
    if (nextRow_ + 1 < height()) accumulate(nextRow_ + 1, y, next_);
    const Footprint& under = rows_[size_t(nextRow_)];
    if (y == under.first + int(under.weights.size()) - 1) {
      emit(current_.data());
      current_.swap(next_);
      std::fill(next_.begin(), next_.end(), 0.0f);
      ++nextRow_;
    }
  }

 private:
  void accumulate(int outRow, int y, std::vector<float>& sum) const {
    const Footprint& under = rows_[size_t(outRow)];
    const int k = y - under.first;
    if (k < 0 || k >= int(under.weights.size())) return;
    for (size_t i = 0; i < sum.size(); ++i) sum[i] += under.weights[size_t(k)] * reduced_[i];
  }

  int channels_, outWidth_;
  std::vector<Footprint> columns_, rows_;
  std::vector<float> reduced_, current_, next_;
  int nextRow_ = 0;
};

// Collects the rows of one level into bands of whole tiles and writes each band.
class TileRowWriter {
 public:
  TileRowWriter(OIIO::ImageOutput& output, int width, int height, int channels)
      : output_(output),
        width_(width),
        height_(height),
        rowValues_(size_t(width) * size_t(channels)),
        band_(rowValues_ * size_t(std::min(height, kTextureTileSize))) {}

  bool addRow(int y, const float* row) {
    const int bandRow = y % kTextureTileSize;
    std::copy(row, row + rowValues_, band_.begin() + std::ptrdiff_t(size_t(bandRow) * rowValues_));
    if (bandRow + 1 < kTextureTileSize && y + 1 < height_) return true;
    const int first = y - bandRow;
    return output_.write_tiles(0, width_, first, y + 1, 0, 1, OIIO::TypeFloat, band_.data());
  }

 private:
  OIIO::ImageOutput& output_;
  int width_, height_;
  size_t rowValues_;
  std::vector<float> band_;
};

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// Removes the spool files however the writing ends.
struct SpoolFiles {
  std::string paths[2];
  ~SpoolFiles() {
    std::error_code ignored;
    for (const std::string& path : paths) std::filesystem::remove(path, ignored);
  }
};

}  // namespace

bool writeMipmappedTexture(OIIO::ImageInput& input, const std::string& output,
                           OIIO::TypeDesc format, const RowTransform& transform,
                           const std::string& spool, std::string* error) {
  const OIIO::ImageSpec& source = input.spec();
  const int channels = std::min(source.nchannels, 4);
  int width = source.width, height = source.height;

  OIIO::ImageSpec spec(width, height, channels, format);
  spec.channelnames.assign(source.channelnames.begin(), source.channelnames.begin() + channels);
  spec.alpha_channel = source.alpha_channel < channels ? source.alpha_channel : -1;
  spec.tile_width = spec.tile_height = kTextureTileSize;
  spec.tile_depth = 1;
  spec.attribute("textureformat", "Plain Texture");
  // Level 1 of zlib: several times faster than the default level on large textures, and still
  // small on disk for the flat or patterned images that make textures huge.
  spec.attribute("compression", "zip:1");
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(output);
  if (!out || !out->open(output, spec)) {
    *error = "cannot write: " + (out ? out->geterror() : OIIO::geterror());
    return false;
  }

  SpoolFiles spools{{spool + ".a", spool + ".b"}};
  const size_t rowValues = size_t(width) * size_t(channels);
  File spoolOut(std::fopen(spools.paths[0].c_str(), "wb"));
  if (!spoolOut) {
    *error = "cannot write the temporary file " + spools.paths[0];
    return false;
  }
  bool spoolOk = true;
  const auto spoolRow = [&](std::FILE* file, size_t values) {
    return [&spoolOk, file, values](const float* row) {
      spoolOk = spoolOk && std::fwrite(row, sizeof(float), values, file) == values;
    };
  };

  // Level 0, from the image, one band of whole tiles at a time.
  {
    TileRowWriter tiles(*out, width, height, channels);
    LevelReducer reducer(width, height, channels);
    const auto emit = spoolRow(spoolOut.get(), size_t(reducer.width()) * size_t(channels));
    std::vector<float> band(rowValues * size_t(std::min(height, kTextureTileSize))), tileRows;
    for (int first = 0; first < height; first += kTextureTileSize) {
      const int last = std::min(height, first + kTextureTileSize);
      // Readers of truncated JPEG and TIFF files fill in what is missing and return true,
      // with an error on record: the image is then as unreadable as a failed read.
      if (!readRows(input, first, last, channels, &tileRows, band.data()) || input.has_error()) {
        *error = "cannot read the image: " + input.geterror();
        return false;
      }
      for (int y = first; y < last; ++y) {
        float* row = &band[size_t(y - first) * rowValues];
        if (transform) transform(row, width, channels);
        if (!tiles.addRow(y, row)) {
          *error = "cannot write: " + out->geterror();
          return false;
        }
        if (width > 1 || height > 1) reducer.addRow(y, row, emit);
      }
    }
  }

  // Every coarser level, from the spool the level above it wrote.
  int spoolIndex = 0;
  while (width > 1 || height > 1) {
    if (!spoolOk || std::fflush(spoolOut.get()) != 0) {
      *error = "cannot write the temporary file " + spools.paths[spoolIndex];
      return false;
    }
    spoolOut.reset();
    File spoolIn(std::fopen(spools.paths[spoolIndex].c_str(), "rb"));
    width = halved(width);
    height = halved(height);
    spoolIndex = 1 - spoolIndex;
    spoolOut.reset(std::fopen(spools.paths[spoolIndex].c_str(), "wb"));
    if (!spoolIn || !spoolOut) {
      *error = "cannot reopen the temporary files " + spool + ".*";
      return false;
    }
    OIIO::ImageSpec levelSpec = spec;
    levelSpec.width = levelSpec.full_width = width;
    levelSpec.height = levelSpec.full_height = height;
    if (!out->open(output, levelSpec, OIIO::ImageOutput::AppendMIPLevel)) {
      *error = "cannot write a MIP level: " + out->geterror();
      return false;
    }
    TileRowWriter tiles(*out, width, height, channels);
    LevelReducer reducer(width, height, channels);
    const auto emit = spoolRow(spoolOut.get(), size_t(reducer.width()) * size_t(channels));
    std::vector<float> row(size_t(width) * size_t(channels));
    for (int y = 0; y < height; ++y) {
      if (std::fread(row.data(), sizeof(float), row.size(), spoolIn.get()) != row.size()) {
        *error = "cannot read the temporary file " + spools.paths[1 - spoolIndex];
        return false;
      }
      if (!tiles.addRow(y, row.data())) {
        *error = "cannot write: " + out->geterror();
        return false;
      }
      if (width > 1 || height > 1) reducer.addRow(y, row.data(), emit);
    }
  }
  if (!out->close()) {
    *error = "cannot write: " + out->geterror();
    return false;
  }
  return true;
}

}  // namespace penumbra::detail
