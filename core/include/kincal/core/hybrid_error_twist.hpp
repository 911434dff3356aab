// The hybrid robot's predicted pose error twist $_t = B·Δχ (seed 000 Eq. (8))
// for the controller: fixed-size, allocation-free, and without forming the
// 6 × 150 matrix B. It is the same linear map as identify's
// HybridErrorModel::error_jacobian (identify/src/hybrid_error_model.cpp),
// evaluated as a weighted sum:
//
//   $_t = J_P⁻¹·[ ŝ_wa,iᵀ·(A_i·Δη_i) + Δξ_i  (i = 1..3) ;  W_c·(A_4·Δη_4) ]
//         + A_w·Δη_w + Σ_j ŝ_ta,j,4·Δθ_j                       (Eqs. (2)–(7))
//
// with A_i·Δη_i = Σ_f Ad(R_f, A_f − P)·Δη_f the twist at P of chain i's
// structural errors (Eqs., (A-2): every error frame's adjoint applied to
// its five or six components), J_P the parallel part's wrench matrix (Eq. (5):
// the three UPS actuation wrenches ŝ_wa,i and the three UP constraint wrenches
// W_c), and the wrist in series (Eq. (6)); then both halves into the workpiece
// frame {R} (Eq. (8)). One 6×6 LU solve replaces J_P⁻¹.
//
// The error frames are those of identify's model (docs/hybrid-error-model.md):
// every limb is a chain of 1-DOF joints whose frames were fixed at the
// reference configuration (all joint angles 0, c = home extension). Here they
// are rebuilt at a configuration from the known axes, without trigonometry
// and without the model's numerical closure of the UPS chains:
//   UPS limb i (U at A1i, P along the leg u, S at A6i), reference leg u_r,
//   horizontal t = u_r × z0 / |…| (x0 for a vertical leg), n_r = u_r × t:
//     frame 0 (I, A1i) (all six errors), frame 1 = [u_r, t×u_r, t] (fixed U axis t),
//     second U axis n = u × t / |…|, u' = t × n, frame 2 = [t, −u', n],
//     t3 = n × u (t carried by the U joint), frame 3 = [n, −t3, u] (P),
//     frame 4 = [u, t3×u, t3] at A6i, s6 = Rp·u_r (the S axis fixed on the
//     platform), z5 = s6 × t3 / |…|, frame 5 = [t3, z5×t3, z5], frame 6 = [z5×s6, z5, s6].
//   UP limb: frame 0 = (I, A0), frame 1 = [z0, −y0, x0], frame 2 = [x0, −Rx(θ1)·z0, y1],
//     frame 3 = Rp (P along w), all at A0.
//   wrist: frame 4 = [Rp·y0, −Rp·x0, w] at A44 = (c − e)·w, frame 5 = [w, −F4·y, F4·x]
//     at Q, frame 6 = [F5·x, −F5·z, F5·y] at P0 (F4, F5 of core/hybrid.hpp).
// Component order per frame: (Δx, Δy, Δz, Δα, Δβ, Δγ) in that frame, with Δz
// omitted for a prismatic and Δγ for a revolute joint frame (Appendix A).
#pragma once

#include "kincal/core/hybrid.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/status.hpp"

