// Private to identify/src: the serial-chain pieces shared by the joint-level
// source-error models of the hybrid (hybrid_error_model.cpp) and the 6-UPS
// (stewart_error_model.cpp): seed 000 Appendix A's error transform per joint
// frame, joint motions and twists, and the Newton closure of a 6-joint limb
// chain on its platform attachment frame.
#pragma once

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "kincal/core/hybrid_exact.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/status.hpp"
#include "kincal/identify/hybrid_error_model.hpp"

namespace kincal::identify::chain {

using Mat6d = Eigen::Matrix<double, 6, 6>;
using Vec6d = Eigen::Matrix<double, 6, 1>;
using Vec3d = Vec3<double>;
using Mat3d = Mat3<double>;

inline Pose<double> make_pose(const Mat3d& R, const Vec3d& p) {
  Pose<double> out;
  out.R = R;
  out.p = p;
  return out;
}

inline Mat3d columns(const Vec3d& x, const Vec3d& y, const Vec3d& z) {
  Mat3d m;
  m.col(0) = x;
  m.col(1) = y;
  m.col(2) = z;
  return m;
}

// E = Trans(Δx, Δy, Δz)·Rx(Δα)·Ry(Δβ)·Rz(Δγ) (the error transform of a frame, in that frame).
inline Pose<double> error_transform(const Vec6d& d) {
  return make_pose(rot_x(d(3)) * rot_y(d(4)) * rot_z(d(5)), d.head<3>());
}

// The six components of a joint frame's five kept errors (Appendix A, k = 0 for
// R: Δγ omitted; k = 1 for P: Δz omitted).
inline Vec6d expand_joint_error(const double* e, bool prismatic) {
  Vec6d d;
  if (prismatic)
    d << e[0], e[1], 0.0, e[2], e[3], e[4];
  else
    d << e[0], e[1], e[2], e[3], e[4], 0.0;
  return d;
}

inline Pose<double> joint_motion(bool prismatic, double x) {
  if (prismatic) return make_pose(Mat3d::Identity(), Vec3d(0, 0, x));
  return make_pose(rot_z(x), Vec3d::Zero());
}

// Twist (v at `point`, ω) of joint frame f's axis per unit joint rate.
inline Vec6d joint_twist(const Pose<double>& f, bool prismatic, const Vec3d& point) {
  Vec6d t;
  const Vec3d a = f.R.col(2);
  if (prismatic) {
    t << a, Vec3d::Zero();
  } else {
    t << a.cross(point - f.p), a;
  }
  return t;
}

struct Closure {
  Status status = Status::NotConverged;
  int iterations = 0;
  double error = 0;               // max(|Δp|, 1000 mm·|Δθ|) at the end
  Eigen::PartialPivLU<Mat6d> lu;  // of the chain's 6×6 joint Jacobian at the solution (twists at the end point)
  Vec3d end = Vec3d::Zero();      // the chain's end point at the solution
};

constexpr double kAngleScale = 1000.0;  // mm per rad in closure tests
constexpr double kClosureTol = 1e-11;   // mm
constexpr int kMaxIterations = 50;

// What moves a chain's end frame onto its target: (Δp, Δθ) in world axes.
inline Vec6d closure_twist(const Pose<double>& target, const Pose<double>& end) {
  Vec6d e;
  e.head<3>() = target.p - end.p;
  e.tail<3>() = log_so3(Mat3d(target.R * end.R.transpose()));
  return e;
}
// Its size in one unit: max(|Δp|, 1000 mm·|Δθ|).
inline double closure_error(const Vec6d& e) { return std::max(e.head<3>().norm(), kAngleScale * e.tail<3>().norm()); }

// Newton on the 6 joint variables x of a limb chain so that its end frame
// coincides with `target` (all six DOF; an S joint is three revolutes).
// `frames_of(x)` gives the chain's frames at joint values x; the chain's six
// joint axes are frames[axis_offset .. axis_offset + 5].
template <class FramesOf>
Closure close_chain(FramesOf frames_of, const std::array<bool, HybridChain::kMaxJoints>& prismatic, int axis_offset,
                    const Pose<double>& target, Vec6d& x) {
  Closure out;
  double prev = std::numeric_limits<double>::infinity();
  for (int it = 0;; ++it) {
    const HybridChainFrames fr = frames_of(x.data());
    const Vec6d e = closure_twist(target, fr.end);
    const double err = closure_error(e);
    Mat6d J;
    for (int j = 0; j < 6; ++j)
      J.col(j) = joint_twist(fr.axis[static_cast<std::size_t>(axis_offset + j)], prismatic[static_cast<std::size_t>(j)],
                             fr.end.p);
    out.lu.compute(J);
    out.iterations = it;
    out.error = err;
    out.end = fr.end.p;
    if (!(err == err)) break;
    // Converged, or at the rounding floor (no longer halving near 1e-11 mm).
    if (err < kClosureTol || (it >= 3 && err < 1e-8 && err > 0.5 * prev)) {
      out.status = Status::Ok;
      return out;
    }
    if (it == kMaxIterations) break;
    if (!(out.lu.rcond() > 1e-13)) {
      out.status = Status::Singular;
      return out;
    }
    x += out.lu.solve(e);
    prev = err;
  }
  out.status = Status::NotConverged;
  return out;
}

// The inverse of a 6 × 6 from its LU, column by column: vector solves, where
// Eigen's inverse() of a fixed 6 × 6 goes through the blocked (allocating)
// triangular solve for matrices.
inline Mat6d inverse_of(const Eigen::PartialPivLU<Mat6d>& lu) {
  Mat6d inv;
  for (int k = 0; k < 6; ++k) inv.col(k) = lu.solve(Vec6d::Unit(k));
  return inv;
}

// The joint frames {R_1,i}..{R_6,i} of a U-P-S limb at its reference
// configuration, and the nominal limb closed on a target in closed form:
// core's (core/hybrid_exact.hpp), which the controller's exact IK uses too.
inline std::array<Pose<double>, 6> ups_reference_frames(const Vec3d& A1, const Vec3d& A6) {
  std::array<Pose<double>, 6> frames;
  kincal::ups_reference_frames(A1, A6, frames.data());
  return frames;
}

inline bool nominal_ups_joints(const Vec3d& A1, const Mat3d& E, const Pose<double>& target, Vec6d& x) {
  return kincal::nominal_ups_joints(A1, E, target, x.data());
}

// A nominal U-P-S limb closed on `target`: the closed form above, checked by
// the limb's own frames (`frames_of`), and Newton from `reference` (close_chain)
// where the check fails (a branch away from the reference configuration).
// Writes the limb's frames; false if neither closes.
template <class FramesOf>
bool close_nominal_ups(FramesOf frames_of, const std::array<bool, HybridChain::kMaxJoints>& prismatic, int axis_offset,
                       const Vec3d& A1, const Mat3d& E, const Vec6d& reference, const Pose<double>& target,
                       HybridChainFrames& frames) {
  Vec6d x;
  if (nominal_ups_joints(A1, E, target, x)) {
    frames = frames_of(x.data());
    if (closure_error(closure_twist(target, frames.end)) < 1e3 * kClosureTol) return true;
  }
  x = reference;
  if (close_chain(frames_of, prismatic, axis_offset, target, x).status != Status::Ok) return false;
  frames = frames_of(x.data());
  return true;
}

}  // namespace kincal::identify::chain
