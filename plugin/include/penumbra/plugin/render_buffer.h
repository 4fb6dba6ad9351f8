// Render buffer bprim (cf. HdRenderBuffer): an image a render pass resolves an AOV into.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "penumbra/plugin/prim.h"

namespace penumbra::plugin {

class RenderBuffer : public Prim {
 public:
  using Prim::Prim;

  /// Allocation (cf. HdRenderBuffer::Allocate); the contents are cleared.
  void allocate(int width, int height) {
    if (width <= 0 || height <= 0)
      throw std::invalid_argument(id() + ": render buffer size must be positive");
    width_ = width;
    height_ = height;
    channels_ = 0;
    data_.clear();
    converged_ = false;
    markDirty(DirtyParams);
  }
  /// Written by a render pass: `values` holds width × height × channels floats.
  void resolve(std::vector<float> values, int channels, bool converged) {
    if (values.size() != size_t(width_) * size_t(height_) * size_t(channels))
      throw std::invalid_argument(id() + ": render buffer size does not match the pass");
    data_ = std::move(values);
    channels_ = channels;
    converged_ = converged;
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  const std::vector<float>& data() const { return data_; }
  bool converged() const { return converged_; }

  /// Render passes write its contents (resolve): a sync has nothing to do.
  void sync(SyncContext&, uint32_t) override {}

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  std::vector<float> data_;
  bool converged_ = false;
};

}  // namespace penumbra::plugin
