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

/// Where a t² + 2 b t + c >= 0: between its roots when a < 0 (none where it has none, but its
/// vertex where it is known to have some: `hasRoots`, rounding aside), all of the line
/// (±infinity) otherwise.
std::optional<OutlineImage::Span> nonNegative(double a, double b, double c, bool hasRoots) {
  if (!(a < 0)) return OutlineImage::Span{-kInfinity, kInfinity};
  // About the vertex -b / a, so that the roots do not cancel.
  const double middle = -b / a;
  const double discriminant = b * b - a * c;
  if (!(discriminant >= 0))
    return hasRoots ? std::optional(OutlineImage::Span{middle, middle}) : std::nullopt;
  const double halfWidth = std::sqrt(discriminant) / -a;
  return OutlineImage::Span{middle - halfWidth, middle + halfWidth};
}

}  // namespace

OutlineImage::OutlineImage(const Camera::RayFamily& family, const Light::Outline& outline,
                           Vec2f origin, double margin)
    : margin_(margin) {
  // The outline is grown by a thousandth of its size, so that rays that graze it by rounding
  // fall inside.
  constexpr double kGrowth = 1.001;
  // Ray directions d(x, y) = d0 + x · dx + y · dy, (x, y) relative to the origin.
  const Vec3d& dx = family.perImageX;
  const Vec3d& dy = family.perImageY;
  Vec3d d0;
  for (size_t axis = 0; axis < 3; ++axis)
    d0[axis] = family.direction[axis] + double(origin.x) * dx[axis] + double(origin.y) * dy[axis];
  // From the light's centre to the camera's.
  const Vec3d e{family.origin[0] - outline.centre.x, family.origin[1] - outline.centre.y,
                family.origin[2] - outline.centre.z};
  // A symmetric bilinear form of directions, f(d, d) >= 0 where rays meet the light, as the
  // conic of the image positions.
  const auto setEllipse = [&](auto&& form) {
    xx_ = form(dx, dx);
    xy_ = form(dx, dy);
    yy_ = form(dy, dy);
    x_ = form(dx, d0);
    y_ = form(dy, d0);
    c_ = form(d0, d0);
    // An ellipse when the form is negative definite in (x, y); else not bounded.
    if (!(xx_ < 0 && xx_ * yy_ - xy_ * xy_ > 0)) return;
    shape_ = Shape::Ellipse;
    // Its rows: where the row's quadratic has a root, b(y)² - a c(y) >= 0, itself a quadratic.
    const std::optional<Span> rows =
        nonNegative(xy_ * xy_ - xx_ * yy_, xy_ * x_ - xx_ * y_, x_ * x_ - xx_ * c_, false);
    if (!rows) return;
    top_ = rows->first;
    bottom_ = rows->second;
    for (const double y : {top_, bottom_})
      extremes_[size_t(extremeCount_++)] = {-(xy_ * y + x_) / xx_, y};  // where its chord closes
  };
  if (outline.type == LightType::Sphere) {
    // A ray from the camera along d meets the sphere (centre c, radius r, w = c - o) where the
    // distance of c from its line is at most r: (w·d)² - (|w|² - r²)|d|² >= 0.
    const Vec3d w{-e[0], -e[1], -e[2]};
    const double radius = double(outline.radius) * kGrowth;
    const double outside = dot(w, w) - radius * radius;
    if (!(outside > 0)) return;
    setEllipse([&](const Vec3d& p, const Vec3d& q) {
      return dot(w, p) * dot(w, q) - outside * dot(p, q);
    });
    return;
  }
  // A ray meets the light's plane (through its centre, normal n = U × V) at t = -(n·e) / (n·d),
  // at the point centre + a U + b V with a = (e + t d)·U* and b likewise (U*, V*: the plane's
  // dual axes, U*·U = 1, U*·V = 0), so (n·d) a = d·α with α = (e·U*) n - (n·e) U*, and (n·d) b =
  // d·β. With s = σ n, σ the sign that makes t > 0 where d·s > 0 (times the growth), the rect is
  // |d·α|, |d·β| <= d·s, the disk (d·α)² + (d·β)² <= (d·s)².
  const Vec3d u{outline.axisU.x, outline.axisU.y, outline.axisU.z};
  const Vec3d v{outline.axisV.x, outline.axisV.y, outline.axisV.z};
  const Vec3d n = cross(u, v);
  const double n2 = dot(n, n);
  const double facing = dot(n, e);
  if (!(n2 > 0) || facing == 0) return;                  // degenerate, or seen edge on
  const Vec3d uDual = cross(v, n), vDual = cross(n, u);  // times |n|²
  const double sigma = facing < 0 ? kGrowth : -kGrowth;
  Vec3d alpha, beta, side;
  for (size_t axis = 0; axis < 3; ++axis) {
    alpha[axis] = (dot(e, uDual) * n[axis] - facing * uDual[axis]) / n2;
    beta[axis] = (dot(e, vDual) * n[axis] - facing * vDual[axis]) / n2;
    side[axis] = sigma * n[axis];
  }
  if (outline.type == LightType::Disk) {
    setEllipse([&](const Vec3d& p, const Vec3d& q) {
      return dot(side, p) * dot(side, q) - dot(alpha, p) * dot(alpha, q) -
             dot(beta, p) * dot(beta, q);
    });
    return;
  }
  // The rect's sides d·s - d·α >= 0, d·s + d·α >= 0, and the same with β.
  const auto linear = [&](const Vec3d& form) {
    return Linear{dot(form, d0), dot(form, dx), dot(form, dy)};
  };
  int index = 0;
  for (const Vec3d* axis : {&alpha, &beta})
    for (const double sign : {-1.0, 1.0}) {
      Vec3d form;
      for (size_t k = 0; k < 3; ++k) form[k] = side[k] + sign * (*axis)[k];
      sides_[size_t(index++)] = linear(form);
    }
  // The corners, where a side of each pair meets a side of the other.
  top_ = kInfinity;
  bottom_ = -kInfinity;
  for (int first = 0; first < 2; ++first)
    for (int second = 2; second < 4; ++second) {
      const Linear& a = sides_[size_t(first)];
      const Linear& b = sides_[size_t(second)];
      const double determinant = a.px * b.py - a.py * b.px;
      const Vec2d corner{(a.py * b.p - a.p * b.py) / determinant,
                         (a.p * b.px - a.px * b.p) / determinant};
      if (!std::isfinite(corner.x) || !std::isfinite(corner.y)) return;  // not bounded
      extremes_[size_t(extremeCount_++)] = corner;
      top_ = std::min(top_, corner.y);
      bottom_ = std::max(bottom_, corner.y);
    }
  shape_ = Shape::Quadrilateral;
}

