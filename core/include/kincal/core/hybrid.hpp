// The 6-DOF hybrid robot of seed 000 (Huang et al.): a 3-UPS + UP parallel
// mechanism in series with a 3R wrist (the UP limb and the wrist form the
// UPRRR limb 4). IK from tool pose to the six actuated joints, FK, and the
// Jacobian. The geometry adopted where the paper is silent is documented in
// docs/hybrid-geometry.md; the frame names follow seed 000 Section 2.
//
//   {R0}: base frame at A0 (centre of the UPS base joints), z0 toward the work.
//   UP limb: U joint at A0 = Rx(θ1)·Ry(θ2) (no spin about the limb axis), the
//     passive prismatic along w = Rp·z, platform centre A64 = c·w (c = q34 + e).
//   UPS limb i: U joint at A1i (base), S joint at A6i = A64 + Rp·a_i; the
//     actuated prismatic length is q_i = |A6i − A1i|.
//   wrist: F4 = Rp·Rz(θ4) (joint 4 about the limb axis), Q = A64 + d_w·w;
//     F5 = F4·Rx(θ5) (joint 5 about F4·x through Q), P0 = Q + l_w·F5·z;
//     F6 = F5·Ry(θ6) (joint 6 about F5·y through P0), P = P0 + l_t·F6·z.
//   tool frame T = F6·C; poses are given in the workpiece frame {R} of seed 000
//     Eq. (8): R_user = wR0·T, p_user = wR0·(P − o), o = workpiece origin in {R0}.
//
// Joint vector q = (q1, q2, q3, θ4, θ5, θ6) as commanded; the physical joint
// is q + joint_offset (seed 000's encoder offsets Δξ: Δq_i and Δθ_j).
#pragma once

#include "kincal/core/pose.hpp"
#include "kincal/core/status.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/stewart.hpp"  // FkReport, FkOptions

