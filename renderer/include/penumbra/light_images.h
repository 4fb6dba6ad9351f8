// Lights the camera sees directly that are only a few pixels across in the image. A camera ray
// finds such a light only when its filter offset happens to land on the light's image, so the
// pixels around it carry most of the image's noise (a many-light scene's sky of small lamps).
// Instead, each camera sample integrates the pixel filter over each such light's image: it
// draws a filter offset as camera rays do, but only within the box around the light's image (as
// the sample's lens point sees it), and weighs what the camera ray through it sees of the light
// by the share of the filter in that box. The image of a sphere, disk or rect light is an
// ellipse or a quadrilateral (OutlineImage): there the offset is drawn in a row that crosses the
// image within the box, then within the image's span of that row, weighted by the filter's
// shares of both, so that every draw lands on the light; a cylinder light's draws may land beside
// it in its box. Camera rays then pass through these lights without adding their emission, so
// each light's directly seen emission is counted once, by one estimator or the other; both
// converge to the same image (in chromatic media, where the camera ray's free flight is only
// approximate, this estimate is the exact one).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "penumbra/camera.h"
#include "penumbra/light.h"

namespace penumbra {

/// An axis-aligned box of image positions (pixels).
struct ImageBox {
  Vec2f lower{kInfinity, kInfinity}, upper{-kInfinity, -kInfinity};

  bool empty() const { return !(lower.x < upper.x) || !(lower.y < upper.y); }
  void include(Vec2f p) {
    lower = {std::min(lower.x, p.x), std::min(lower.y, p.y)};
    upper = {std::max(upper.x, p.x), std::max(upper.y, p.y)};
  }
  ImageBox widened(float by) const {
    return {{lower.x - by, lower.y - by}, {upper.x + by, upper.y + by}};
  }
  ImageBox intersected(const ImageBox& other) const {
    return {{std::max(lower.x, other.lower.x), std::max(lower.y, other.lower.y)},
            {std::min(upper.x, other.upper.x), std::min(upper.y, other.upper.y)}};
  }
};

/// The image of a sphere, disk or rect light (Light::outline) through one lens point at one
/// moment (Camera::RayFamily): an ellipse for a sphere or disk, a quadrilateral for a rect, in
/// image positions (pixels) relative to `origin`. Its spans hold every position whose ray meets
/// the light, and every position within `margin` pixels of one (rounding may let its ray meet
/// the light too), across rows as along them. Where the image is not bounded (a camera
/// inside a sphere, in a disk's or rect's plane, or seeing it across its horizon), they are
/// whole rows and columns.
class OutlineImage {
 public:
  using Span = std::pair<double, double>;
  OutlineImage(const Camera::RayFamily& family, const Light::Outline& outline, Vec2f origin,
               double margin);
  /// The positions x of row y whose rays may meet the light; none where the row misses it.
  std::optional<Span> row(double y) const;
  /// The rows y whose span reaches columns [x0, x1]; none where that strip misses the image.
  std::optional<Span> rowsWithin(double x0, double x1) const;

 private:
  /// p + px x + py y.
  struct Linear {
    double p, px, py;
  };
  struct Vec2d {
    double x, y;
  };
  /// The positions along one axis where the ellipse's quadratic or the quadrilateral's sides
  /// allow them, the other axis's coordinate fixed at `at` (`alongX`: a row), not widened.
  /// `crosses`: the line is known to cross the image (between its extremes), so that where
  /// rounding leaves it none, it gets the point where it touches.
  std::optional<Span> line(bool alongX, double at, bool crosses) const;

  enum class Shape { Unbounded, Ellipse, Quadrilateral } shape_ = Shape::Unbounded;
  // Ellipse: xx x² + 2 xy x y + yy y² + 2 x x + 2 y y + c >= 0.
  double xx_ = 0, xy_ = 0, yy_ = 0, x_ = 0, y_ = 0, c_ = 0;
  // Quadrilateral: its sides' forms >= 0, two pairs of opposite sides.
  std::array<Linear, 4> sides_{};
  // The points where the image reaches highest and lowest: an ellipse's two, a quadrilateral's
  // four corners.
  std::array<Vec2d, 4> extremes_{};
  int extremeCount_ = 0;
  // The rows it spans, not widened (empty, top_ > bottom_, for an ellipse with no rows).
  double top_ = kInfinity, bottom_ = -kInfinity;
  double margin_;
};

class LightImages {
 public:
  /// Lights whose image (over the whole lens) fits in a box of this side (pixels) are
  /// integrated over their image; with a moving camera, at each moment looked at, and only
  /// while the box around its streak over the shutter is at most kMaxStreakSide (past that, the
  /// box would list it in many pixels its streak does not cross, each paying for its image box
  /// every sample). Drawn in the box, a draw may miss the light beside it, so the gain shrinks
  /// as lights grow (2.1 times less variance than camera rays at 5 pixels across) while the
  /// cost, a ray per sample of every pixel they cover, grows.
  static constexpr float kMaxImageSide = 8;
  /// Rect, disk and sphere lights seen through a perspective camera, whose draws land on them
  /// (OutlineImage), gain as much at their edges whatever their size (a sphere 5 pixels
  /// across: 7.3 times less variance): they are integrated up to this side, past which the
  /// pixels inside, which camera rays already see whole, would pay for most of their rays.
  static constexpr float kMaxOutlinedImageSide = 32;
  static constexpr float kMaxStreakSide = 4 * kMaxImageSide;
  /// Pixels per side of the cells that list the lights near them.
  static constexpr int kCellSize = 8;
  /// The moments of the shutter (evenly spaced, ends included) at which a moving camera's view
  /// of the lights is looked at to choose them and list them near pixels.
  static constexpr int kShutterTimes = 33;

