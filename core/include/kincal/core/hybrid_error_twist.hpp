// The hybrid robot's predicted pose error twist $_t = B·Δχ (seed 000 Eq. (8))
// for the controller: fixed-size, allocation-free, and without forming the
// 6 × 150 matrix B. It is the same linear map as identify's
// HybridErrorModel::error_jacobian (identify/src/families/hybrid_error_model.cpp),
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
//   the tool frame ("frame 7", issue #31: the last body's own errors) F6·C
//     at P (tool = F6·C·E).
// Component order per frame: (Δx, Δy, Δz, Δα, Δβ, Δγ) in that frame, with Δz
// omitted for a prismatic and Δγ for a revolute joint frame (Appendix A); the
// tool frame keeps all six.
#pragma once

#include "kincal/core/hybrid.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/status.hpp"

#if defined(__GNUC__)
#define KINCAL_TWIST_NOINLINE __attribute__((noinline))
#else
#define KINCAL_TWIST_NOINLINE
#endif

namespace kincal {

// Layout of Δχ (identify's HybridErrorModel): 6 encoder offsets, then the Δη of
// UPS limbs 1..3 (36 each), the UP limb (21) and the wrist (15) — seed 000's
// 150 — then the tool frame's 6.
struct HybridErrorLayout {
  static constexpr int kEncoders = 6;
  static constexpr int kUpsCount = 36;
  static constexpr int kUpCount = 21;
  static constexpr int kWristCount = 15;
  static constexpr int kEndCount = 6;
  static constexpr int ups(int i) { return kEncoders + kUpsCount * i; }
  static constexpr int up() { return kEncoders + 3 * kUpsCount; }
  static constexpr int wrist() { return up() + kUpCount; }
  static constexpr int tool() { return wrist() + kWristCount; }
  static constexpr int size() { return tool() + kEndCount; }
  // Whether entry k is an angle (rad) rather than a length (mm), as identify's
  // HybridErrorParameter::angular() (a host test compares all 150): the wrist's
  // three encoder offsets (entries 3..5); in every error frame its Δα, Δβ, Δγ
  // in the component order of the file comment — frame 0 of a limb has all
  // six (x y z α β γ), a revolute frame x y z α β, the prismatic frame 3 of a
  // limb x y α β γ. The UP limb's four frames are laid out as a UPS limb's
  // first four, the wrist's three are revolute.
  static constexpr bool angular(int k) {
    if (k < kEncoders) return k >= 3;
    if (k >= tool()) return k - tool() >= 3;
    if (k >= wrist()) return (k - wrist()) % 5 >= 3;
    const int e = k < up() ? (k - kEncoders) % kUpsCount : k - up();  // entry within its limb
    if (e < 6) return e >= 3;
    const int frame = 1 + (e - 6) / 5, c = (e - 6) % 5;
    return frame == 3 ? c >= 2 : c >= 3;
  }
};
static_assert(HybridErrorLayout::tool() == 150, "seed 000 Eq. (7): 150 source errors, then the tool frame");
static_assert(HybridErrorLayout::size() == 156, "150 + the tool frame's 6");

// hybrid_frames_at_pose (the frames at a pose, without joint limits) is in
// hybrid.hpp: hybrid_ik is built on it.

namespace hybrid_twist_detail {

// Adds Ad(R, A − P)·Δη of one revolute joint error frame (seed 000 Eq.:
// Δx, Δy, Δz, Δα, Δβ; Δγ is the joint's own) to `t`, R = [x, −y_neg, z] (the
// wrist frames all have a negated axis as their y column), r = A − P. Plain
// vector arithmetic, no 3×3 temporaries: this runs on the controller's stack.
template <class Scalar>
void add_wrist_frame(Twist<Scalar>& t, const Vec3<Scalar>& x, const Vec3<Scalar>& y_neg, const Vec3<Scalar>& z,
                     const Vec3<Scalar>& r, const Scalar* e) {
  Vec3<Scalar> w = x * e[3];
  w -= y_neg * e[4];
  Vec3<Scalar> v = r.cross(w);
  v += x * e[0];
  v -= y_neg * e[1];
  v += z * e[2];
  t.template head<3>() += v;
  t.template tail<3>() += w;
}

// Adds the twist (a × (P − p), a)·θ of a revolute joint screw (axis a through p).
template <class Scalar>
void add_joint_screw(Twist<Scalar>& t, const Vec3<Scalar>& a, const Vec3<Scalar>& p, const Vec3<Scalar>& P,
                     Scalar theta) {
  const Vec3<Scalar> d = P - p;
  t.template head<3>() += a.cross(d) * theta;
  t.template tail<3>() += a * theta;
}

}  // namespace hybrid_twist_detail

// The parallel part's wrench matrix J_P (seed 000 Eq. (5)) at a configuration,
// factorised: rows are the UPS actuation wrenches ŝ_wa,i (unit force along the
// leg u_i through A6i) and the UP limb's constraint wrenches (forces along
// w2 = y1 and n1 = w2 × w through A0, the couple n3 = w2 × x0), acting on
// twists (v at P, ω) as f·v + m·ω. Stored dimensionless (angular columns / L).
template <class Scalar> struct HybridWrenches {
  SmallLu<Scalar, 6> lu;
  Vec3<Scalar> u[3];  // unit leg vectors u_i (A1i → A6i)
};

// The constants of the error frames that depend on the nominal geometry only
// (identify's model fixes them at the reference configuration: all joint
// angles 0, c = home extension): each UPS limb's reference leg u_r,i and
// horizontal U axis t_i, and e = |A44 A64|.
template <class Scalar> struct HybridErrorReference {
  Vec3<Scalar> leg[3];
  Vec3<Scalar> axis[3];
  Scalar up_split = Scalar(345);
};

template <class Scalar>
HybridErrorReference<Scalar> hybrid_error_reference(const HybridGeometry<Scalar>& g, Scalar up_split) {
  HybridErrorReference<Scalar> r;
  const Vec3<Scalar> c_ref = g.home.extension * Vec3<Scalar>::UnitZ();  // platform centre at the reference
  for (int i = 0; i < 3; ++i) {
    Vec3<Scalar> ur = c_ref + g.platform_joints.col(i) - g.base_joints.col(i);
    ur.normalize();
    Vec3<Scalar> t = ur.cross(Vec3<Scalar>::UnitZ());
    if (t.norm() < Scalar(1e-6)) t = Vec3<Scalar>::UnitX();  // a vertical leg: any horizontal axis
    t.normalize();
    r.leg[i] = ur;
    r.axis[i] = t;
  }
  r.up_split = up_split;
  return r;
}

// Builds and factorises J_P at `f`, and is the controller's singularity test
// of the configuration: the tool twist is $ = J_P⁻¹·[q̇_UPS; 0] + J_S·θ̇
// (Eqs. (5), (6)), so J_f = [J_P⁻¹·E | J_S] and det J_f = det(W_c·J_S) / det J_P:
// J_f is singular exactly when J_P is (a parallel / constraint singularity) or
// when the 3×3 W_c·J_S is (the wrist screws lose rank against the UP limb's
// constraints). Both are judged by the pivot ratio of the dimensionless matrix
// (rows / columns in mm divided by L), as everywhere in core. Status Singular
// or Ok; `w` is usable only on Ok.
template <class Scalar>
Status hybrid_wrenches(const HybridGeometry<Scalar>& g, const HybridFrames<Scalar>& f, HybridWrenches<Scalar>& w) {
  const Vec3<Scalar> ex = Vec3<Scalar>::UnitX();
  const Vec3<Scalar>& P = f.P;
  const Scalar inv_L = Scalar(1) / g.characteristic_length;
  auto JP = w.lu.storage();
  for (int i = 0; i < 3; ++i) {
    const Vec3<Scalar> u = f.legs.col(i).normalized();
    w.u[i] = u;
    JP.template block<1, 3>(i, 0) = u.transpose();
    JP.template block<1, 3>(i, 3) = (Vec3<Scalar>(f.platform_joints.col(i) - P).cross(u) * inv_L).transpose();
  }
  const Vec3<Scalar> n1 = f.y1.cross(f.w), n3 = f.y1.cross(ex);
  JP.template block<1, 3>(3, 0) = f.y1.transpose();
  JP.template block<1, 3>(3, 3) = (P.cross(f.y1) * (-inv_L)).transpose();  // (A0 − P) × y1
  JP.template block<1, 3>(4, 0) = n1.transpose();
  JP.template block<1, 3>(4, 3) = (P.cross(n1) * (-inv_L)).transpose();
  JP.template block<1, 3>(5, 0).setZero();
  JP.template block<1, 3>(5, 3) = (n3 * inv_L).transpose();
  if (!w.lu.factor() || !(w.lu.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio)) return Status::Singular;
  // W_c·J_S: a force f through A0 on the screw of axis a through p gives
  // f·(p × a); the couple n3 gives n3·a. Joint 4's axis w passes through A0.
  SmallLu<Scalar, 3> lu3;
  auto X = lu3.storage();
  const Vec3<Scalar> m5 = f.Q.cross(f.F5.col(0)) * inv_L, m6 = f.P0.cross(f.F5.col(1)) * inv_L;
  X << Scalar(0), f.y1.dot(m5), f.y1.dot(m6),  //
      Scalar(0), n1.dot(m5), n1.dot(m6),         //
      n3.dot(f.w), n3.dot(f.F5.col(0)), n3.dot(f.F5.col(1));
  if (!lu3.factor() || !(lu3.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio)) return Status::Singular;
  return Status::Ok;
}

// $_t = B·Δχ at the configuration `f` (hybrid_frames_at_pose) with J_P
// factorised by hybrid_wrenches, as (v at P, ω) in {R}: exactly the twist
// identify's error_jacobian(pose)·Δχ gives. `errors` points at the 156
// entries of Δχ (HybridErrorLayout). Writes `twist` only on Ok (InvalidInput
// if it is not finite).
//
// Where the sum is cheaper than the matrix: a limb's errors reach the twist
// only through its row of J_P (Eq. (5): J_P⁻¹·G_P). For a UPS limb that row is
// a force along the leg line through A1i and A6i, and every error frame of the
// limb sits at A1i or A6i, so ŝ_wa,iᵀ·Ad(R_f, A_f − P)·Δη_f = u_i·(R_f·Δp_f):
// only each frame's translation error along the leg counts (the moments of
// the rotation errors about the leg line vanish). Likewise the UP limb's
// frames all sit at A0, where its two constraint forces pass: they see Σ R_f·Δp_f,
// the constraint couple sees Σ R_f·Δθ_f.
namespace hybrid_twist_detail {

// The pieces below are separate, non-inlined functions on purpose: each keeps
// its own few vectors, so the controller's worst-case stack is the largest
// piece, not the sum of all their temporaries (Cortex-M bar: 4 KiB).

// ŝ_wa,iᵀ·(A_i·Δη_i) of UPS limb i = Σ_f u·(R_f·Δp_f) (see hybrid_error_twist).
// ur, t: the limb's reference leg and U axis; u: its leg at the configuration;
// e: its 36 entries of Δχ (frame 0 six, frames 1–6 five, translations first).
template <class Scalar>
KINCAL_TWIST_NOINLINE Scalar ups_leg_error(const Vec3<Scalar>& ur, const Vec3<Scalar>& t, const Vec3<Scalar>& u,
                                           const Mat3<Scalar>& Rp, const Scalar* e) {
  // Frames at the configuration: the second U axis n, u' = t × n, t3 = n × u,
  // the platform-fixed S axis s6 and the middle S axis z5 (file comment).
  const Vec3<Scalar> n = u.cross(t).normalized();
  const Vec3<Scalar> t3 = n.cross(u);
  const Vec3<Scalar> s6 = Rp * ur;
  const Vec3<Scalar> z5 = s6.cross(t3).normalized();
  // The terms left out are zero by construction: u ⊥ n and u ⊥ t3, so frame
  // 3's Δx, Δy and frame 5's Δx drop out; frame 4's axes are u, t3×u, t3.
  Scalar g = u.dot(Vec3<Scalar>(e[0], e[1], e[2]));                       // frame 0 (I, A1i)
  g += u.dot(ur) * e[6] + u.dot(t.cross(ur)) * e[7] + u.dot(t) * e[8];     // frame 1 [u_r, t×u_r, t]
  g += u.dot(t) * e[11] - u.dot(t.cross(n)) * e[12];                       // frame 2 [t, −u', n]
  g += e[21];                                                              // frame 4 [u, t3×u, t3]
  g += u.dot(z5.cross(t3)) * e[27] + u.dot(z5) * e[28];                    // frame 5 [t3, z5×t3, z5]
  // Frame 6 [z5×s6, z5, s6]: Δz only; its Δx, Δy act on the platform-fixed
  // end frame Rp·[t, u_r×t, u_r] (the S centre on the platform).
  g += u.dot(Rp * t) * e[31] + u.dot(Rp * ur.cross(t)) * e[32] + u.dot(s6) * e[33];
  return g;
}

// W_c·(A_4·Δη_4) of the UP limb (21 entries): frame 0 (I), frame 1
// [z0, −y0, x0], frame 2 [x0, −x0×y1, y1] (revolute), frame 3 Rp (prismatic:
// Δx, Δy, Δα, Δβ, Δγ), all at A0.
template <class Scalar>
KINCAL_TWIST_NOINLINE void up_limb_error(const HybridFrames<Scalar>& f, const Scalar* e, Scalar* b) {
  const Vec3<Scalar> ex = Vec3<Scalar>::UnitX();
  const Vec3<Scalar> x1y = ex.cross(f.y1);
  // One term per statement: long Eigen sums keep every operand on the stack.
  Vec3<Scalar> lin(e[0] + e[8], e[1] - e[7], e[2] + e[6]);
  lin += ex * e[11];
  lin -= x1y * e[12];
  lin += f.y1 * e[13];
  lin += f.Rp.col(0) * e[16];
  lin += f.Rp.col(1) * e[17];
  Vec3<Scalar> ang(e[3], e[4] - e[10], e[5] + e[9]);
  ang += ex * e[14];
  ang -= x1y * e[15];
  ang += f.Rp.col(0) * e[18];
  ang += f.Rp.col(1) * e[19];
  ang += f.Rp.col(2) * e[20];
  b[0] = f.y1.dot(lin);
  b[1] = f.y1.cross(f.w).dot(lin);
  b[2] = f.y1.cross(ex).dot(ang);
}

// The wrist in series (Eq. (6)): its structural errors (Eq., 15
// entries) and its encoder offsets Δθ_j along the joint screws, added to `t`
// (in {R0}, at P).
// `tool`: the tool frame's six errors in the tool frame F6·C at P
// (tool = F6·C·E): a twist (R·Δp, R·Δθ) at P.
template <class Scalar>
KINCAL_TWIST_NOINLINE void add_wrist_errors(Twist<Scalar>& t, const HybridGeometry<Scalar>& g,
                                            const HybridFrames<Scalar>& f, Scalar up_split, const Scalar* e,
                                            const Scalar* encoders, const Scalar* tool) {
  const Vec3<Scalar>& P = f.P;
  const Vec3<Scalar> A44 = (f.extension - up_split) * f.w;
  add_wrist_frame<Scalar>(t, f.Rp.col(1), f.Rp.col(0), f.w, A44 - P, e);                // [Rp·y0, −Rp·x0, w]
  add_wrist_frame<Scalar>(t, f.w, f.F4.col(1), f.F4.col(0), f.Q - P, e + 5);            // [w, −F4·y, F4·x]
  add_wrist_frame<Scalar>(t, f.F5.col(0), f.F5.col(2), f.F5.col(1), f.P0 - P, e + 10);  // [F5·x, −F5·z, F5·y]
  // Joint screws (a × (P − p), a): joint 4 about w through A44, 5 about F4·x
  // through Q, 6 about F5·y through P0.
  add_joint_screw<Scalar>(t, f.w, A44, P, encoders[0]);
  add_joint_screw<Scalar>(t, f.F4.col(0), f.Q, P, encoders[1]);
  add_joint_screw<Scalar>(t, f.F5.col(1), f.P0, P, encoders[2]);
  const Mat3<Scalar> Rt = f.F6 * g.tool_offset;
  t.template head<3>() += Rt * Vec3<Scalar>(tool[0], tool[1], tool[2]);
  t.template tail<3>() += Rt * Vec3<Scalar>(tool[3], tool[4], tool[5]);
}

}  // namespace hybrid_twist_detail

template <class Scalar>
Status hybrid_error_twist(const HybridGeometry<Scalar>& g, const HybridErrorReference<Scalar>& ref,
                          const HybridFrames<Scalar>& f, const HybridWrenches<Scalar>& w, const Scalar* errors,
                          Twist<Scalar>& twist) {
  using L = HybridErrorLayout;
  // Right-hand side [ŝ_wa,iᵀ·(A_i Δη_i) + Δξ_i ; W_c·(A_4 Δη_4)] (B_ξ of the UPS
  // encoders is J_P⁻¹'s first three columns).
  Vec6<Scalar> b;
  for (int i = 0; i < 3; ++i)
    b(i) = hybrid_twist_detail::ups_leg_error(ref.leg[i], ref.axis[i], w.u[i], f.Rp, errors + L::ups(i)) + errors[i];
  hybrid_twist_detail::up_limb_error(f, errors + L::up(), b.data() + 3);
  Twist<Scalar> out = w.lu.solve(b);
  out.template tail<3>() *= Scalar(1) / g.characteristic_length;  // J_P was solved in scaled unknowns
  hybrid_twist_detail::add_wrist_errors(out, g, f, ref.up_split, errors + L::wrist(), errors + 3, errors + L::tool());
  // Eq. (8): into the workpiece frame {R}.
  const Mat3<Scalar>& Rw = g.workpiece_rotation;
  Twist<Scalar> result;
  result.template head<3>() = Rw * out.template head<3>();
  result.template tail<3>() = Rw * out.template tail<3>();
  if (!all_finite(result)) return Status::InvalidInput;
  twist = result;
  return Status::Ok;
}

// The same, building J_P first (Singular if the configuration is).
template <class Scalar>
Status hybrid_error_twist(const HybridGeometry<Scalar>& g, Scalar up_split, const HybridFrames<Scalar>& f,
                          const Scalar* errors, Twist<Scalar>& twist) {
  HybridWrenches<Scalar> w;
  const Status s = hybrid_wrenches(g, f, w);
  if (s != Status::Ok) return s;
  return hybrid_error_twist(g, hybrid_error_reference(g, up_split), f, w, errors, twist);
}

// Static joint load of a unit weight at P (`weight` in {R}) from the factorised
// J_P, for the compliance effect: τ = J_fᵀ·(F, 0) (core/effects.hpp), with
// J_f's UPS columns J_P⁻¹·e_i and its wrist columns the joint screws at P
// (the same numbers as static_load_forward on hybrid_forward_jacobian).
template <class Scalar>
Vec6<Scalar> hybrid_static_load(const HybridGeometry<Scalar>& g, const HybridFrames<Scalar>& f,
                                const HybridWrenches<Scalar>& w, const Vec3<Scalar>& weight) {
  const Vec3<Scalar> F = g.workpiece_rotation.transpose() * weight;  // in {R0}
  Vec6<Scalar> tau;
  for (int i = 0; i < 3; ++i) tau(i) = F.dot(Vec3<Scalar>(w.lu.solve(Vec6<Scalar>::Unit(i)).template head<3>()));
  tau(3) = F.dot(f.w.cross(f.P));  // joint 4's axis passes through A0
  tau(4) = F.dot(f.F5.col(0).cross(Vec3<Scalar>(f.P - f.Q)));
  tau(5) = F.dot(f.F5.col(1).cross(Vec3<Scalar>(f.P - f.P0)));
  return tau;
}

}  // namespace kincal
