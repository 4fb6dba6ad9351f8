#include "penumbra/light_images.h"

#include <algorithm>
#include <array>
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

std::optional<std::pair<double, double>> imageRowSpan(const Camera::RayFamily& family,
                                                      const Light::Outline& outline, double y,
                                                      double margin) {
  using Vector = std::array<double, 3>;
  const auto dot = [](const Vector& a, const Vector& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  };
  const auto cross = [](const Vector& a, const Vector& b) {
    return Vector{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  const auto vector = [](const Vec3f& v) { return Vector{v.x, v.y, v.z}; };
  const std::pair<double, double> wholeRow{-kInfinity, kInfinity};
  // The outline is grown by a thousandth of its size, so that rays that graze it by rounding
  // fall inside.
  constexpr double kGrowth = 1.001;
  // The row's ray directions d(x) = row + x · along, x the image position.
  const Vector& along = family.perImageX;
  Vector row;
  for (size_t axis = 0; axis < 3; ++axis)
    row[axis] = family.direction[axis] + y * family.perImageY[axis];
  // From the light's centre to the camera's.
  const Vector toOrigin{family.origin[0] - outline.centre.x, family.origin[1] - outline.centre.y,
                        family.origin[2] - outline.centre.z};
  // Where the quadratic a x² + 2 b x + c is at least 0: between its roots when a < 0, the
  // whole row when the set is not bounded.
  const auto between = [&](double a, double b,
                           double c) -> std::optional<std::pair<double, double>> {
    if (!(a < 0)) return wholeRow;
    // About the vertex -b / a, so that the roots do not cancel.
    const double middle = -b / a;
    const double discriminant = b * b - a * c;
    if (!(discriminant >= 0)) return std::nullopt;
    const double halfWidth = std::sqrt(discriminant) / -a;
    return std::pair<double, double>{middle - halfWidth, middle + halfWidth};
  };
  std::optional<std::pair<double, double>> span;
  if (outline.type == LightType::Sphere) {
    // A ray from o along d meets the sphere (centre c, radius r, w = c - o) where the distance
    // of c from its line is at most r: (w·d)² - (|w|² - r²)|d|² >= 0.
    const Vector w{-toOrigin[0], -toOrigin[1], -toOrigin[2]};
    const double radius = double(outline.radius) * kGrowth;
    const double outside = dot(w, w) - radius * radius;
    if (!(outside > 0)) return wholeRow;
    const auto form = [&](const Vector& p, const Vector& q) {
      return dot(w, p) * dot(w, q) - outside * dot(p, q);
    };
    span = between(form(along, along), form(along, row), form(row, row));
  } else {
    // A ray from o along d meets the light's plane (through its centre, normal n = U × V) at
    // t = -(n·e) / (n·d), e = o - centre, at a = (e + t d)·Û and b likewise (Û = U / |U|²,
    // Light::Outline's coordinates), so (n·d) a = d·α with α = (e·Û) n - (n·e) Û, and
    // (n·d) b = d·β. With s = σ n·d, σ the sign that makes t > 0 where s > 0, the rect is
    // |d·α|, |d·β| <= s, the disk (d·α)² + (d·β)² <= s²; each term is linear in x.
    const Vector u = vector(outline.axisU), v = vector(outline.axisV);
    const Vector n = cross(u, v);
    const double facing = dot(n, toOrigin);
    if (!(dot(u, u) > 0) || !(dot(v, v) > 0) || facing == 0) return wholeRow;  // edge on
    Vector uHat, vHat;
    for (size_t axis = 0; axis < 3; ++axis) {
      uHat[axis] = u[axis] / dot(u, u);
      vHat[axis] = v[axis] / dot(v, v);
    }
    const double sigma = facing < 0 ? 1.0 : -1.0;
    struct Linear {
      double at0, slope;  // the value at x = 0 and per unit of x
    };
    const auto linear = [&](const Vector& coefficients) {
      return Linear{dot(coefficients, row), dot(coefficients, along)};
    };
    Vector alpha, beta, sVector;
    for (size_t axis = 0; axis < 3; ++axis) {
      alpha[axis] = dot(toOrigin, uHat) * n[axis] - facing * uHat[axis];
      beta[axis] = dot(toOrigin, vHat) * n[axis] - facing * vHat[axis];
      sVector[axis] = sigma * n[axis];
    }
    const Linear a = linear(alpha), b = linear(beta), s = linear(sVector);
    if (outline.type == LightType::Rect) {
      std::pair<double, double> interval = wholeRow;
      // Keeps the part of the interval where p + q x >= 0.
      const auto keep = [&](double p, double q) {
        if (q > 0)
          interval.first = std::max(interval.first, -p / q);
        else if (q < 0)
          interval.second = std::min(interval.second, -p / q);
        else if (!(p >= 0))
          interval = {kInfinity, -kInfinity};
      };
      for (const Linear& side : {a, b}) {
        keep(kGrowth * s.at0 - side.at0, kGrowth * s.slope - side.slope);
        keep(kGrowth * s.at0 + side.at0, kGrowth * s.slope + side.slope);
      }
      if (!(interval.first <= interval.second)) return std::nullopt;
      span = interval;
    } else {
      const double growth2 = kGrowth * kGrowth;
      span = between(growth2 * s.slope * s.slope - a.slope * a.slope - b.slope * b.slope,
                     growth2 * s.at0 * s.slope - a.at0 * a.slope - b.at0 * b.slope,
                     growth2 * s.at0 * s.at0 - a.at0 * a.at0 - b.at0 * b.at0);
    }
  }
  if (!span) return std::nullopt;
  return std::pair<double, double>{span->first - margin, span->second + margin};
}

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
    if (!seen || side > (light.outline() ? kMaxOutlinedImageSide : kMaxImageSide)) continue;
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