  /// The lights of `lights` that `camera` sees directly, small in its image: area lights (rect,
  /// disk, sphere, cylinder) visible to the camera, emitting towards it, whole between its
  /// clipping planes. A camera that moves, zooms or refocuses over the shutter is looked at
  /// at kShutterTimes moments: a light qualifies when it does at each, and the pixels near any
  /// of those images list it (its streak); each sample then finds its image at its own time.
  /// The camera must outlive this.
  /// `filterRadius`: how far (pixels) a sample may land from its pixel's centre.
  LightImages(const std::vector<Light>& lights, const Camera& camera, float filterRadius);
  /// It keeps the camera when it moves.
  LightImages(const std::vector<Light>& lights, Camera&& camera, float filterRadius) = delete;

  bool empty() const { return integrated_.empty(); }
  /// Whether light `index`'s directly seen emission may be integrated here.
  bool integrates(uint32_t index) const {
    return index < integratesLight_.size() && integratesLight_[index];
  }
  /// An integrated light: its bounding box, its corners as a static camera sees them (unused
  /// when it moves: they are projected per sample), and the
  /// box of image positions whose filter may reach its image through some lens point (at some
  /// moment).
  struct Integrated {
    uint32_t lightIndex;
    Vec3f lower, upper;
    PointImage corners[8];
    ImageBox reach;
    float margin;  // pixels the boxes are widened by, for rounding
    /// A sphere, disk or rect light seen through a perspective camera: its outline, whose image
    /// (OutlineImage) the draws land on; none: they are drawn in the box.
    std::optional<Light::Outline> outline;

    /// Whether samples of the pixel with centre `centre` may see its image.
    bool reaches(Vec2f centre) const {
      return centre.x >= reach.lower.x && centre.x <= reach.upper.x && centre.y >= reach.lower.y &&
             centre.y <= reach.upper.y;
    }
  };
  /// The camera at shutter time `time` when it moves (for imageBox, made once per sample); none
  /// when it is static.
  std::optional<Camera::Moment> momentAt(float time) const;
  /// The box holding `light`'s image seen through lens point `lens` (unit disk) at `moment`
  /// (momentAt's); none when, at that moment, part of the light is outside the clipping planes.
  std::optional<ImageBox> imageBox(const Integrated& light, Vec2f lens,
                                   const std::optional<Camera::Moment>& moment) const;
  /// The box a sample of the pixel with centre `centre` integrates `light` over (imageBox),
  /// none where it does not integrate it: the pixel is beyond its reach, or imageBox has none.
  std::optional<ImageBox> integratedBox(const Integrated& light, Vec2f centre, Vec2f lens,
                                        const std::optional<Camera::Moment>& moment) const {
    if (!light.reaches(centre)) return std::nullopt;
    return imageBox(light, lens, moment);
  }
  /// Whether pixel (x, y)'s camera sample at lens point `lens` and time `time` integrates light
  /// `index` over its image, so that its camera ray must pass the light without adding it.
  bool integratesAt(uint32_t index, int x, int y, Vec2f lens, float time) const;

  /// The integrated lights, in light order.
  const std::vector<Integrated>& integrated() const { return integrated_; }
  /// Those whose image may reach samples of pixel (x, y) (image coordinates), as [begin, end)
  /// of positions in integrated(): those whose reach holds some pixel of its cell.
  std::pair<const uint32_t*, const uint32_t*> near(int x, int y) const;

 private:
  const Camera* camera_ = nullptr;  // set when the camera moves: boxes are found per sample
  std::vector<Integrated> integrated_;
  std::vector<bool> integratesLight_;  // by light index
  int cellsX_ = 0, cellsY_ = 0;
  std::vector<uint32_t> cellStart_;   // by cell: its first entry in cellLights_ (one more at end)
  std::vector<uint32_t> cellLights_;  // each cell's lights (positions in integrated_), in order
};

}  // namespace penumbra
