#include "penumbra/volume_field.h"

namespace penumbra {
namespace {

class ConstantField final : public VolumeField {
 public:
  ConstantField(const Vec3f& value, int components) : value_(value), components_(components) {}

  int components() const override { return components_; }
  void sample(const Vec3f&, float* value) const override {
    for (int c = 0; c < components_; ++c) value[c] = value_[c];
  }
  Bounds3f objectBounds() const override { return {Vec3f(-kInfinity), Vec3f(kInfinity)}; }
  float maxIn(const Bounds3f&) const override {
    return components_ == 1 ? value_.x : maxComponent(value_);
  }
  uint64_t activeVoxels() const override { return 0; }
  size_t memoryBytes() const override { return sizeof(*this); }

 private:
  Vec3f value_;
  int components_;
};

}  // namespace

std::shared_ptr<const VolumeField> constantField(const Vec3f& value, int components) {
  return std::make_shared<ConstantField>(value, components == 1 ? 1 : 3);
}

}  // namespace penumbra