namespace kincal {

template <class Scalar> struct HybridPassive {
  Scalar theta1 = Scalar(0);  // U joint at A0, about x0
  Scalar theta2 = Scalar(0);  // U joint at A0, about Rx(θ1)·y0
  Scalar extension = Scalar(0);  // c = |A0 A64|, mm
};

template <class Scalar> struct HybridGeometry {
  Mat3<Scalar> base_joints = Mat3<Scalar>::Zero();      // A1i in {R0}, columns, mm
  Mat3<Scalar> platform_joints = Mat3<Scalar>::Zero();  // a_i = A6i − A64 in the platform frame, mm
  Scalar platform_to_wrist = Scalar(405);  // |A64 Q|
  Scalar wrist_link = Scalar(120);         // |Q P0|
  Scalar tool_length = Scalar(250);        // |P0 P|
  Mat3<Scalar> workpiece_rotation = Mat3<Scalar>::Identity();  // wR0, seed 000 Eq. (8)
  Vec3<Scalar> workpiece_origin = Vec3<Scalar>::Zero();        // origin of {R}, in {R0}
  Mat3<Scalar> tool_offset = Mat3<Scalar>::Identity();         // C
  Vec6<Scalar> joint_offset = Vec6<Scalar>::Zero();            // physical − commanded
  Vec6<Scalar> min_joint = Vec6<Scalar>::Constant(Scalar(-1e9));
  Vec6<Scalar> max_joint = Vec6<Scalar>::Constant(Scalar(1e9));
  Scalar min_extension = Scalar(0), max_extension = Scalar(1e9);
  HybridPassive<Scalar> home;  // FK's default starting configuration
  // Radians → millimetres for singularity tests (about the base-to-tool size).
  Scalar characteristic_length = Scalar(1000);

  template <class Other> HybridGeometry<Other> cast() const {
    HybridGeometry<Other> g;
    g.base_joints = base_joints.template cast<Other>();
    g.platform_joints = platform_joints.template cast<Other>();
    g.platform_to_wrist = Other(platform_to_wrist);
    g.wrist_link = Other(wrist_link);
    g.tool_length = Other(tool_length);
    g.workpiece_rotation = workpiece_rotation.template cast<Other>();
    g.workpiece_origin = workpiece_origin.template cast<Other>();
    g.tool_offset = tool_offset.template cast<Other>();
    g.joint_offset = joint_offset.template cast<Other>();
    g.min_joint = min_joint.template cast<Other>();
    g.max_joint = max_joint.template cast<Other>();
    g.min_extension = Other(min_extension);
    g.max_extension = Other(max_extension);
    g.home.theta1 = Other(home.theta1);
    g.home.theta2 = Other(home.theta2);
    g.home.extension = Other(home.extension);
    g.characteristic_length = Other(characteristic_length);
    return g;
  }
};
using HybridGeometryd = HybridGeometry<double>;
using HybridGeometryf = HybridGeometry<float>;

// Every frame and point of the chain at one configuration, in {R0}. The
// Jacobian and the error models are built from these (seed 000 Eq. (5), (6)).
template <class Scalar> struct HybridFrames {
  Mat3<Scalar> Rp;           // platform (UP limb) orientation
  Vec3<Scalar> w;            // limb axis w_{3,4} = Rp·z
  Vec3<Scalar> y1;           // second U-joint axis, Rx(θ1)·y0
  Scalar extension;          // c
  Eigen::Matrix<Scalar, 3, 3> platform_joints;  // A6i in {R0}
  Eigen::Matrix<Scalar, 3, 3> legs;             // A6i − A1i
  Mat3<Scalar> F4, F5, F6;   // wrist joint frames
  Vec3<Scalar> Q, P0, P;     // wrist points and tool point
};

template <class Scalar>
HybridFrames<Scalar> hybrid_frames(const HybridGeometry<Scalar>& g, const HybridPassive<Scalar>& s,
                                   const Vec3<Scalar>& wrist_angles) {
  HybridFrames<Scalar> f;
  const Mat3<Scalar> R1 = rot_x(s.theta1);
  f.Rp = R1 * rot_y(s.theta2);
  f.w = f.Rp.col(2);
  f.y1 = R1.col(1);
  f.extension = s.extension;
  const Vec3<Scalar> a64 = s.extension * f.w;
  f.platform_joints = f.Rp * g.platform_joints;
  f.platform_joints.colwise() += a64;
  f.legs = f.platform_joints - g.base_joints;
  f.F4 = f.Rp * rot_z(wrist_angles(0));
  f.F5 = f.F4 * rot_x(wrist_angles(1));
  f.F6 = f.F5 * rot_y(wrist_angles(2));
  f.Q = a64 + g.platform_to_wrist * f.w;
  f.P0 = f.Q + g.wrist_link * f.F5.col(2);
  f.P = f.P0 + g.tool_length * f.F6.col(2);
  return f;
}

// Tool pose in the workpiece frame {R}.
template <class Scalar> Pose<Scalar> hybrid_tool_pose(const HybridGeometry<Scalar>& g, const HybridFrames<Scalar>& f) {
  Pose<Scalar> out;
  out.R = g.workpiece_rotation * f.F6 * g.tool_offset;
  out.p = g.workpiece_rotation * (f.P - g.workpiece_origin);
  return out;
}

// Forward Jacobian: tool twist at P in {R} per unit rate of the six actuated
// joints. The parallel part follows seed 000 Eq. (5): the UP limb admits the
// passive rates ṡ = (θ̇1, θ̇2, ċ) (its constraint wrenches remove the rest), and
// the UPS actuation wrenches give q̇_{1..3} = M·ṡ, M_ij = u_i·(axis_j × A6i) for
// the U axes and u_i·w for ċ. The wrist columns are its joint screws taken to P
// (seed 000 Eq. (6)). Returns false if M is singular (a parallel singularity).
template <class Scalar>
bool hybrid_forward_jacobian(const HybridGeometry<Scalar>& g, const HybridFrames<Scalar>& f, Mat6<Scalar>& J) {
  const Vec3<Scalar> ex = Vec3<Scalar>::UnitX();
  Mat3<Scalar> M;
  for (int i = 0; i < 3; ++i) {
    const Vec3<Scalar> u = f.legs.col(i).normalized();
    const Vec3<Scalar> x = f.platform_joints.col(i);
    M(i, 0) = u.dot(ex.cross(x));
    M(i, 1) = u.dot(f.y1.cross(x));
    M(i, 2) = u.dot(f.w);
  }
  const Scalar L = g.characteristic_length;
  M.template leftCols<2>() /= L;  // angle columns in mm per (mm of arc): dimensionless
  SmallLu<Scalar, 3> lu;
  if (!factor_regular(lu, M)) return false;
  Mat3<Scalar> Minv = lu.inverse();
  Minv.template topRows<2>() /= L;
  // Tool twist in {R} per passive rate (k_lin, k_ang), then per actuated UPS
  // rate (k·M⁻¹). Built column by column in {R}: no 6×6 temporaries, which
  // keeps the firmware's worst-case stack small (docs/benchmarks.md).
  const Mat3<Scalar>& Rw = g.workpiece_rotation;
  const Vec3<Scalar> k_lin[3] = {Rw * ex.cross(f.P), Rw * f.y1.cross(f.P), Rw * f.w};
  const Vec3<Scalar> k_ang[3] = {Rw.col(0), Rw * f.y1, Vec3<Scalar>::Zero()};
  for (int j = 0; j < 3; ++j) {
    J.template block<3, 1>(0, j) = k_lin[0] * Minv(0, j) + k_lin[1] * Minv(1, j) + k_lin[2] * Minv(2, j);
    J.template block<3, 1>(3, j) = k_ang[0] * Minv(0, j) + k_ang[1] * Minv(1, j);
  }
  const Vec3<Scalar> axes[3] = {f.w, f.F5.col(0), f.F6.col(1)};
  const Vec3<Scalar> through[3] = {f.Q, f.Q, f.P0};
  for (int j = 0; j < 3; ++j) {
    J.template block<3, 1>(0, 3 + j) = Rw * axes[j].cross(f.P - through[j]);
    J.template block<3, 1>(3, 3 + j) = Rw * axes[j];
  }
  return true;
}

template <class Scalar> bool hybrid_within_limits(const HybridGeometry<Scalar>& g, const Vec6<Scalar>& q) {
  return !((q.array() < g.min_joint.array()).any() || (q.array() > g.max_joint.array()).any());
}

// Every frame of the chain at the nominal configuration that reaches a tool
// pose in {R}, in closed form (trig-free but for the wrist angles), without
// joint limits: hybrid_ik adds the commands and the limits, the controller's
// error twist (hybrid_error_twist.hpp) uses the frames wherever the geometry
// closes. `wrist_angles` gets the physical wrist angles θ4..θ6.
// InvalidInput, Unreachable, Singular as hybrid_ik. A building block: `f` is
// the caller's scratch and is filled as the computation goes (meaningful
// only on Ok) — no second copy of the frames on the controller's stack.
template <class Scalar>
Status hybrid_frames_at_pose(const HybridGeometry<Scalar>& g, const Pose<Scalar>& tool, HybridFrames<Scalar>& f,
                             Vec3<Scalar>& wrist_angles) {
  if (!tool.finite()) return Status::InvalidInput;
  const Mat3<Scalar> wR0t = g.workpiece_rotation.transpose();
  f.F6 = wR0t * tool.R * g.tool_offset.transpose();
  f.P = g.workpiece_origin + wR0t * tool.p;
  const Vec3<Scalar> a6 = f.F6.col(1);  // joint-6 axis, = F5·y
  f.P0 = f.P - g.tool_length * f.F6.col(2);
  // Q lies on the limb line through A0 and joint 5's axis is normal to that
  // line, so F5·z (the link Q→P0, normal to a6) is the part of A0→P0 normal to a6.
  // P0 at A0 would need a negative limb extension; P0 on joint 6's axis line
  // through A0 leaves the limb free to turn about that axis: a singularity.
  if (!(f.P0.norm() > g.wrist_link)) return Status::Unreachable;
  Vec3<Scalar> u = f.P0 - f.P0.dot(a6) * a6;
  const Scalar un = u.norm();
  if (!(un > Scalar(1e-6) * f.P0.norm())) return Status::Singular;
  u /= un;
  f.Q = f.P0 - g.wrist_link * u;
  const Scalar r = f.Q.norm();
  f.w = f.Q / r;
  if (!(f.w.z() > Scalar(0))) return Status::Unreachable;
  f.extension = r - g.platform_to_wrist;
  // Every frame follows from axes already known, without trigonometry:
  // Rp = Rx(θ1)·Ry(θ2) has third column w, so s2 = w_x, c2 = √(w_y² + w_z²),
  // s1 = −w_y/c2, c1 = w_z/c2 (c2 > 0 since w_z > 0).
  const Scalar s2 = f.w.x(), c2 = std::sqrt(f.w.y() * f.w.y() + f.w.z() * f.w.z());
  const Scalar s1 = -f.w.y() / c2, c1 = f.w.z() / c2;
  f.Rp << c2, Scalar(0), s2, s1 * s2, c1, -s1 * c2, -c1 * s2, s1, c1 * c2;
  f.y1 = Vec3<Scalar>(Scalar(0), c1, s1);
  // F4 = [x5, w × x5, w], F5 = [x5, a6, u] (joint 5's axis x5 = a6 × u), F6 given.
  const Vec3<Scalar> x5 = a6.cross(u);
  f.F4.col(0) = x5;
  f.F4.col(1) = f.w.cross(x5);
  f.F4.col(2) = f.w;
  f.F5.col(0) = x5;
  f.F5.col(1) = a6;
  f.F5.col(2) = u;
  f.platform_joints = f.Rp * g.platform_joints;
  f.platform_joints.colwise() += f.extension * f.w;
  f.legs = f.platform_joints - g.base_joints;
  if (!all_finite(f.legs) || !all_finite(f.F6)) return Status::InvalidInput;
  wrist_angles(0) = std::atan2(x5.dot(f.Rp.col(1)), x5.dot(f.Rp.col(0)));  // Rp·Rz(θ4)·x = x5
  wrist_angles(1) = std::atan2(-u.dot(f.F4.col(1)), u.dot(f.w));             // F4·Rx(θ5)·z = u
  wrist_angles(2) = std::atan2(x5.dot(f.F6.col(2)), x5.dot(f.F6.col(0)));   // F5·Ry(θ6) = F6
  return Status::Ok;
}

// IK: commanded joints for a tool pose in {R}; closed form. Writes `q` (and
// `jacobian` = ∂q/∂twist, and `passive`) only on Ok.
//   InvalidInput  non-finite pose
//   Unreachable   no assembly reaches this pose (the wrist centre P0 within
//                 |QP0| of A0, or the limb would point away from the work)
//   OutOfLimits   a UPS length, wrist angle or the UP extension outside its range
//   Singular      joint 6's axis passes through A0 (the IK has a continuum of
//                 solutions), or, when the Jacobian is requested, a parallel or
//                 wrist singularity (J_f rank-deficient)
template <class Scalar>
Status hybrid_ik(const HybridGeometry<Scalar>& g, const Pose<Scalar>& tool, Vec6<Scalar>& q,
                 NonDeducedT<Mat6<Scalar>>* jacobian = nullptr, NonDeducedT<HybridPassive<Scalar>>* passive = nullptr) {
  HybridFrames<Scalar> f;
  Vec3<Scalar> angles;
  const Status frames = hybrid_frames_at_pose(g, tool, f, angles);
  if (frames != Status::Ok) return frames;

  Vec6<Scalar> cmd;
  cmd.template head<3>() = f.legs.colwise().norm().transpose();
  cmd.template tail<3>() = angles;
  cmd -= g.joint_offset;
  if (!all_finite(cmd)) return Status::InvalidInput;
  if (!hybrid_within_limits(g, cmd) || f.extension < g.min_extension || f.extension > g.max_extension)
    return Status::OutOfLimits;
  if (jacobian != nullptr) {
    // Dimensionless J_s = D·J_f·D⁻¹ with D = diag(1,1,1,L,L,L) (angles × L).
    const Scalar L = g.characteristic_length;
    SmallLu<Scalar, 6> lu;
    {
      Mat6<Scalar> Jf;
      if (!hybrid_forward_jacobian(g, f, Jf)) return Status::Singular;
      Jf.template bottomRows<3>() *= L;
      Jf.template rightCols<3>() *= Scalar(1) / L;
      if (!factor_regular(lu, Jf)) return Status::Singular;
    }
    // Nothing can fail past this point, so the output is written in place:
    // J_s⁻¹ = D·J_f⁻¹·D⁻¹, column by column, then unscaled.
    Mat6<Scalar>& inv = *jacobian;
    for (int j = 0; j < 6; ++j) inv.col(j) = lu.solve(Vec6<Scalar>::Unit(j));
    inv.template bottomRows<3>() *= Scalar(1) / L;
    inv.template rightCols<3>() *= L;
  }
  if (passive != nullptr) {
    // Rp = Rx(θ1)·Ry(θ2): Rp(2,1) = s1, Rp(1,1) = c1, Rp(0,2) = s2, Rp(0,0) = c2.
    passive->theta1 = std::atan2(f.Rp(2, 1), f.Rp(1, 1));
    passive->theta2 = std::atan2(f.Rp(0, 2), f.Rp(0, 0));
    passive->extension = f.extension;
  }
  q = cmd;
  return Status::Ok;
}

// FK: tool pose for commanded joints. The wrist is serial, so only the
// parallel part needs Newton's method: solve |A6i(s) − A1i| = q_i + Δq_i for
// the passive s = (θ1, θ2, c) with the 3×3 Jacobian M above, starting from
// `guess` (the last configuration in a controller, `home` otherwise).
// Writes `tool` (and `passive`) only on Ok.
template <class Scalar>
FkReport<Scalar> hybrid_fk(const HybridGeometry<Scalar>& g, const Vec6<Scalar>& q, const HybridPassive<Scalar>& guess,
                           Pose<Scalar>& tool, NonDeducedT<HybridPassive<Scalar>>* passive = nullptr,
                           const NonDeducedT<FkOptions<Scalar>>& options = FkOptions<Scalar>()) {
  FkReport<Scalar> report;
  if (!all_finite(q) || !is_finite(guess.theta1) || !is_finite(guess.theta2) || !is_finite(guess.extension)) {
    report.status = Status::InvalidInput;
    return report;
  }
  if (!hybrid_within_limits(g, q)) {
    report.status = Status::OutOfLimits;
    return report;
  }
  const Vec6<Scalar> physical = q + g.joint_offset;
  const Vec3<Scalar> target = physical.template head<3>();
  const Vec3<Scalar> wrist = physical.template tail<3>();
  const Vec3<Scalar> ex = Vec3<Scalar>::UnitX();
  const Scalar tolerance = options.relative_residual * target.cwiseAbs().maxCoeff();
  HybridPassive<Scalar> s = guess;
  for (int it = 0;; ++it) {
    const Mat3<Scalar> R1 = rot_x(s.theta1);
    const Mat3<Scalar> Rp = R1 * rot_y(s.theta2);
    const Vec3<Scalar> w = Rp.col(2), y1 = R1.col(1);
    Mat3<Scalar> M;
    Vec3<Scalar> residual;
    for (int i = 0; i < 3; ++i) {
      const Vec3<Scalar> x = s.extension * w + Rp * g.platform_joints.col(i);
      const Vec3<Scalar> leg = x - g.base_joints.col(i);
      const Scalar len = leg.norm();
      const Vec3<Scalar> u = leg / len;
      residual(i) = len - target(i);
      M(i, 0) = u.dot(ex.cross(x));
      M(i, 1) = u.dot(y1.cross(x));
      M(i, 2) = u.dot(w);
    }
    report.iterations = it;
    report.residual = residual.cwiseAbs().maxCoeff();
    if (report.residual < tolerance) {  // also false for NaN
      if (s.extension < g.min_extension || s.extension > g.max_extension) {
        report.status = Status::OutOfLimits;
        return report;
      }
      const Pose<Scalar> out = hybrid_tool_pose(g, hybrid_frames(g, s, wrist));
      if (!out.finite()) break;
      tool = out;
      if (passive != nullptr) *passive = s;
      report.status = Status::Ok;
      return report;
    }
    if (it == options.max_iterations || !(report.residual == report.residual)) break;
    M.template leftCols<2>() /= g.characteristic_length;  // dimensionless, as in the Jacobian
    SmallLu<Scalar, 3> lu;
    if (!factor_regular(lu, M)) {
      report.status = Status::Singular;
      return report;
    }
    Vec3<Scalar> step = -lu.solve(residual);
    step.template head<2>() /= g.characteristic_length;
    s.theta1 += step(0);
    s.theta2 += step(1);
    s.extension += step(2);
  }
  report.status = Status::NotConverged;
  return report;
}

template <class Scalar>
FkReport<Scalar> hybrid_fk(const HybridGeometry<Scalar>& g, const Vec6<Scalar>& q, Pose<Scalar>& tool) {
  return hybrid_fk(g, q, g.home, tool);
}

}  // namespace kincal
