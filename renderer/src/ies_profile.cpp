#include "penumbra/ies_profile.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "penumbra/math.h"

namespace penumbra {
namespace {

/// The numbers after the TILT line, read one at a time.
class Numbers {
 public:
  explicit Numbers(std::istream& in) : in_(in) {}

  double next(const char* what) {
    std::string token;
    if (!(in_ >> token)) throw std::invalid_argument(std::string("the file ends before ") + what);
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0' || !std::isfinite(value))
      throw std::invalid_argument(std::string(what) + " '" + token + "' is not a finite number");
    return value;
  }

  int count(const char* what) {
    const double value = next(what);
    if (value != std::floor(value) || value < 1 || value > 100000)
      throw std::invalid_argument(std::string(what) + " must be a whole number from 1 to 100000");
    return int(value);
  }

  std::vector<float> angles(int count, const char* what) {
    std::vector<float> result;
    for (int i = 0; i < count; ++i) {
      result.push_back(float(next(what)));
      if (i > 0 && !(result[size_t(i)] > result[size_t(i) - 1]))
        throw std::invalid_argument(std::string(what) + " must increase");
    }
    return result;
  }

 private:
  std::istream& in_;
};

/// Index i with values[i] <= x < values[i + 1] (clamped to the last interval) and the fraction
/// of the way from values[i] to values[i + 1]; values has two entries or more.
std::pair<size_t, float> bracket(const std::vector<float>& values, float x) {
  const auto upper = std::upper_bound(values.begin() + 1, values.end() - 1, x);
  const size_t i = size_t(upper - values.begin()) - 1;
  const float t = (x - values[i]) / (values[i + 1] - values[i]);
  return {i, std::clamp(t, 0.0f, 1.0f)};
}

}  // namespace

IesProfile IesProfile::parse(const std::string& text) {
  // Lines end in LF, CRLF or (old Mac files) CR; the TILT line's keyword and mode in any case,
  // with spaces around '='.
  std::string lines = text;
  std::replace(lines.begin(), lines.end(), '\r', '\n');
  std::istringstream in(lines);
  std::string line, mode;
  bool tilt = false;
  while (!tilt && std::getline(in, line)) {
    std::string upper = line;
    std::transform(upper.begin(), upper.end(), upper.begin(),
                   [](unsigned char c) { return char(std::toupper(c)); });
    const size_t start = upper.find_first_not_of(" \t");
    if (start == std::string::npos || upper.compare(start, 4, "TILT") != 0) continue;
    const size_t equals = upper.find_first_not_of(" \t", start + 4);
    if (equals == std::string::npos || upper[equals] != '=') continue;
    tilt = true;
    const size_t first = upper.find_first_not_of(" \t", equals + 1);
    if (first != std::string::npos)
      mode = upper.substr(first, upper.find_last_not_of(" \t") + 1 - first);
  }
  if (!tilt) throw std::invalid_argument("there is no TILT= line (not an IES LM-63 profile)");
  // The numbers that follow, separated by spaces, line ends or commas.
  std::string rest(std::istreambuf_iterator<char>(in), {});
  std::replace(rest.begin(), rest.end(), ',', ' ');
  std::istringstream values(rest);
  Numbers numbers(values);
  if (mode == "INCLUDE") {  // lamp-to-luminaire geometry, then angles and factors
    numbers.next("the tilt geometry");
    const int tiltAngles = numbers.count("the number of tilt angles");
    for (int i = 0; i < 2 * tiltAngles; ++i) numbers.next("a tilt value");
  }
  numbers.next("the number of lamps");
  numbers.next("the lumens per lamp");
  const double multiplier = numbers.next("the candela multiplier");
  const int verticalCount = numbers.count("the number of vertical angles");
  const int horizontalCount = numbers.count("the number of horizontal angles");
  // Each value takes two characters or more: a count the file cannot hold is refused before
  // anything is allocated for it.
  const size_t valueCount = size_t(verticalCount) * size_t(horizontalCount);
  if (valueCount > rest.size() / 2)
    throw std::invalid_argument("the file is too short for its " + std::to_string(verticalCount) +
                                " x " + std::to_string(horizontalCount) + " candela values");
  const double photometricType = numbers.next("the photometric type");
  if (photometricType != 1) {
    std::ostringstream type;  // as written (a double too large for an int is no type either)
    type << photometricType;
    throw std::invalid_argument("photometric type " + type.str() +
                                " is not supported (only type C, 1)");
  }
  for (const char* what : {"the units type", "the width", "the length", "the height"})
    numbers.next(what);
  const double scale =
      multiplier * numbers.next("the ballast factor") * numbers.next("the ballast-lamp factor");
  numbers.next("the input watts");
  std::vector<float> vertical = numbers.angles(verticalCount, "vertical angles");
  std::vector<float> horizontal = numbers.angles(horizontalCount, "horizontal angles");
  if (vertical.front() < 0 || vertical.back() > 180)
    throw std::invalid_argument("vertical angles must lie in [0, 180] degrees");
  if (horizontal.front() < 0 || horizontal.back() > 360)
    throw std::invalid_argument("horizontal angles must lie in [0, 360] degrees");
  std::vector<float> candelas;
  candelas.reserve(valueCount);
  for (size_t i = 0; i < valueCount; ++i) {
    const double value = numbers.next("a candela value") * scale;
    if (!(value >= 0) || value > 3.0e38)
      throw std::invalid_argument(
          "candela values times the multiplier and ballast factors must lie in [0, 3e38]");
    candelas.push_back(float(value));
  }
  return IesProfile(std::move(vertical), std::move(horizontal), std::move(candelas));
}

IesProfile IesProfile::read(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::invalid_argument("cannot read the IES profile " + path);
  std::ostringstream text;
  text << file.rdbuf();
  try {
    return parse(text.str());
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument("the IES profile " + path + " is unusable: " + error.what());
  }
}

IesProfile::IesProfile(std::vector<float> vertical, std::vector<float> horizontal,
                       std::vector<float> candelas)
    : vertical_(std::move(vertical)),
      horizontal_(std::move(horizontal)),
      candelas_(std::move(candelas)) {
  const float first = horizontal_.front(), last = horizontal_.back();
  if (horizontal_.size() == 1)
    symmetry_ = Symmetry::Rotational;
  else if (first == 0 && last == 90)
    symmetry_ = Symmetry::Quadrant;
  else if (first == 0 && last == 180)
    symmetry_ = Symmetry::Bilateral;
  else if (first == 90 && last == 270)
    symmetry_ = Symmetry::BilateralAcross90;
  // The mean over the sphere (or the hemisphere the profile covers): each column's integral
  // over the vertical angles, exact for candelas linear in θ between them, then the mean of
  // those over the turn by the same horizontal interpolation candela() makes.
  std::vector<double> columns(horizontal_.size(), 0.0);
  for (size_t h = 0; h < horizontal_.size(); ++h)
    for (size_t v = 0; v + 1 < vertical_.size(); ++v) {
      const double a = vertical_[v] * kPi / 180, b = vertical_[v + 1] * kPi / 180;
      const double from = candelas_[h * vertical_.size() + v];
      const double to = candelas_[h * vertical_.size() + v + 1];
      // ∫ (from + (to − from)(θ − a)/(b − a)) sin θ dθ over [a, b].
      const double ramp = -(b - a) * std::cos(b) + std::sin(b) - std::sin(a);
      columns[h] += from * (std::cos(a) - std::cos(b)) + (to - from) / (b - a) * ramp;
    }
  constexpr int kPhiSteps = 1440;
  double turn = 0;
  for (int j = 0; j < kPhiSteps; ++j)
    turn += acrossColumns(float((j + 0.5) * 360.0 / kPhiSteps),
                          [&columns](size_t h) { return columns[h]; });
  const bool sphere = vertical_.back() - vertical_.front() > 90.0f + 5.73f;  // hdEmbree's 0.1 rad
  meanCandela_ = float(turn / kPhiSteps / (sphere ? 2 : 1));
}

float IesProfile::horizontalAngle(float phi) const {
  switch (symmetry_) {
    case Symmetry::Rotational:
      return horizontal_.front();
    case Symmetry::Quadrant:
      phi = std::fmod(phi, 180.0f);
      return phi > 90 ? 180 - phi : phi;
    case Symmetry::Bilateral:
      return phi > 180 ? 360 - phi : phi;
    case Symmetry::BilateralAcross90:  // mirrored across the 90°–270° plane
      return phi < 90 ? 180 - phi : (phi > 270 ? 540 - phi : phi);
    case Symmetry::None:
      break;
  }
  return phi;
}

template <typename Column>
double IesProfile::acrossColumns(float phiDegrees, const Column& column) const {
  if (horizontal_.size() == 1) return column(0);
  const float h = horizontalAngle(phiDegrees);
  if (h >= horizontal_.front() && h <= horizontal_.back()) {
    const auto [i, t] = bracket(horizontal_, h);
    return column(i) * (1 - t) + column(i + 1) * t;
  }
  // A whole turn given short of 360° (or starting past 0°): across the gap, from the last
  // angle round to the first.
  const float gap = horizontal_.front() + 360 - horizontal_.back();
  const float t = std::fmod(h - horizontal_.back() + 360, 360.0f) / gap;
  return column(horizontal_.size() - 1) * (1 - t) + column(0) * t;
}

float IesProfile::candela(float theta, float phi) const {
  const float thetaDegrees = theta * (180 / kPi);
  if (thetaDegrees < vertical_.front() || thetaDegrees > vertical_.back()) return 0;
  float phiDegrees = std::fmod(phi * (180 / kPi), 360.0f);
  if (phiDegrees < 0) phiDegrees += 360;
  const size_t verticalCount = vertical_.size();
  const auto [v, t] =
      verticalCount == 1 ? std::pair<size_t, float>{0, 0.0f} : bracket(vertical_, thetaDegrees);
  const auto atTheta = [&](size_t h) {  // column h at θ
    const float* column = candelas_.data() + h * verticalCount;
    return verticalCount == 1 ? column[0] : column[v] * (1 - t) + column[v + 1] * t;
  };
  return float(acrossColumns(phiDegrees, atTheta));
}

}  // namespace penumbra
