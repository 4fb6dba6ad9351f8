#include "penumbra/motion.h"

#include <stdexcept>

namespace penumbra {
namespace {

using Column = Vec3d;

Quaternion quaternionFromRotation(const Column& c0, const Column& c1, const Column& c2) {
  // Rotation matrix R with columns c0, c1, c2: R[i][j] = cj[i]. Shepperd's method (stable).
  const double r00 = c0[0], r11 = c1[1], r22 = c2[2];
  const double trace = r00 + r11 + r22;
  Quaternion q;
  if (trace > 0) {
    const double s = 2 * std::sqrt(1 + trace);
    q = {0.25 * s, (c1[2] - c2[1]) / s, (c2[0] - c0[2]) / s, (c0[1] - c1[0]) / s};
  } else if (r00 > r11 && r00 > r22) {
    const double s = 2 * std::sqrt(1 + r00 - r11 - r22);
    q = {(c1[2] - c2[1]) / s, 0.25 * s, (c1[0] + c0[1]) / s, (c2[0] + c0[2]) / s};
  } else if (r11 > r22) {
    const double s = 2 * std::sqrt(1 + r11 - r00 - r22);
    q = {(c2[0] - c0[2]) / s, (c1[0] + c0[1]) / s, 0.25 * s, (c2[1] + c1[2]) / s};
  } else {
    const double s = 2 * std::sqrt(1 + r22 - r00 - r11);
    q = {(c0[1] - c1[0]) / s, (c2[0] + c0[2]) / s, (c2[1] + c1[2]) / s, 0.25 * s};
  }
  return q;
}

/// Any unit vector orthogonal to `v` (for degenerate, zero-scale axes).
Column orthogonalTo(const Column& v) {
  const Column axis = std::fabs(v[0]) < 0.9 ? Column{1, 0, 0} : Column{0, 1, 0};
  const Column u = cross(axis, v);
  const double n = std::sqrt(dot(u, u));
  return {u[0] / n, u[1] / n, u[2] / n};
}

}  // namespace

Quaternion slerp(const Quaternion& a, const Quaternion& bIn, double t) {
  Quaternion b = bIn;
  double cosine = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
  if (cosine < 0) {  // q and -q are the same rotation: take the shorter way round
    b = {-b.w, -b.x, -b.y, -b.z};
    cosine = -cosine;
  }
  double wa = 1 - t, wb = t;
  if (cosine < 0.9995) {
    const double angle = std::acos(cosine), sine = std::sin(angle);
    wa = std::sin((1 - t) * angle) / sine;
    wb = std::sin(t * angle) / sine;
  }
  Quaternion q{wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y, wa * a.z + wb * b.z};
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}

TransformDecomposition decompose(const Transform& m) {
  // Columns of the linear part in column-vector form: A[i][j] = at(j, i), so column j is row j.
  Column a[3];
  for (int j = 0; j < 3; ++j) a[j] = {m.at(j, 0), m.at(j, 1), m.at(j, 2)};
  // Gram–Schmidt QR: A = Q · U with Q orthonormal and U upper triangular.
  TransformDecomposition d;
  Column q[3];
  double u[3][3] = {};
  for (int j = 0; j < 3; ++j) {
    Column v = a[j];
    for (int i = 0; i < j; ++i) {
      u[i][j] = dot(q[i], a[j]);
      for (int k = 0; k < 3; ++k) v[k] -= u[i][j] * q[i][k];
    }
    u[j][j] = std::sqrt(dot(v, v));
    if (u[j][j] > 1e-300) {
      q[j] = {v[0] / u[j][j], v[1] / u[j][j], v[2] / u[j][j]};
    } else if (j == 0) {
      q[0] = {1, 0, 0};
    } else if (j == 1) {
      q[1] = orthogonalTo(q[0]);
    } else {
      q[2] = {q[0][1] * q[1][2] - q[0][2] * q[1][1], q[0][2] * q[1][0] - q[0][0] * q[1][2],
              q[0][0] * q[1][1] - q[0][1] * q[1][0]};
    }
  }
  // Keep Q a proper rotation: a mirror goes into the last scale.
  if (dot(cross(q[0], q[1]), q[2]) < 0) {
    q[2] = {-q[2][0], -q[2][1], -q[2][2]};
    u[2][2] = -u[2][2];
  }
  d.rotation = quaternionFromRotation(q[0], q[1], q[2]);
  d.scaleShear = {u[0][0], u[0][1], u[0][2], u[1][1], u[1][2], u[2][2]};
  d.translation = {m.at(3, 0), m.at(3, 1), m.at(3, 2)};
  return d;
}

Transform compose(const TransformDecomposition& d) {
  const Quaternion& q = d.rotation;
  // Rotation matrix R (column-vector form).
  const double r[3][3] = {
      {1 - 2 * (q.y * q.y + q.z * q.z), 2 * (q.x * q.y - q.w * q.z), 2 * (q.x * q.z + q.w * q.y)},
      {2 * (q.x * q.y + q.w * q.z), 1 - 2 * (q.x * q.x + q.z * q.z), 2 * (q.y * q.z - q.w * q.x)},
      {2 * (q.x * q.z - q.w * q.y), 2 * (q.y * q.z + q.w * q.x), 1 - 2 * (q.x * q.x + q.y * q.y)}};
  const auto& s = d.scaleShear;
  const double u[3][3] = {{s[0], s[1], s[2]}, {0, s[3], s[4]}, {0, 0, s[5]}};
  Transform m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double a = 0;  // A[i][j] = Σ_k R[i][k] U[k][j]; stored row-vector style at(j, i)
      for (int k = 0; k < 3; ++k) a += r[i][k] * u[k][j];
      m.m[size_t(j * 4 + i)] = a;
    }
  for (int i = 0; i < 3; ++i) m.m[size_t(12 + i)] = d.translation[size_t(i)];
  return m;
}

TransformDecomposition interpolate(const TransformDecomposition& a, const TransformDecomposition& b,
                                   double t) {
  TransformDecomposition d;
  for (size_t i = 0; i < 3; ++i)
    d.translation[i] = (1 - t) * a.translation[i] + t * b.translation[i];
  for (size_t i = 0; i < 6; ++i) d.scaleShear[i] = (1 - t) * a.scaleShear[i] + t * b.scaleShear[i];
  d.rotation = slerp(a.rotation, b.rotation, t);
  return d;
}

StepPosition locateStep(size_t stepCount, float time) {
  if (stepCount < 2) return {0, 0};
  const float position = std::clamp(time, 0.0f, 1.0f) * float(stepCount - 1);
  const size_t step = std::min(size_t(position), stepCount - 2);
  return {step, position - float(step)};
}

MotionTransform::MotionTransform(std::vector<Transform> steps) : steps_(std::move(steps)) {
  if (steps_.empty()) throw std::invalid_argument("a motion transform needs at least one sample");
  if (isAnimated())
    for (const Transform& step : steps_) decompositions_.push_back(decompose(step));
}

Transform MotionTransform::at(float time) const {
  if (!isAnimated()) return steps_.front();
  const StepPosition where = locateStep(steps_.size(), time);
  return compose(interpolate(decompositions_[where.step], decompositions_[where.step + 1],
                             double(where.fraction)));
}

}  // namespace penumbra
