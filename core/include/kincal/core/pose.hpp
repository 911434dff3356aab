// Rigid-body pose, rotations, twists and adjoints.
//
// Convention (GUIDE "Measurement CSV"): R = Rz(rz)·Ry(ry)·Rx(rx); this is also
// seed 001 Eq. (2) with α = rz, β = ry, γ = rx. A twist is (v, ω): v the
// linear velocity (or small displacement) of the pose's origin, ω the angular
// velocity (or small rotation vector), both in base-frame coordinates, so that
// a small pose error is  p_actual = p + v,  R_actual = exp([ω]×)·R.
// This is the pose error twist of seed 000 Eq. (1), evaluated at the reference
// point P in the frame {R'0} whose axes are parallel to the base frame.
#pragma once

#include "kincal/core/scalar.hpp"
#include "kincal/core/sin_cos.hpp"

namespace kincal {

template <class Scalar> Mat3<Scalar> skew(const Vec3<Scalar>& v) {
  Mat3<Scalar> m;
  m << Scalar(0), -v.z(), v.y(),  //
      v.z(), Scalar(0), -v.x(),   //
      -v.y(), v.x(), Scalar(0);
  return m;
}

template <class Scalar> Mat3<Scalar> rot_x(Scalar a) {
  Scalar s, c;
  sin_and_cos(a, s, c);
  Mat3<Scalar> m;
  m << Scalar(1), Scalar(0), Scalar(0), Scalar(0), c, -s, Scalar(0), s, c;
  return m;
}
template <class Scalar> Mat3<Scalar> rot_y(Scalar a) {
  Scalar s, c;
  sin_and_cos(a, s, c);
  Mat3<Scalar> m;
  m << c, Scalar(0), s, Scalar(0), Scalar(1), Scalar(0), -s, Scalar(0), c;
  return m;
}
template <class Scalar> Mat3<Scalar> rot_z(Scalar a) {
  Scalar s, c;
  sin_and_cos(a, s, c);
  Mat3<Scalar> m;
  m << c, -s, Scalar(0), s, c, Scalar(0), Scalar(0), Scalar(0), Scalar(1);
  return m;
}

// R = Rz(rz)·Ry(ry)·Rx(rx)
template <class Scalar> inline Mat3<Scalar> rotation_from_rpy(Scalar rx, Scalar ry, Scalar rz) {
  return rot_z(rz) * rot_y(ry) * rot_x(rx);
}

// Inverse of rotation_from_rpy, ry in [-π/2, π/2]. Returns (rx, ry, rz).
template <class Scalar> Vec3<Scalar> rpy_from_rotation(const Mat3<Scalar>& R) {
  const Scalar ry = std::atan2(-R(2, 0), std::sqrt(R(0, 0) * R(0, 0) + R(1, 0) * R(1, 0)));
  const Scalar rz = std::atan2(R(1, 0), R(0, 0));
  const Scalar rx = std::atan2(R(2, 1), R(2, 2));
  return Vec3<Scalar>(rx, ry, rz);
}

// Rodrigues' formula: exp([w]×).
template <class Scalar> Mat3<Scalar> exp_so3(const Vec3<Scalar>& w) {
  const Scalar theta2 = w.squaredNorm();
  const Mat3<Scalar> W = skew(w);
  Scalar a, b;
  if (theta2 < Scalar(1e-8)) {  // Taylor terms: exact to rounding below this
    a = Scalar(1) - theta2 / Scalar(6);
    b = Scalar(0.5) - theta2 / Scalar(24);
  } else {
    const Scalar theta = std::sqrt(theta2);
    Scalar sine, cosine;
    sin_and_cos(theta, sine, cosine);
    a = sine / theta;
    b = (Scalar(1) - cosine) / theta2;
  }
  return Mat3<Scalar>::Identity() + a * W + b * W * W;
}

// Rotation vector of R (inverse of exp_so3), for |angle| < π.
template <class Scalar> Vec3<Scalar> log_so3(const Mat3<Scalar>& R) {
  const Vec3<Scalar> axis_sin(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));  // 2 sinθ · n
  const Scalar s = axis_sin.norm() / Scalar(2);
  const Scalar c = (R.trace() - Scalar(1)) / Scalar(2);
  const Scalar theta = std::atan2(s, c);
  if (s < Scalar(1e-7)) return axis_sin / Scalar(2);  // θ ≈ sinθ for small angles
  return axis_sin * (theta / (Scalar(2) * s));
}