std::optional<OutlineImage::Span> OutlineImage::line(bool alongX, double at, bool crosses) const {
  if (shape_ == Shape::Unbounded) return Span{-kInfinity, kInfinity};
  if (shape_ == Shape::Ellipse) {
    // The conic with one coordinate fixed: a quadratic in the other.
    return alongX ? nonNegative(xx_, xy_ * at + x_, (yy_ * at + 2 * y_) * at + c_, crosses)
                  : nonNegative(yy_, xy_ * at + y_, (xx_ * at + 2 * x_) * at + c_, crosses);
  }
  Span interval{-kInfinity, kInfinity};
  for (const Linear& side : sides_) {
    // p + q t >= 0 along the line.
    const double p = side.p + (alongX ? side.py : side.px) * at;
    const double q = alongX ? side.px : side.py;
    if (q > 0)
      interval.first = std::max(interval.first, -p / q);
    else if (q < 0)
      interval.second = std::min(interval.second, -p / q);
    else if (!(p >= 0) && !crosses)
      return std::nullopt;
  }
  if (interval.first <= interval.second) return interval;
  // Through a corner, rounding may leave the sides' bounds crossed.
  if (!crosses) return std::nullopt;
  const double corner = 0.5 * (interval.first + interval.second);
  return Span{corner, corner};
}

std::optional<OutlineImage::Span> OutlineImage::row(double y) const {
  if (shape_ == Shape::Unbounded) return Span{-kInfinity, kInfinity};
  // Rounding may let a ray meet the light up to the margin beyond its outline, across rows as
  // along them: the row's span is the union of those within the margin above and below it,
  // widened by the margin (the image is convex: the union's ends lie at the band's edges, or at
  // the image's leftmost or rightmost point, which the three rows miss by about the margin's
  // square over the image's size).
  if (!(y >= top_ - margin_ && y <= bottom_ + margin_)) return std::nullopt;
  Span span{kInfinity, -kInfinity};
  for (const double at : {y - margin_, y, y + margin_})
    if (const std::optional<Span> crossing = line(true, std::clamp(at, top_, bottom_), true))
      span = {std::min(span.first, crossing->first), std::max(span.second, crossing->second)};
  if (!(span.first <= span.second)) return std::nullopt;
  return Span{span.first - margin_, span.second + margin_};
}

std::optional<OutlineImage::Span> OutlineImage::rowsWithin(double x0, double x1) const {
  if (shape_ == Shape::Unbounded) return Span{-kInfinity, kInfinity};
  // The image is convex: within the strip its highest and lowest points lie on the strip's
  // edges or are the image's own highest and lowest points (an ellipse's two, or corners).
  // The strip and the rows are widened by the margin, as rows' spans are.
  x0 -= margin_;
  x1 += margin_;
  Span rows{kInfinity, -kInfinity};
  const auto include = [&](double low, double high) {
    rows = {std::min(rows.first, low), std::max(rows.second, high)};
  };
  for (const double x : {x0, x1})
    if (const std::optional<Span> column = line(false, x, false))
      include(column->first, column->second);
  for (int index = 0; index < extremeCount_; ++index) {
    const Vec2d& extreme = extremes_[size_t(index)];
    if (extreme.x >= x0 && extreme.x <= x1) include(extreme.y, extreme.y);
  }
  if (!(rows.first <= rows.second)) return std::nullopt;
  return Span{rows.first - margin_, rows.second + margin_};
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
    Integrated entry{index, bounds.lower, bounds.upper, {}, {}, 0, {}};  // corners, reach, ...
    // The draws land on the light where its image is an outline: a sphere, disk or rect seen
    // through a perspective camera, whose rays share an origin (Camera::rayFamily).
    if (camera.params().projection == Projection::Perspective) entry.outline = light.outline();
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
    if (!seen || side > (entry.outline ? kMaxOutlinedImageSide : kMaxImageSide)) continue;
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
