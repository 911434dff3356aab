// 6-UPS Stewart platform (seed 001): inverse kinematics, its Jacobian, and
// forward kinematics by Newton's method.
//
// Model (seed 001 Eq. (1)): leg i joins the base hinge B_i (base frame) to the
// platform hinge P_i (platform frame); with platform pose (R, OP)
//   l_i = |R·P_i + OP − B_i|.
// The actuator reports q_i; the physical leg is l_i = q_i + length_offset_i,
// which is how seed 001's dl_i (Table 3) enters: a zero / encoder offset of the
// leg length. Nominal machines have length_offset = 0.
//
// Leg offsets (issue #31, not in seed 001's 42 parameters): a leg whose
// prismatic line passes at a distance o_i beside its U centre, the S centre
// on that line, keeps |L_i|² = l_i² + o_i² (the U centre, the line's foot and
// the S centre form a right angle), so
//   l_i = √(|L_i|² − s_i),  s_i = o_i² = leg_offset_sq_i (mm²).
// The square is the parameter because |L_i| depends on o_i only through it
// (and so the identification is linear in it where o_i = 0: ∂l/∂o vanishes
// there). 0 for every machine that does not model them: then l_i = |L_i| to
// the last bit.
#pragma once

#include "kincal/core/pose.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/status.hpp"