template <class Scalar> struct Pose {
  Mat3<Scalar> R = Mat3<Scalar>::Identity();
  Vec3<Scalar> p = Vec3<Scalar>::Zero();

  static Pose from_xyz_rpy(Scalar x, Scalar y, Scalar z, Scalar rx, Scalar ry, Scalar rz) {
    Pose out;
    out.R = rotation_from_rpy(rx, ry, rz);
    out.p = Vec3<Scalar>(x, y, z);
    return out;
  }
  static Pose from_xyz_rpy(const Vec6<Scalar>& v) { return from_xyz_rpy(v(0), v(1), v(2), v(3), v(4), v(5)); }

  // (x, y, z, rx, ry, rz)
  Vec6<Scalar> to_xyz_rpy() const {
    Vec6<Scalar> v;
    v.template head<3>() = p;
    v.template tail<3>() = rpy_from_rotation(R);
    return v;
  }

  Pose operator*(const Pose& b) const {
    // noalias: out is a fresh object, so Eigen need not evaluate the product
    // into a temporary first (on the controller that temporary and its
    // assignment calls were the deepest frames of the exact IK).
    Pose out;
    out.R.noalias() = R * b.R;
    out.p = p;
    out.p.noalias() += R * b.p;
    return out;
  }
  Pose inverse() const {
    Pose out;
    out.R = R.transpose();
    out.p = -(out.R * p);
    return out;
  }
  Vec3<Scalar> transform(const Vec3<Scalar>& x) const { return R * x + p; }

  bool finite() const { return all_finite(R) && all_finite(p); }

  template <class Other> Pose<Other> cast() const {
    Pose<Other> out;
    out.R = R.template cast<Other>();
    out.p = p.template cast<Other>();
    return out;
  }
};
using Posed = Pose<double>;
using Posef = Pose<float>;

// Apply a small twist: p + v, exp([ω]×)·R (the twist convention above).
template <class Scalar> Pose<Scalar> apply_twist(const Pose<Scalar>& pose, const Twist<Scalar>& t) {
  Pose<Scalar> out;
  out.p = pose.p + t.template head<3>();
  out.R = exp_so3(Vec3<Scalar>(t.template tail<3>())) * pose.R;
  return out;
}

// The twist that takes `nominal` to `actual` (exact inverse of apply_twist).
template <class Scalar> Twist<Scalar> pose_error(const Pose<Scalar>& actual, const Pose<Scalar>& nominal) {
  Twist<Scalar> t;
  t.template head<3>() = actual.p - nominal.p;
  t.template tail<3>() = log_so3(Mat3<Scalar>(actual.R * nominal.R.transpose()));
  return t;
}

// 6×6 adjoint of seed 000 Eq.: maps a twist (v, ω) expressed at a point
// with position r relative to the new reference point, in a frame rotated by R:
//   [ R  [r×]R ; 0  R ].
template <class Scalar> Mat6<Scalar> adjoint(const Mat3<Scalar>& R, const Vec3<Scalar>& r) {
  Mat6<Scalar> A;
  A.template topLeftCorner<3, 3>() = R;
  A.template topRightCorner<3, 3>() = skew(r) * R;
  A.template bottomLeftCorner<3, 3>().setZero();
  A.template bottomRightCorner<3, 3>() = R;
  return A;
}

}  // namespace kincal
