// Small vector/matrix types for the renderer. Points and directions are float (Embree's
// precision); transforms are kept in double until they are applied.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace penumbra {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 0.31830988618379067154f;
constexpr float kInfinity = INFINITY;

struct Vec2f {
  float x = 0, y = 0;
};

struct Vec3f {
  float x = 0, y = 0, z = 0;

  constexpr Vec3f() = default;
  constexpr Vec3f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  constexpr explicit Vec3f(float v) : x(v), y(v), z(v) {}

  float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  Vec3f operator-() const { return {-x, -y, -z}; }
  Vec3f& operator+=(const Vec3f& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  Vec3f& operator*=(const Vec3f& o) {
    x *= o.x;
    y *= o.y;
    z *= o.z;
    return *this;
  }
  Vec3f& operator*=(float s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
};

inline Vec3f operator+(const Vec3f& a, const Vec3f& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline Vec3f operator-(const Vec3f& a, const Vec3f& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline Vec3f operator*(const Vec3f& a, const Vec3f& b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z};
}
inline Vec3f operator*(const Vec3f& a, float s) {
  return {a.x * s, a.y * s, a.z * s};
}
inline Vec3f operator*(float s, const Vec3f& a) {
  return a * s;
}
inline Vec3f operator/(const Vec3f& a, float s) {
  return a * (1.0f / s);
}
inline float dot(const Vec3f& a, const Vec3f& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Vec3f cross(const Vec3f& a, const Vec3f& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(const Vec3f& a) {
  return std::sqrt(dot(a, a));
}
/// A vector in double precision, for the few computations float would lose (rotations taken
/// apart, the outlines of lights' images, colour matrices).
using Vec3d = std::array<double, 3>;
inline double dot(const Vec3d& a, const Vec3d& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline Vec3f normalize(const Vec3f& a) {
  return a / length(a);
}
inline float maxComponent(const Vec3f& a) {
  return std::max(a.x, std::max(a.y, a.z));
}
inline float maxAbsComponent(const Vec3f& a) {
  return std::max(std::fabs(a.x), std::max(std::fabs(a.y), std::fabs(a.z)));
}
/// Per-component minimum and maximum (as std::min and std::max order their arguments).
inline Vec3f componentMin(const Vec3f& a, const Vec3f& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
inline Vec3f componentMax(const Vec3f& a, const Vec3f& b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline bool isBlack(const Vec3f& a) {
  return a.x == 0 && a.y == 0 && a.z == 0;
}
inline bool isFinite(const Vec3f& a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}
/// The mean of the three components.
inline float average(const Vec3f& v) {
  return (v.x + v.y + v.z) / 3;
}
/// Rec.709 luminance of a linear RGB triple.
inline float luminance(const Vec3f& rgb) {
  return 0.2126f * rgb.x + 0.7152f * rgb.y + 0.0722f * rgb.z;
}

/// Orthonormal basis around a unit normal (Duff et al. 2017, branchless).
struct Frame {
  Vec3f s, t, n;

  explicit Frame(const Vec3f& normal) : n(normal) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    s = {1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x};
    t = {b, sign + n.y * n.y * a, -n.y};
  }
  /// The frame whose s is `tangent` made orthogonal to the normal (t = n × s, right-handed);
  /// Frame(normal) where the tangent is (nearly) parallel to the normal or not finite.
  static Frame withTangent(const Vec3f& normal, const Vec3f& tangent) {
    Frame frame(normal);
    const Vec3f inPlane = tangent - normal * dot(normal, tangent);
    const float len = std::sqrt(dot(inPlane, inPlane));
    if (!(len > 1e-6f * std::sqrt(dot(tangent, tangent))) || !std::isfinite(len)) return frame;
    frame.s = inPlane / len;
    frame.t = cross(normal, frame.s);
    return frame;
  }
  Vec3f toWorld(const Vec3f& v) const { return s * v.x + t * v.y + n * v.z; }
  Vec3f toLocal(const Vec3f& v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
};

/// An axis-aligned box; empty (lower above upper) until a point extends it.
struct Bounds3f {
  Vec3f lower{kInfinity, kInfinity, kInfinity};
  Vec3f upper{-kInfinity, -kInfinity, -kInfinity};

  bool empty() const { return lower.x > upper.x || lower.y > upper.y || lower.z > upper.z; }
  void extend(const Vec3f& point) {
    lower = componentMin(lower, point);
    upper = componentMax(upper, point);
  }
  void extend(const Bounds3f& other) {
    lower = componentMin(lower, other.lower);
    upper = componentMax(upper, other.upper);
  }
  bool contains(const Vec3f& p) const {
    return p.x >= lower.x && p.x <= upper.x && p.y >= lower.y && p.y <= upper.y && p.z >= lower.z &&
           p.z <= upper.z;
  }
};

/// The common part of two boxes (empty when they do not meet).
inline Bounds3f intersection(const Bounds3f& a, const Bounds3f& b) {
  return {componentMax(a.lower, b.lower), componentMin(a.upper, b.upper)};
}

/// Affine transform in USD's row-vector convention: p' = p · M, translation in the last row.
/// Stored as the 4x4 row-major matrix USD gives (Gf.Matrix4d).
struct Transform {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

  static Transform fromRowMajor(const double* values) {
    Transform t;
    std::copy(values, values + 16, t.m.begin());
    return t;
  }
  double at(int row, int col) const { return m[row * 4 + col]; }

  Vec3f applyToPoint(const Vec3f& p) const {
    return {float(p.x * at(0, 0) + p.y * at(1, 0) + p.z * at(2, 0) + at(3, 0)),
            float(p.x * at(0, 1) + p.y * at(1, 1) + p.z * at(2, 1) + at(3, 1)),
            float(p.x * at(0, 2) + p.y * at(1, 2) + p.z * at(2, 2) + at(3, 2))};
  }
  Vec3f applyToVector(const Vec3f& v) const {
    return {float(v.x * at(0, 0) + v.y * at(1, 0) + v.z * at(2, 0)),
            float(v.x * at(0, 1) + v.y * at(1, 1) + v.z * at(2, 1)),
            float(v.x * at(0, 2) + v.y * at(1, 2) + v.z * at(2, 2))};
  }
  /// Determinant of the linear 3x3 part (negative: the transform mirrors).
  double linearDeterminant() const {
    return at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1)) -
           at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0)) +
           at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0));
  }
  /// What transforms normals: the inverse transpose of the linear part, as the cofactor matrix
  /// times the determinant's sign (unnormalised results). A mirroring transform therefore keeps
  /// the authored front side, as Hydra's rule "flip the orientation when det < 0" requires.
  /// Made once for several normals of one transform (applyToNormal makes it for one).
  struct NormalMatrix {
    double sign;
    std::array<double, 9> cofactors;  // row-major, in column-vector form

    Vec3f apply(const Vec3f& n) const {
      const std::array<double, 9>& c = cofactors;
      return {float(sign * (c[0] * n.x + c[1] * n.y + c[2] * n.z)),
              float(sign * (c[3] * n.x + c[4] * n.y + c[5] * n.z)),
              float(sign * (c[6] * n.x + c[7] * n.y + c[8] * n.z))};
    }
  };
  NormalMatrix normalMatrix() const {
    // In column-vector form A[i][j] = at(j, i); normals transform by sign(det A) · cof(A).
    const double a00 = at(0, 0), a01 = at(1, 0), a02 = at(2, 0);
    const double a10 = at(0, 1), a11 = at(1, 1), a12 = at(2, 1);
    const double a20 = at(0, 2), a21 = at(1, 2), a22 = at(2, 2);
    return {linearDeterminant() < 0 ? -1.0 : 1.0,
            {a11 * a22 - a12 * a21, a12 * a20 - a10 * a22, a10 * a21 - a11 * a20,
             a02 * a21 - a01 * a22, a00 * a22 - a02 * a20, a01 * a20 - a00 * a21,
             a01 * a12 - a02 * a11, a02 * a10 - a00 * a12, a00 * a11 - a01 * a10}};
  }
  Vec3f applyToNormal(const Vec3f& n) const { return normalMatrix().apply(n); }
  /// The inverse of an affine transform (singular linear parts give non-finite values).
  Transform inverse() const {
    Transform result;
    // Inverse of the linear part L (row-vector form): adj(L) / det(L), via cofactors.
    const double det = linearDeterminant();
    auto cofactor = [this](int r, int c) {
      const int r0 = (r + 1) % 3, r1 = (r + 2) % 3, c0 = (c + 1) % 3, c1 = (c + 2) % 3;
      return at(r0, c0) * at(r1, c1) - at(r0, c1) * at(r1, c0);
    };
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) result.m[size_t(r * 4 + c)] = cofactor(c, r) / det;
    for (int c = 0; c < 3; ++c) {
      double t = 0;
      for (int k = 0; k < 3; ++k) t -= at(3, k) * result.at(k, c);
      result.m[size_t(12 + c)] = t;
    }
    return result;
  }
  /// The 3x4 column-major matrix Embree expects for RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR.
  std::array<float, 12> toEmbreeColumnMajor3x4() const {
    std::array<float, 12> out{};
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 3; ++row) out[col * 3 + row] = float(at(col, row));
    return out;
  }
};

}  // namespace penumbra