namespace kincal {

template <class Scalar> struct StewartGeometry {
  Eigen::Matrix<Scalar, 3, 6> base;      // B_i, base frame, mm
  Eigen::Matrix<Scalar, 3, 6> platform;  // P_i, platform frame, mm
  Vec6<Scalar> length_offset = Vec6<Scalar>::Zero();  // l_i − q_i, mm
  Vec6<Scalar> leg_offset_sq = Vec6<Scalar>::Zero();  // s_i: squared distance of leg i's line from its U centre, mm²
  Vec6<Scalar> min_length = Vec6<Scalar>::Constant(Scalar(0));  // actuator stroke on q, mm
  Vec6<Scalar> max_length = Vec6<Scalar>::Constant(Scalar(1e9));
  Pose<Scalar> home;  // FK's default starting pose
  // Length that turns radians into millimetres when judging how singular a
  // Jacobian is (about the platform radius): the conditioning of a mixed-unit
  // matrix is meaningless without it.
  Scalar characteristic_length = Scalar(200);

  template <class Other> StewartGeometry<Other> cast() const {
    StewartGeometry<Other> g;
    g.base = base.template cast<Other>();
    g.platform = platform.template cast<Other>();
    g.length_offset = length_offset.template cast<Other>();
    g.leg_offset_sq = leg_offset_sq.template cast<Other>();
    g.min_length = min_length.template cast<Other>();
    g.max_length = max_length.template cast<Other>();
    g.home = home.template cast<Other>();
    g.characteristic_length = Other(characteristic_length);
    return g;
  }
};
using StewartGeometryd = StewartGeometry<double>;
using StewartGeometryf = StewartGeometry<float>;

// Leg vectors L_i = R·P_i + OP − B_i (columns). No checks: a building block.
template <class Scalar>
Eigen::Matrix<Scalar, 3, 6> stewart_leg_vectors(const StewartGeometry<Scalar>& g, const Pose<Scalar>& pose) {
  Eigen::Matrix<Scalar, 3, 6> legs = pose.R * g.platform;
  legs.colwise() += pose.p;
  legs -= g.base;
  return legs;
}

// Inverse-kinematics Jacobian J = ∂q/∂twist (6×6): row i is
// [u_iᵀ, ((R·P_i) × u_i)ᵀ] with u_i the unit leg vector — the actuation wrench
// of leg i (seed 000 Eq. (3) for a UPS limb). `arms` are R·P_i, `lengths` |L_i|.
template <class Scalar, class Out>
void stewart_jacobian_into(Out&& J, const Eigen::Matrix<Scalar, 3, 6>& arms, const Eigen::Matrix<Scalar, 3, 6>& legs,
                           const Vec6<Scalar>& lengths) {
  for (int i = 0; i < 6; ++i) {
    const Vec3<Scalar> u = legs.col(i) * (Scalar(1) / lengths(i));
    J.template block<1, 3>(i, 0) = u.transpose();
    J.template block<1, 3>(i, 3) = Vec3<Scalar>(arms.col(i)).cross(u).transpose();
  }
}

template <class Scalar>
Mat6<Scalar> stewart_jacobian(const Eigen::Matrix<Scalar, 3, 6>& arms, const Eigen::Matrix<Scalar, 3, 6>& legs,
                              const Vec6<Scalar>& lengths) {
  Mat6<Scalar> J;
  stewart_jacobian_into(J, arms, legs, lengths);
  return J;
}

template <class Scalar>
Mat6<Scalar> stewart_jacobian(const StewartGeometry<Scalar>& g, const Pose<Scalar>& pose) {
  const Eigen::Matrix<Scalar, 3, 6> arms = pose.R * g.platform;
  const Eigen::Matrix<Scalar, 3, 6> legs = stewart_leg_vectors(g, pose);
  return stewart_jacobian(arms, legs, Vec6<Scalar>(legs.colwise().norm().transpose()));
}

// Singularity is judged on a dimensionless Jacobian: the angular columns of
// J = ∂q/∂twist are divided by the characteristic length L.
template <class Scalar> Mat6<Scalar> scale_angular_columns(Mat6<Scalar> J, Scalar length) {
  J.template rightCols<3>() *= Scalar(1) / length;
  return J;
}

// IK: actuator commands q for a platform pose. Writes `q` (and `jacobian`, if
// given, = ∂q/∂twist) only on Ok.
//   InvalidInput  non-finite pose
//   Unreachable   a platform hinge on or below its base hinge's plane
//                 (legs would have to pass through the base: not this assembly mode)
//   OutOfLimits   a command outside [min_length, max_length]
//   Singular      (only when the Jacobian is requested) J is singular here
template <class Scalar>
Status stewart_ik(const StewartGeometry<Scalar>& g, const Pose<Scalar>& pose, Vec6<Scalar>& q,
                  NonDeducedT<Mat6<Scalar>>* jacobian = nullptr) {
  if (!pose.finite()) return Status::InvalidInput;
  const Eigen::Matrix<Scalar, 3, 6> arms = pose.R * g.platform;
  Eigen::Matrix<Scalar, 3, 6> legs = arms - g.base;
  legs.colwise() += pose.p;
  for (int i = 0; i < 6; ++i)
    if (!(legs(2, i) > Scalar(0))) return Status::Unreachable;
  const Vec6<Scalar> distances = legs.colwise().norm().transpose();  // |L_i|
  // l_i = √(|L_i|² − s_i): a leg shorter than its offset cannot reach (the
  // squared norm, not the norm squared, so s = 0 gives |L_i| exactly).
  Vec6<Scalar> lengths;
  for (int i = 0; i < 6; ++i) {
    const Scalar squared = legs.col(i).squaredNorm() - g.leg_offset_sq(i);
    if (!(squared > Scalar(0))) return squared == squared ? Status::Unreachable : Status::InvalidInput;
    lengths(i) = g.leg_offset_sq(i) == Scalar(0) ? distances(i) : Scalar(std::sqrt(squared));
  }
  const Vec6<Scalar> cmd = lengths - g.length_offset;
  if (!all_finite(cmd)) return Status::InvalidInput;
  if ((cmd.array() < g.min_length.array()).any() || (cmd.array() > g.max_length.array()).any())
    return Status::OutOfLimits;
  if (jacobian != nullptr) {
    // ∂l_i = (|L_i| / l_i)·∂|L_i|: row i of the distances' Jacobian scaled.
    Mat6<Scalar> J = stewart_jacobian(arms, legs, distances);
    for (int i = 0; i < 6; ++i)
      if (g.leg_offset_sq(i) != Scalar(0)) J.row(i) *= distances(i) / lengths(i);
    SmallLu<Scalar, 6> lu;
    if (!factor_regular(lu, scale_angular_columns(J, g.characteristic_length))) return Status::Singular;
    *jacobian = J;
  }
  q = cmd;
  return Status::Ok;
}

// FK diagnostics, exposed like LinuxCNC's iteration counters.
template <class Scalar> struct FkReport {
  Status status = Status::NotConverged;
  int iterations = 0;            // Newton steps taken
  Scalar residual = Scalar(0);   // largest joint residual at the end (mm)
};

template <class Scalar> struct FkOptions {
  int max_iterations = Tolerance<Scalar>::fk_max_iterations;
  Scalar relative_residual = Tolerance<Scalar>::fk_residual;  // × the largest joint value
};

// The platform pose where six platform points p_i (platform frame) lie at
// distances ℓ_i from six anchors a_i (base frame): |R·p_i + t − a_i| = ℓ_i,
// by Newton's method with the analytic Jacobian of stewart_jacobian_into, each
// step a twist applied with apply_twist (the iteration stays on SE(3)), from
// `guess`. The 6-UPS's FK (anchors the base joints, distances the leg
// lengths) and the 6-RUS's (anchors the crank tips, distances the rods).
// Writes `pose` only on Ok; stops below `tolerance` (mm).
//
// Once the iterate that the Jacobian was factored at lay within
// kChordResidual × the longest distance of the solution, the next steps
// reuse that factorisation (chord steps: Kelley, Solving Nonlinear Equations
// with Newton's Method, §5.4). The Jacobian then differs from the one at the
// current iterate by about the relative move since, under 1e-5, so a chord
// step leaves about 1e-5 of the residual where a Newton step would leave
// residual²/size; both end below `tolerance` in the same step count from
// home or from the last pose (6-RUS from home: residuals 26, 2.6, 2.8e-3,
// 3.2e-8 mm, then 5.7e-14 either way), and the last step costs no Jacobian
// and no LU — about 40 % of an iteration (docs/benchmarks.md "The 6-RUS").
template <class Scalar>
FkReport<Scalar> six_distance_fk(const Eigen::Matrix<Scalar, 3, 6>& anchors, const Eigen::Matrix<Scalar, 3, 6>& points,
                                 const Vec6<Scalar>& distances, Scalar characteristic_length, Scalar tolerance,
                                 int max_iterations, const Pose<Scalar>& guess, Pose<Scalar>& pose) {
  FkReport<Scalar> report;
  const Scalar inv_length = Scalar(1) / characteristic_length;
  constexpr Scalar kChordResidual = Scalar(1e-5);
  const Scalar chord_residual = kChordResidual * distances.cwiseAbs().maxCoeff();
  Pose<Scalar> x = guess;
  SmallLu<Scalar, 6> lu;
  bool factored_near = false;  // the factorisation's iterate was within chord_residual
  for (int it = 0;; ++it) {
    const Eigen::Matrix<Scalar, 3, 6> arms = x.R * points;
    Eigen::Matrix<Scalar, 3, 6> legs = arms - anchors;
    legs.colwise() += x.p;
    const Vec6<Scalar> lengths = legs.colwise().norm().transpose();
    const Vec6<Scalar> residual = lengths - distances;
    report.iterations = it;
    report.residual = residual.cwiseAbs().maxCoeff();
    if (report.residual < tolerance) {  // also false for NaN
      pose = x;
      report.status = Status::Ok;
      return report;
    }
    if (it == max_iterations || !(report.residual == report.residual)) break;
    // Solve in scaled unknowns (angles × L) so the singularity test is
    // dimensionless, then scale back. The Jacobian is built in the LU's own
    // storage (no copies on the controller's stack).
    if (!factored_near) {
      stewart_jacobian_into(lu.storage(), arms, legs, lengths);
      lu.storage().template rightCols<3>() *= inv_length;
      if (!lu.factor() || !(lu.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio)) {
        report.status = Status::Singular;
        return report;
      }
      factored_near = report.residual < chord_residual;
    }
    Twist<Scalar> step = -lu.solve(residual);
    step.template tail<3>() *= inv_length;
    x = apply_twist(x, step);
  }
  report.status = Status::NotConverged;
  return report;
}

// FK: platform pose for actuator commands q, by Newton's method on
// l(pose) − (q + offset) = 0 with the analytic Jacobian above; each step is a
// twist applied with apply_twist, so the iteration stays on SE(3). Starts from
// `guess` (the last pose in a controller, `home` otherwise). Writes `pose` only
// on Ok. Status: InvalidInput (non-finite q or guess), OutOfLimits (q outside
// the stroke), Singular (J singular on the way), NotConverged.
template <class Scalar>
FkReport<Scalar> stewart_fk(const StewartGeometry<Scalar>& g, const Vec6<Scalar>& q, const Pose<Scalar>& guess,
                            Pose<Scalar>& pose, const NonDeducedT<FkOptions<Scalar>>& options = FkOptions<Scalar>()) {
  FkReport<Scalar> report;
  if (!all_finite(q) || !guess.finite()) {
    report.status = Status::InvalidInput;
    return report;
  }
  if ((q.array() < g.min_length.array()).any() || (q.array() > g.max_length.array()).any()) {
    report.status = Status::OutOfLimits;
    return report;
  }
  const Vec6<Scalar> lengths = q + g.length_offset;
  // The platform joints' distances from the base joints: √(l_i² + s_i).
  Vec6<Scalar> target = lengths;
  for (int i = 0; i < 6; ++i)
    if (g.leg_offset_sq(i) != Scalar(0)) {
      const Scalar squared = lengths(i) * lengths(i) + g.leg_offset_sq(i);
      if (!(squared > Scalar(0))) {
        report.status = squared == squared ? Status::Unreachable : Status::InvalidInput;
        return report;
      }
      target(i) = Scalar(std::sqrt(squared));
    }
  return six_distance_fk(g.base, g.platform, target, g.characteristic_length,
                         options.relative_residual * target.cwiseAbs().maxCoeff(), options.max_iterations, guess, pose);
}

template <class Scalar>
FkReport<Scalar> stewart_fk(const StewartGeometry<Scalar>& g, const Vec6<Scalar>& q, Pose<Scalar>& pose) {
  return stewart_fk(g, q, g.home, pose);
}

}  // namespace kincal