namespace kincal {

// Layout of Δχ (identify's HybridErrorModel): 6 encoder offsets, then the Δη of
// UPS limbs 1..3 (36 each), the UP limb (21) and the wrist (15).
struct HybridErrorLayout {
  static constexpr int kEncoders = 6;
  static constexpr int kUpsCount = 36;
  static constexpr int kUpCount = 21;
  static constexpr int kWristCount = 15;
  static constexpr int ups(int i) { return kEncoders + kUpsCount * i; }
  static constexpr int up() { return kEncoders + 3 * kUpsCount; }
  static constexpr int wrist() { return up() + kUpCount; }
  static constexpr int size() { return wrist() + kWristCount; }
};
static_assert(HybridErrorLayout::size() == 150, "seed 000 Eq. (7): 150 source errors");

// Every frame of the chain at the nominal configuration that reaches a tool
// pose in {R}: hybrid_ik's closed form (trig-free, the same arithmetic) but
// without joint limits, so the error twist can be evaluated wherever the
// geometry closes. `wrist_angles` gets the physical wrist angles θ4..θ6.
// Writes the outputs only on Ok; InvalidInput, Unreachable, Singular as
// hybrid_ik.
template <class Scalar>
Status hybrid_frames_at_pose(const HybridGeometry<Scalar>& g, const Pose<Scalar>& tool, HybridFrames<Scalar>& out,
                             Vec3<Scalar>& wrist_angles) {
  if (!tool.finite()) return Status::InvalidInput;
  const Mat3<Scalar> wR0t = g.workpiece_rotation.transpose();
  HybridFrames<Scalar> f;
  f.F6 = wR0t * tool.R * g.tool_offset.transpose();
  f.P = g.workpiece_origin + wR0t * tool.p;
  const Vec3<Scalar> a6 = f.F6.col(1);
  f.P0 = f.P - g.tool_length * f.F6.col(2);
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
  const Scalar s2 = f.w.x(), c2 = std::sqrt(f.w.y() * f.w.y() + f.w.z() * f.w.z());
  const Scalar s1 = -f.w.y() / c2, c1 = f.w.z() / c2;
  f.Rp << c2, Scalar(0), s2, s1 * s2, c1, -s1 * c2, -c1 * s2, s1, c1 * c2;
  f.y1 = Vec3<Scalar>(Scalar(0), c1, s1);
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
  wrist_angles(0) = std::atan2(x5.dot(f.Rp.col(1)), x5.dot(f.Rp.col(0)));
  wrist_angles(1) = std::atan2(-u.dot(f.F4.col(1)), u.dot(f.w));
  wrist_angles(2) = std::atan2(x5.dot(f.F6.col(2)), x5.dot(f.F6.col(0)));
  out = f;
  return Status::Ok;
}

namespace hybrid_twist_detail {

template <class Scalar> Mat3<Scalar> columns(const Vec3<Scalar>& a, const Vec3<Scalar>& b, const Vec3<Scalar>& c) {
  Mat3<Scalar> m;
  m.col(0) = a;
  m.col(1) = b;
  m.col(2) = c;
  return m;
}

// Adds Ad(R, A − P)·Δη of one error frame (seed 000 Eq.) to `t`.
// kind 0: all six components; 1: revolute joint frame (Δγ omitted);
// 2: prismatic joint frame (Δz omitted). Returns the number of components read.
template <class Scalar>
int add_frame(Twist<Scalar>& t, const NonDeducedT<Mat3<Scalar>>& R, const NonDeducedT<Vec3<Scalar>>& r, int kind,
              const Scalar* e) {
  Vec3<Scalar> lin, ang;
  if (kind == 0) {
    lin << e[0], e[1], e[2];
    ang << e[3], e[4], e[5];
  } else if (kind == 1) {
    lin << e[0], e[1], e[2];
    ang << e[3], e[4], Scalar(0);
  } else {
    lin << e[0], e[1], Scalar(0);
    ang << e[2], e[3], e[4];
  }
  const Vec3<Scalar> w = R * ang;
  t.template head<3>() += R * lin + r.cross(w);
  t.template tail<3>() += w;
  return kind == 0 ? 6 : 5;
}

}  // namespace hybrid_twist_detail

// $_t = B·Δχ at the configuration `f` (hybrid_frames_at_pose), as (v at P, ω)
// in {R}: exactly the twist identify's error_jacobian(pose)·Δχ gives.
// `errors` points at the 150 entries of Δχ (HybridErrorLayout). `up_split` is
// e = |A44 A64|. Writes `twist` only on Ok; Singular when J_P (Eq. (5)) is.
template <class Scalar>
Status hybrid_error_twist(const HybridGeometry<Scalar>& g, Scalar up_split, const HybridFrames<Scalar>& f,
                          const Scalar* errors, Twist<Scalar>& twist) {
  using hybrid_twist_detail::add_frame;
  using hybrid_twist_detail::columns;
  using L = HybridErrorLayout;
  const Vec3<Scalar> ex = Vec3<Scalar>::UnitX(), ey = Vec3<Scalar>::UnitY(), ez = Vec3<Scalar>::UnitZ();
  const Vec3<Scalar>& P = f.P;
  const Vec3<Scalar> zero = Vec3<Scalar>::Zero();

  // J_P (Eq. (5)) in dimensionless form, built in the LU's storage; b collects
  // the right-hand side [ŝ_wa,iᵀ·(A_i Δη_i) + Δξ_i ; W_c·(A_4 Δη_4)].
  SmallLu<Scalar, 6> lu;
  auto JP = lu.storage();  // a Map of the LU's own storage
  Vec6<Scalar> b;
  const Vec3<Scalar> c_ref_point = g.home.extension * ez;  // platform centre at the reference configuration
  for (int i = 0; i < 3; ++i) {
    const Vec3<Scalar> A1 = g.base_joints.col(i);
    const Vec3<Scalar> A6 = f.platform_joints.col(i);
    // Reference frames of the chain (identify's constructor).
    Vec3<Scalar> ur = c_ref_point + g.platform_joints.col(i) - A1;
    ur.normalize();
    Vec3<Scalar> t = ur.cross(ez);
    if (t.norm() < Scalar(1e-6)) t = ex;  // a vertical leg: any horizontal axis
    t.normalize();
    // At the configuration.
    const Vec3<Scalar> u = f.legs.col(i).normalized();
    const Vec3<Scalar> n = u.cross(t).normalized();
    const Vec3<Scalar> u1 = t.cross(n);
    const Vec3<Scalar> t3 = n.cross(u);
    const Vec3<Scalar> s6 = f.Rp * ur;
    const Vec3<Scalar> z5 = s6.cross(t3).normalized();
    const Scalar* e = errors + L::ups(i);
    Twist<Scalar> ti = Twist<Scalar>::Zero();
    const Vec3<Scalar> r1 = A1 - P, r6 = A6 - P;
    e += add_frame(ti, Mat3<Scalar>::Identity(), r1, 0, e);
    e += add_frame(ti, columns<Scalar>(ur, t.cross(ur), t), r1, 1, e);
    e += add_frame(ti, columns<Scalar>(t, -u1, n), r1, 1, e);
    e += add_frame(ti, columns<Scalar>(n, -t3, u), r1, 2, e);
    e += add_frame(ti, columns<Scalar>(u, t3.cross(u), t3), r6, 1, e);
    e += add_frame(ti, columns<Scalar>(t3, z5.cross(t3), z5), r6, 1, e);
    add_frame(ti, columns<Scalar>(z5.cross(s6), z5, s6), r6, 1, e);
    // Actuation wrench of limb i: unit force along u through A6 (Eq. (3)).
    const Vec3<Scalar> m = r6.cross(u);
    JP.template block<1, 3>(i, 0) = u.transpose();
    JP.template block<1, 3>(i, 3) = m.transpose();
    b(i) = u.dot(ti.template head<3>()) + m.dot(ti.template tail<3>()) + errors[i];
  }
  {
    // UP limb: constraint wrenches reciprocal to its U and P twists: forces
    // along w2 = y1 and n1 = w2 × w through A0, the couple n3 = w2 × x0.
    const Mat3<Scalar> F2 = columns<Scalar>(ex, -ex.cross(f.y1), f.y1);
    const Vec3<Scalar> r0 = -P;
    const Scalar* e = errors + L::up();
    Twist<Scalar> tu = Twist<Scalar>::Zero();
    e += add_frame(tu, Mat3<Scalar>::Identity(), r0, 0, e);
    e += add_frame(tu, columns<Scalar>(ez, -ey, ex), r0, 1, e);
    e += add_frame(tu, F2, r0, 1, e);
    add_frame(tu, f.Rp, r0, 2, e);
    const Vec3<Scalar> n1 = f.y1.cross(f.w), n3 = f.y1.cross(ex);
    const Vec3<Scalar> m0 = r0.cross(f.y1), m1 = r0.cross(n1);
    JP.template block<1, 3>(3, 0) = f.y1.transpose();
    JP.template block<1, 3>(3, 3) = m0.transpose();
    JP.template block<1, 3>(4, 0) = n1.transpose();
    JP.template block<1, 3>(4, 3) = m1.transpose();
    JP.template block<1, 3>(5, 0) = zero.transpose();
    JP.template block<1, 3>(5, 3) = n3.transpose();
    b(3) = f.y1.dot(tu.template head<3>()) + m0.dot(tu.template tail<3>());
    b(4) = n1.dot(tu.template head<3>()) + m1.dot(tu.template tail<3>());
    b(5) = n3.dot(tu.template tail<3>());
  }
  // Solve J_P·$ = b in scaled unknowns (angles × L) so the singularity test is
  // dimensionless, as in the kinematics.
  const Scalar Lc = g.characteristic_length;
  JP.template rightCols<3>() *= Scalar(1) / Lc;
  if (!lu.factor() || !(lu.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio)) return Status::Singular;
  Twist<Scalar> out = lu.solve(b);
  out.template tail<3>() *= Scalar(1) / Lc;

  // Wrist in series (Eq. (6)): its structural errors (Eq.) and its
  // encoder offsets Δθ_j along the joint screws.
  {
    const Vec3<Scalar> A44 = (f.extension - up_split) * f.w;
    const Mat3<Scalar> W4 = columns<Scalar>(f.Rp * ey, -(f.Rp * ex), f.w);
    const Mat3<Scalar> W5 = columns<Scalar>(f.w, -f.F4.col(1), f.F4.col(0));
    const Mat3<Scalar> W6 = columns<Scalar>(f.F5.col(0), -f.F5.col(2), f.F5.col(1));
    const Scalar* e = errors + L::wrist();
    e += add_frame(out, W4, Vec3<Scalar>(A44 - P), 1, e);
    e += add_frame(out, W5, Vec3<Scalar>(f.Q - P), 1, e);
    add_frame(out, W6, Vec3<Scalar>(f.P0 - P), 1, e);
    const Vec3<Scalar> axes[3] = {f.w, f.F4.col(0), f.F5.col(1)};
    const Vec3<Scalar> through[3] = {A44, f.Q, f.P0};
    for (int j = 0; j < 3; ++j) {
      out.template head<3>() += errors[3 + j] * axes[j].cross(Vec3<Scalar>(P - through[j]));
      out.template tail<3>() += errors[3 + j] * axes[j];
    }
  }
  // Eq. (8): into the workpiece frame {R}.
  const Mat3<Scalar>& Rw = g.workpiece_rotation;
  Twist<Scalar> result;
  result.template head<3>() = Rw * out.template head<3>();
  result.template tail<3>() = Rw * out.template tail<3>();
  if (!all_finite(result)) return Status::InvalidInput;
  twist = result;
  return Status::Ok;
}

}  // namespace kincal
