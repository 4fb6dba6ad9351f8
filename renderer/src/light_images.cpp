#include "penumbra/light_images.h"

#include <algorithm>
#include <cmath>

namespace penumbra {
namespace {

/// How far (pixels) to widen a light's image box so that rounding in projecting its corners
/// and in the camera rays through it never leaves a point of its image outside (a flat light's
/// outline touches its box): a hundredth of a pixel, plus what a millionth of the coordinates'
/// magnitude (a few float roundings) moves the image by, at `pixelsPerUnit`.
float imageBoxMargin(const LightBounds& bounds, const Camera& camera, float pixelsPerUnit) {
  float magnitude = 0;
  for (const Vec3f& point : {bounds.lower, bounds.upper, camera.centre(0)})
    magnitude = std::max({magnitude, std::abs(point.x), std::abs(point.y), std::abs(point.z)});
  return 0.01f + 1e-6f * magnitude * pixelsPerUnit;
}

/// Whether camera rays may see a light with these bounds emit: it emits, and a one-sided light
/// (rect, disk: one emission axis) faces the pinhole (a lens sees it from several sides).
bool seenEmitting(const LightBounds& bounds, const Camera& camera) {
  if (!(bounds.power > 0)) return false;
  if (bounds.cosThetaO < 1 || camera.lensRadius() > 0) return true;
  return dot(camera.centre(0) - bounds.centroid(), bounds.axis) > 0;
}

}  // namespace

LightImages::LightImages(const std::vector<Light>& lights, const Camera& camera, float filterRadius)
    : integratesLight_(lights.size(), false) {
  if (!camera.isStatic()) return;
  const int width = camera.imageWidth(), height = camera.imageHeight();
  for (uint32_t index = 0; index < lights.size(); ++index) {
    const Light& light = lights[index];
    if (!light.cameraVisible() || !light.isAreaLight()) continue;
    const LightBounds bounds = light.bounds();
    if (!seenEmitting(bounds, camera)) continue;
    Integrated entry{index, {}, {}, 0};  // lightIndex, corners, reach, margin
    ImageBox box;
    bool seen = true;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3f point{corner & 1 ? bounds.upper.x : bounds.lower.x,
                        corner & 2 ? bounds.upper.y : bounds.lower.y,
                        corner & 4 ? bounds.upper.z : bounds.lower.z};
      const std::optional<PointImage> image = camera.pointImage(point);
      seen = image && std::isfinite(image->position.x) && std::isfinite(image->position.y) &&
             std::isfinite(image->perLensUnit.x) && std::isfinite(image->perLensUnit.y);
      if (!seen) break;
      entry.corners[corner] = *image;
      // The lens is the unit disk: each coordinate of its points within [-1, 1].
      const Vec2f spread{std::abs(image->perLensUnit.x), std::abs(image->perLensUnit.y)};
      box.include({image->position.x - spread.x, image->position.y - spread.y});
      box.include({image->position.x + spread.x, image->position.y + spread.y});
    }
    if (!seen) continue;
    const float side = std::max(box.upper.x - box.lower.x, box.upper.y - box.lower.y);
    if (side > kMaxImageSide) continue;
    const float extent = length(bounds.upper - bounds.lower);
    entry.margin = imageBoxMargin(bounds, camera, extent > 0 ? side / extent : 0.0f);
    // The pixels whose samples may land on its image, through any lens point.
    const ImageBox inImage = box.widened(filterRadius + entry.margin)
                                 .intersected({{0, 0}, {float(width), float(height)}});
    if (inImage.empty()) continue;
    entry.reach = inImage;
    integratesLight_[index] = true;
    integrated_.push_back(entry);
  }
  if (integrated_.empty()) return;
  // The lights near each cell, in light order (so every pixel visits them alike).
  cellsX_ = (width + kCellSize - 1) / kCellSize;
  cellsY_ = (height + kCellSize - 1) / kCellSize;
  cellStart_.assign(size_t(cellsX_) * size_t(cellsY_) + 1, 0);
  const auto cellRange = [&](const ImageBox& box, int* x0, int* x1, int* y0, int* y1) {
    *x0 = std::clamp(int(std::floor(box.lower.x / kCellSize)), 0, cellsX_ - 1);
    *x1 = std::clamp(int(std::floor(box.upper.x / kCellSize)), 0, cellsX_ - 1);
    *y0 = std::clamp(int(std::floor(box.lower.y / kCellSize)), 0, cellsY_ - 1);
    *y1 = std::clamp(int(std::floor(box.upper.y / kCellSize)), 0, cellsY_ - 1);
  };
  int x0, x1, y0, y1;
  for (const Integrated& entry : integrated_) {
    cellRange(entry.reach, &x0, &x1, &y0, &y1);
    for (int cy = y0; cy <= y1; ++cy)
      for (int cx = x0; cx <= x1; ++cx) ++cellStart_[size_t(cy) * size_t(cellsX_) + size_t(cx) + 1];
  }
  for (size_t cell = 1; cell < cellStart_.size(); ++cell) cellStart_[cell] += cellStart_[cell - 1];
  cellLights_.resize(cellStart_.back());
  std::vector<uint32_t> filled(cellStart_.begin(), cellStart_.end() - 1);
  for (uint32_t position = 0; position < integrated_.size(); ++position) {
    cellRange(integrated_[position].reach, &x0, &x1, &y0, &y1);
    for (int cy = y0; cy <= y1; ++cy)
      for (int cx = x0; cx <= x1; ++cx)
        cellLights_[filled[size_t(cy) * size_t(cellsX_) + size_t(cx)]++] = position;
  }
}

std::pair<const uint32_t*, const uint32_t*> LightImages::near(int x, int y) const {
  if (integrated_.empty() || x < 0 || y < 0) return {nullptr, nullptr};
  const int cx = x / kCellSize, cy = y / kCellSize;
  if (cx >= cellsX_ || cy >= cellsY_) return {nullptr, nullptr};
  const size_t cell = size_t(cy) * size_t(cellsX_) + size_t(cx);
  return {cellLights_.data() + cellStart_[cell], cellLights_.data() + cellStart_[cell + 1]};
}

ImageBox LightImages::Integrated::imageBox(Vec2f lens) const {
  ImageBox box;
  for (const PointImage& corner : corners)
    box.include({corner.position.x + corner.perLensUnit.x * lens.x,
                 corner.position.y + corner.perLensUnit.y * lens.y});
  return box.widened(margin);
}

}  // namespace penumbra
