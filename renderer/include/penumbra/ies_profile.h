// A luminaire's photometric profile (IES LM-63, photometric type C), as UsdLuxShapingAPI's
// `shaping:ies:file` names it: candelas over vertical angles (0 at the nadir, the direction the
// luminaire points) and horizontal angles about that axis, with the symmetries the format
// allows (one horizontal angle: the same all round; 0–90°: each quadrant alike; 0–180° or
// 90–270°: the two halves mirrored; otherwise the whole turn).
#pragma once

#include <string>
#include <vector>

namespace penumbra {

class IesProfile {
 public:
  /// Parses LM-63 text (1986 to 2019 editions: optional `IESNA:` line and `[KEYWORD]` lines,
  /// `TILT=NONE`, `TILT=INCLUDE` with its table, or a tilt file, whose tilt is not applied;
  /// numbers separated by spaces, line ends or commas); candelas are scaled by the file's
  /// candela multiplier and ballast factors. Throws std::invalid_argument saying what is wrong
  /// (a count, or more values than the file can hold, an angle out of order, a value that is
  /// not a finite number, a photometric type other than C, too few values).
  static IesProfile parse(const std::string& text);
  /// Reads and parses the file at `path`; errors name it.
  static IesProfile read(const std::string& path);

  /// Candelas at vertical angle `theta` (radians from the nadir, 0 to π) and horizontal angle
  /// `phi` (radians, any turn), interpolated bilinearly; 0 outside the vertical angles given.
  float candela(float theta, float phi) const;
  /// The mean candela value over the sphere, or over the hemisphere when the vertical angles
  /// span 90° or less (what UsdLux's `shaping:ies:normalize` divides by, as hdEmbree does).
  float meanCandela() const { return meanCandela_; }

 private:
  enum class Symmetry { Rotational, Quadrant, Bilateral, BilateralAcross90, None };
  IesProfile(std::vector<float> vertical, std::vector<float> horizontal,
             std::vector<float> candelas);
  /// `phi` (degrees, [0, 360)) mapped into the horizontal angles given.
  float horizontalAngle(float phiDegrees) const;
  /// The value between the columns (horizontal angles) at `phiDegrees`, interpolated linearly
  /// from `column(h)`, the value of column h.
  template <typename Column>
  double acrossColumns(float phiDegrees, const Column& column) const;

  std::vector<float> vertical_;    // degrees, increasing
  std::vector<float> horizontal_;  // degrees, increasing
  std::vector<float> candelas_;    // horizontal-major: candelas_[h * vertical_.size() + v]
  Symmetry symmetry_ = Symmetry::None;
  float meanCandela_ = 0;
};

}  // namespace penumbra
