#include "penumbra/light_images.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>
#include <vector>

namespace penumbra {
namespace {

/// How far (pixels) to widen a light's image box so that rounding in projecting its corners
/// and in the camera rays through it never leaves a point of its image outside (a flat light's
/// outline touches its box): a hundredth of a pixel, plus what a millionth of the coordinates'
/// magnitude (a few float roundings) moves the image by, at `pixelsPerUnit`.
/// `cameraMagnitude`: the largest coordinate of the camera's centre at the moments looked at.
float imageBoxMargin(const LightBounds& bounds, float cameraMagnitude, float pixelsPerUnit) {
  float magnitude = cameraMagnitude;
  for (const Vec3f& point : {bounds.lower, bounds.upper})
    magnitude = std::max({magnitude, std::abs(point.x), std::abs(point.y), std::abs(point.z)});
  return 0.01f + 1e-6f * magnitude * pixelsPerUnit;
}

/// Whether camera rays may see a light with these bounds emit: it emits, and a one-sided light
/// (rect, disk: one emission axis) faces the pinhole (a lens, or a moving camera, sees it from
/// several sides).
bool seenEmitting(const LightBounds& bounds, const Camera& camera) {
  if (!(bounds.power > 0)) return false;
  if (bounds.cosThetaO < 1 || camera.lensRadius() > 0 || !camera.isStatic()) return true;
  return dot(camera.centre(0) - bounds.centroid(), bounds.axis) > 0;
}

/// The images of the corners of the box [lower, upper] at `moment`; false when one has none
/// (outside the clipping planes) or it is not finite.
bool cornerImages(const Camera& camera, const Camera::Moment& moment, const Vec3f& lower,
                  const Vec3f& upper, PointImage (&corners)[8]) {
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3f point{corner & 1 ? upper.x : lower.x, corner & 2 ? upper.y : lower.y,
                      corner & 4 ? upper.z : lower.z};
    const std::optional<PointImage> image = camera.pointImage(point, moment);
    if (!image || !std::isfinite(image->position.x) || !std::isfinite(image->position.y) ||
        !std::isfinite(image->perLensUnit.x) || !std::isfinite(image->perLensUnit.y))
      return false;
    corners[corner] = *image;
  }
  return true;
}

/// The box holding the images of `corners` through lens point `lens` (unit disk), widened by
/// `margin`.
ImageBox boxThroughLens(const PointImage (&corners)[8], Vec2f lens, float margin) {
  ImageBox box;
  for (const PointImage& corner : corners)
    box.include({corner.position.x + corner.perLensUnit.x * lens.x,
                 corner.position.y + corner.perLensUnit.y * lens.y});
  return box.widened(margin);
}

}  // namespace

LightImages::LightImages(const std::vector<Light>& lights, const Camera& camera, float filterRadius)
    : camera_(camera.isStatic() ? nullptr : &camera), integratesLight_(lights.size(), false) {
  const int width = camera.imageWidth(), height = camera.imageHeight();
  std::vector<float> times{0.0f};
  if (camera_) {
    times.resize(kShutterTimes);
    for (int moment = 0; moment < kShutterTimes; ++moment)
      times[size_t(moment)] = float(moment) / float(kShutterTimes - 1);
  }
  std::vector<Camera::Moment> moments;
  float cameraMagnitude = 0;
  for (const float time : times) {
    moments.push_back(camera.momentAt(time));
    const Vec3f centre = camera.centre(time);
    cameraMagnitude =
        std::max({cameraMagnitude, std::abs(centre.x), std::abs(centre.y), std::abs(centre.z)});
  }
  for (uint32_t index = 0; index < lights.size(); ++index) {
    const Light& light = lights[index];
    if (!light.cameraVisible() || !light.isAreaLight()) continue;
    const LightBounds bounds = light.bounds();
    if (!seenEmitting(bounds, camera)) continue;
    Integrated entry{index, bounds.lower, bounds.upper, {}, {}, 0};  // corners, reach, margin
    // Its image's box over the whole lens at each moment: each must be small; together they
    // are the streak whose pixels list it.
    ImageBox streak;
    float side = 0;
    bool seen = true;
    for (size_t moment = 0; moment < times.size(); ++moment) {
      PointImage corners[8];
      seen = cornerImages(camera, moments[moment], entry.lower, entry.upper, corners);
      if (!seen) break;
      ImageBox box;
      for (const PointImage& image : corners) {
        // The lens is the unit disk: each coordinate of its points within [-1, 1].
        const Vec2f spread{std::abs(image.perLensUnit.x), std::abs(image.perLensUnit.y)};
        box.include({image.position.x - spread.x, image.position.y - spread.y});
        box.include({image.position.x + spread.x, image.position.y + spread.y});
      }
      side = std::max({side, box.upper.x - box.lower.x, box.upper.y - box.lower.y});
      streak.include(box.lower);
      streak.include(box.upper);
      if (moment == 0) std::copy(std::begin(corners), std::end(corners), entry.corners);
    }
    if (!seen || side > kMaxImageSide) continue;
    if (streak.upper.x - streak.lower.x > kMaxStreakSide ||
        streak.upper.y - streak.lower.y > kMaxStreakSide)
      continue;
    const float extent = length(bounds.upper - bounds.lower);
    entry.margin = imageBoxMargin(bounds, cameraMagnitude, extent > 0 ? side / extent : 0.0f);
    // The pixels whose samples may land on its image, through any lens point.
    const ImageBox inImage = streak.widened(filterRadius + entry.margin)
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

std::optional<Camera::Moment> LightImages::momentAt(float time) const {
  if (!camera_) return std::nullopt;
  return camera_->momentAt(time);
}

std::optional<ImageBox> LightImages::imageBox(const Integrated& light, Vec2f lens,
                                              const std::optional<Camera::Moment>& moment) const {
  if (!moment) return boxThroughLens(light.corners, lens, light.margin);
  PointImage corners[8];
  if (!cornerImages(*camera_, *moment, light.lower, light.upper, corners)) return std::nullopt;
  return boxThroughLens(corners, lens, light.margin);
}

bool LightImages::integratesAt(uint32_t index, int x, int y, Vec2f lens, float time) const {
  if (!integrates(index)) return false;
  // A static camera sees each light's image only from pixels that list it.
  if (!camera_) return true;
  // A moving one may see it, at moments between those looked at, from a pixel that does not.
  const Vec2f centre{float(x) + 0.5f, float(y) + 0.5f};
  const auto [begin, end] = near(x, y);
  for (const uint32_t* position = begin; position != end; ++position) {
    const Integrated& light = integrated_[*position];
    if (light.lightIndex == index)
      return integratedBox(light, centre, lens, momentAt(time)).has_value();
  }
  return false;
}

}  // namespace penumbra
