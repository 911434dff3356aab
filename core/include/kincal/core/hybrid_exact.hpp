// The erroneous hybrid machine itself, not its first-order image (issue #31):
// every limb a serial chain of 1-DOF joints whose links carry the identified
// source errors Δχ (seed 000 Appendix A, the parametrisation of identify's
// HybridErrorModel and docs/hybrid-error-model.md), with
//
//   T_end = T_parent · base·E_0 · Π_j ( L_j·E_j · M_j(x_j) ) · L_end (·E_7 for the tool)
//
// L_j the nominal link to joint j's frame {R_j,i}, E_j = Trans(Δx, Δy, Δz)·
// Rx(Δα)·Ry(Δβ)·Rz(Δγ) its error (the component along / about the joint's
// own axis is the joint variable's: zero here), M_j = Rz(x) or Tz(x). The
// errors are constant on their links, so each L_j·E_j is folded once
// (hybrid_exact_chains) and a chain costs what the nominal one does.
//
// Two solvers over the same chains, allocation-free and bounded:
//   hybrid_exact_ik  the commands that put the erroneous machine's tool on a
//                    pose: the UP limb and the wrist form one 6-joint serial
//                    chain (θ1, θ2, c − e, θ4, θ5, θ6), solved by Newton from
//                    the nominal closed form; then each UPS limb (U, P, S: six
//                    joints) is closed on its platform attachment by a 6 × 6
//                    Newton, whose prismatic variable is the leg's length
//                    (on the host, a limb whose S is a ball by a 3 × 3 one
//                    on the ball's centre: close_ups_on_centre).
//   hybrid_exact_fk  the pose for commands: Newton on the UP passive (θ1, θ2, c)
//                    so that each closed UPS limb's length equals its command
//                    (identify's HybridErrorModel::actual_fk, the "truth").
// Both work in the base frame {R0} and convert at the workpiece frame {R}
// (seed 000 Eq. (8)).
#pragma once

#include <cstdint>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/hybrid_error_twist.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/sin_cos.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/status.hpp"

#if defined(__GNUC__)
#define KINCAL_EXACT_NOINLINE __attribute__((noinline))
#else
#define KINCAL_EXACT_NOINLINE
#endif

namespace kincal {

// One chain of N joints: T_end = T_parent · base · Π_j (link[j] · M_j(x_j)) ·
// end. Nominal (hybrid_exact_chains with no errors) or with Δχ folded into base, links
// and end.
template <class Scalar, int N> struct HybridChainLinks {
  static constexpr int kJoints = N;
  Pose<Scalar> base;
  Pose<Scalar> link[N];
  Pose<Scalar> end;
};
template <class Scalar> using HybridUpsLinks = HybridChainLinks<Scalar, 6>;     // U (2 R), P, S (3 R)
template <class Scalar> using HybridSerialLinks = HybridChainLinks<Scalar, 3>;  // UP: U (2 R), P; wrist: 3 R

// Each joint's axis in the world at a configuration: where its twist acts.
template <class Scalar, int N> struct HybridJointAxes {
  Vec3<Scalar> direction[N];
  Vec3<Scalar> point[N];
};

// UPS limb i as a chain from {R0} to its S centre frame {R_6,i}, and what
// closes it: the attachment of that frame on the platform, and the
// reference axes its closed-form start is taken about.
template <class Scalar> struct HybridUpsLimb {
  HybridUpsLinks<Scalar> links;  // U (2 R), P, S (3 R): joint 2 prismatic
  Pose<Scalar> attach;             // platform frame → the limb's end frame
  Vec3<Scalar> origin;             // A1i: the U centre
  Mat3<Scalar> axes;               // the reference end frame's axes [t, u × t, u]
};

// A UPS limb's U and P as close_ups_on_centre evaluates them, where its S
// joint is a ball (hybrid_ups_ball): the leg's centre is
// C = p1 + R1·Rz(x1)·(b + x2·d) (close_ups_on_centre).
template <class S> struct HybridUpsCentreChain {
  Pose<S> first;   // base·link[0]: joint 0's frame
  Vec3<S> b, d;    // link[2].p + link[2].R·link[3].p, link[2].R·z
  Vec3<S> centre;  // the ball's centre in the platform frame
};

// The five chains of the hybrid (identify's HybridErrorModel chains 0–4),
// held for the host (identify, `kincal compensate` through the
// compensator's stored form); a controller builds each chain when it needs
// it instead (hybrid_exact_ik from the table's numbers: 3.5 KiB of chains
// do not fit its static RAM).
template <class Scalar> struct HybridChains {
  HybridUpsLimb<Scalar> ups[3];
  // Where UPS limb i's S joint is a ball (hybrid_ups_ball), its U and P
  // and the ball's centre on the platform, for the IK's closure on the
  // centre alone (close_ups_on_centre).
  bool ups_ball[3] = {false, false, false};
  HybridUpsCentreChain<Scalar> ups_centre[3];
  HybridSerialLinks<Scalar> up;     // U (2 R), P: from {R0} to the platform frame (at A64)
  HybridSerialLinks<Scalar> wrist;  // 3 R from the platform frame to the tool frame at P
  Vec6<Scalar> joint_offset = Vec6<Scalar>::Zero();  // physical − commanded (nominal + Δξ)
  Scalar up_split = Scalar(345);    // e = |A44 A64| (seed 000 Table 1)
};

namespace hybrid_exact_detail {

template <class S> Pose<S> make_pose(const NonDeducedT<Mat3<S>>& R, const NonDeducedT<Vec3<S>>& p) {
  Pose<S> out;
  out.R = R;
  out.p = p;
  return out;
}

template <class S> Mat3<S> columns(const Vec3<S>& x, const Vec3<S>& y, const Vec3<S>& z) {
  Mat3<S> m;
  m.col(0) = x;
  m.col(1) = y;
  m.col(2) = z;
  return m;
}

template <class S> Mat3<S> rotation_about(int axis, S angle) {
  S s, c;
  sin_cos(angle, s, c);  // a finite error angle (checked before it gets here)
  Mat3<S> R = Mat3<S>::Identity();
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  R(i, i) = c;
  R(j, j) = c;
  R(i, j) = -s;
  R(j, i) = s;
  return R;
}

template <class S> Pose<S> joint_motion(bool prismatic, S x) {
  if (prismatic) return make_pose<S>(Mat3<S>::Identity(), Vec3<S>(S(0), S(0), x));
  return make_pose<S>(rotation_about(2, x), Vec3<S>::Zero());
}

// E = Trans(Δx, Δy, Δz)·Rx(Δα)·Ry(Δβ)·Rz(Δγ) (Appendix A; d = (Δx … Δγ)),
// the product written out (no 3×3 products), and no sin / cos of an angle
// that is exactly zero (every joint frame has one: Δγ of a revolute).
template <class S> Pose<S> error_transform(const S* d) {
  S sa(0), ca(1), sb(0), cb(1), sg(0), cg(1);
  if (d[3] != S(0)) sin_cos(d[3], sa, ca);
  if (d[4] != S(0)) sin_cos(d[4], sb, cb);
  if (d[5] != S(0)) sin_cos(d[5], sg, cg);
  Mat3<S> R;
  R << cb * cg, -cb * sg, sb,                           //
      ca * sg + sa * sb * cg, ca * cg - sa * sb * sg, -sa * cb,  //
      sa * sg - ca * sb * cg, sa * cg + ca * sb * sg, ca * cb;
  return make_pose<S>(R, Vec3<S>(d[0], d[1], d[2]));
}

// A joint frame's five kept errors as six (Δz omitted for a prismatic, Δγ for
// a revolute joint: Appendix A's k = 1, k = 0).
template <class S> void expand_joint_error(const S* e, bool prismatic, S* d) {
  if (prismatic) {
    d[0] = e[0], d[1] = e[1], d[2] = S(0), d[3] = e[2], d[4] = e[3], d[5] = e[4];
  } else {
    d[0] = e[0], d[1] = e[1], d[2] = e[2], d[3] = e[3], d[4] = e[4], d[5] = S(0);
  }
}

// The links of a chain from the world poses of its joint frames at a
// reference configuration x_ref (frame_at(j), made one at a time so the
// controller's stack never holds them all) and of its end frame there.
template <class S, int N, class FrameAt>
void set_links(HybridChainLinks<S, N>& c, const bool* prismatic, const Pose<S>& parent_ref, const FrameAt& frame_at,
               const S* x_ref, const Pose<S>& end_ref) {
  Pose<S> prev = parent_ref * c.base;
  for (int j = 0; j < N; ++j) {
    const Pose<S> frame = frame_at(j);
    c.link[j] = prev.inverse() * frame;
    prev = frame * joint_motion(prismatic[j], x_ref[j]);
  }
  c.end = prev.inverse() * end_ref;
}

// Folds a chain's Δη (frame 0's six if `base_error`, then five per joint)
// into its base and links.
// `centre_on_end`: the last joint's Δx, Δy act after its motion, on the end
// frame (a UPS limb's S centre displaced on the platform, perpendicular to
// the last S axis; its displacement along that axis is Δz either way) —
// before it, they would offset the S joint's axes from one another, which a
// ball joint cannot do (docs/hybrid-error-model.md §3).
template <class S, int N>
void fold_errors(HybridChainLinks<S, N>& c, const bool* prismatic, bool base_error, const S* eta,
                 bool centre_on_end = false) {
  int k = 0;
  if (base_error) {
    c.base = c.base * error_transform(eta);
    k = 6;
  }
  for (int j = 0; j < N; ++j, k += 5) {
    S d[6];
    expand_joint_error(eta + k, prismatic[j], d);
    if (centre_on_end && j == N - 1) {
      c.end = make_pose<S>(Mat3<S>::Identity(), Vec3<S>(d[0], d[1], S(0))) * c.end;
      d[0] = d[1] = S(0);
    }
    c.link[j] = c.link[j] * error_transform(d);
  }
}

inline constexpr bool kUpsPrismatic[6] = {false, false, true, false, false, false};
inline constexpr bool kUpPrismatic[3] = {false, false, true};
inline constexpr bool kWristPrismatic[3] = {false, false, false};

// T ← T·M(x) in place: a revolute joint turns two columns of R (T·Rz(x)), a
// prismatic one moves the origin along the third (T·Tz(x)) — a quarter of a
// full pose product, and the chains are mostly these.
// R ← R·Rz(x) from sin x and cos x.
template <class S> void turn_about_z(Mat3<S>& R, S s, S c) {
  for (int k = 0; k < 3; ++k) {  // row by row: no column temporary on the controller's deepest path
    const S rx = R(k, 0), ry = R(k, 1);
    R(k, 0) = c * rx + s * ry;
    R(k, 1) = c * ry - s * rx;
  }
}

template <class S> void move_along_joint(Pose<S>& T, bool prismatic, S x) {
  if (prismatic) {
    T.p += x * T.R.col(2);
    return;
  }
  S s(0), c(1);
  if (!sin_cos(x, s, c)) {  // a diverged iterate: poison the pose, the caller's finiteness test stops
    T.p.setConstant(x - x + S(NAN));
    return;
  }
  turn_about_z(T.R, s, c);
}

// sin and cos of atan2(y, x), without libm: (y, x) over its norm, which it
// returns; (0, 1) where both vanish, as atan2(0, 0) = 0.
template <class S> S direction(S y, S x, S& sine, S& cosine) {
  const S h = std::sqrt(x * x + y * y);
  if (!(h > S(0))) {
    sine = S(0), cosine = S(1);
    return h;
  }
  const S inv = S(1) / h;
  sine = y * inv, cosine = x * inv;
  return h;
}

// A chain's end pose at joint values x; `visit(j, direction, point)` is told
// each joint's axis in the world on the way (the Newton writes its Jacobian
// from them, straight into the LU's storage).
template <class S, int N, class Visit>
Pose<S> chain_end_visiting(const HybridChainLinks<S, N>& c, const bool* prismatic, const Pose<S>& parent, const S* x,
                           Visit&& visit) {
  Pose<S> T = parent * c.base;
  for (int j = 0; j < N; ++j) {
    T = T * c.link[j];
    visit(j, T.R.col(2), T.p);
    move_along_joint(T, prismatic[j], x[j]);
  }
  return T * c.end;
}

// The same for the Newton of close_serial, which carries each revolute
// joint's sine and cosine (`sine[j]`, `cosine[j]`; x[j] only for a prismatic
// joint) instead of the angle: no sin / cos per evaluation (five of them were
// ~0.5k of the ~1.7k instructions of a UPS limb's evaluation, callgrind).
// `parent` null: the chain starts at the world frame ({R0}), whose product
// would multiply by the identity (the UPS limbs and the UP limb);
// `kEndTranslation`: the end link has no rotation (a UPS limb's, from
// build_ups_limb: its S centre's Δx, Δy), so T·end is p += R·t.
template <bool kEndTranslation, class S, int N, class Visit>
Pose<S> chain_end_turned(const HybridChainLinks<S, N>& c, const bool* prismatic, const Pose<S>* parent, const S* x,
                         const S* sine, const S* cosine, Visit&& visit) {
  Pose<S> T = parent != nullptr ? *parent * c.base : c.base;
  for (int j = 0; j < N; ++j) {
    T = T * c.link[j];
    visit(j, T.R.col(2), T.p);
    if (prismatic[j])
      T.p += x[j] * T.R.col(2);
    else
      turn_about_z(T.R, sine[j], cosine[j]);
  }
  if constexpr (kEndTranslation) {
    T.p.noalias() += T.R * c.end.p;
    return T;
  } else {
    return T * c.end;
  }
}

// The same, with the axes in `axes` if given.
template <class S, int N>
Pose<S> chain_end(const HybridChainLinks<S, N>& c, const bool* prismatic, const Pose<S>& parent, const S* x,
                  HybridJointAxes<S, N>* axes) {
  return chain_end_visiting(c, prismatic, parent, x, [axes](int j, const auto& direction, const auto& point) {
    if (axes == nullptr) return;
    axes->direction[j] = direction;
    axes->point[j] = point;
  });
}

// The residual that moves a chain's end onto `target`: (Δp, ω) in world axes,
// ω = vee(skew part of R_target·R_endᵀ) — sin θ·axis, which vanishes exactly
// where the rotations agree (|θ| < π/2) and is what Newton needs; no libm.
// Only D's six off-diagonal entries, D_ij = row i of R_target · row j of
// R_end: no 3×3 product (a third of its multiplications, and no D on the
// stack of the controller's deepest path, close_serial's).
template <class S> Vec6<S> closure_residual(const Pose<S>& target, const Pose<S>& end) {
  const auto D = [&](int i, int j) { return target.R.row(i).dot(end.R.row(j)); };
  Vec6<S> e;
  e.template head<3>() = target.p - end.p;
  e(3) = S(0.5) * (D(2, 1) - D(1, 2));
  e(4) = S(0.5) * (D(0, 2) - D(2, 0));
  e(5) = S(0.5) * (D(1, 0) - D(0, 1));
  return e;
}

}  // namespace hybrid_exact_detail

// The reference frames {R_1,i} … {R_6,i} of a U-P-S limb (every angle zero,
// the leg straight from the U centre A1 to the S centre A6;
// docs/hybrid-error-model.md): U axes t and u × t at A1, P along u, S axes t,
// u × t, u at A6, t = u × z0 horizontal (x0 for a vertical leg). One frame
// (j = 0 … 5) at a time, so a controller building a limb holds one, not six.
template <class S> Pose<S> ups_reference_frame(const Vec3<S>& A1, const Vec3<S>& A6, int j) {
  using hybrid_exact_detail::columns;
  using hybrid_exact_detail::make_pose;
  const Vec3<S> u = (A6 - A1).normalized();
  Vec3<S> t = u.cross(Vec3<S>::UnitZ());
  if (t.norm() < S(1e-6)) t = Vec3<S>::UnitX();
  t.normalize();
  const Vec3<S> n = u.cross(t);
  switch (j) {
    case 0: return make_pose<S>(columns<S>(u, t.cross(u), t), A1);  // z = t, x = u
    case 1: return make_pose<S>(columns<S>(t, -u, n), A1);          // z = u × t, x = t
    case 2: return make_pose<S>(columns<S>(n, -t, u), A1);          // z = u (P), x = u × t
    case 3: return make_pose<S>(columns<S>(u, t.cross(u), t), A6);  // z = t, x = u
    case 4: return make_pose<S>(columns<S>(t, -u, n), A6);          // z = u × t, x = t
    default: return make_pose<S>(columns<S>(t, n, u), A6);          // z = u, x = t
  }
}
template <class S> void ups_reference_frames(const Vec3<S>& A1, const Vec3<S>& A6, Pose<S>* frames) {
  for (int j = 0; j < 6; ++j) frames[j] = ups_reference_frame(A1, A6, j);
}

// The nominal U-P-S limb of ups_reference_frames closed on `target` in
// closed form: about the reference axes E = [t, u × t, u] the end frame is
// E·Rx(x0)·Ry(x1)·Rx(x3)·Ry(x4)·Rz(x5) and the S centre A1 + x2·E·Rx(x0)·
// Ry(x1)·e_z, so the leg's direction gives the U angles and its length, the
// rest of the rotation the S angles, each on the branch through the
// reference. False for a target on the U centre.
template <class S> bool nominal_ups_joints(const Vec3<S>& A1, const Mat3<S>& E, const Pose<S>& target, S* x) {
  Vec3<S> v = E.transpose() * (target.p - A1);
  const S length = v.norm();
  if (!(length > S(0))) return false;
  v /= length;
  const S one(1);
  x[0] = std::atan2(-v(1), v(2));
  x[1] = std::asin(v(0) < -one ? -one : v(0) > one ? one : v(0));
  x[2] = length;
  const Mat3<S> R = rot_y(-x[1]) * rot_x(-x[0]) * E.transpose() * target.R;  // Rx(x3)·Ry(x4)·Rz(x5)
  x[3] = std::atan2(-R(1, 2), R(2, 2));
  x[4] = std::asin(R(0, 2) < -one ? -one : R(0, 2) > one ? one : R(0, 2));
  x[5] = std::atan2(-R(0, 1), R(0, 0));
  return true;
}

// The same start for close_ups, which needs only the leg's length: the
// joints' sines and cosines straight from the leg's direction and the
// rotation's entries (the atan2 / asin arguments over their norms), not the
// angles — the three atan2, two asin and then five sin / cos of an angle
// were ~1.4k of a limb's ~5k instructions (callgrind). The same branch as
// nominal_ups_joints (cos x1, cos x4 ≥ 0); `sine[2]`, `cosine[2]` (the P
// joint) are set to 0, 1.
// Its U-P part: the leg from A1 to `point` about the reference axes E — its
// length, and the U joints' sines and cosines (close_ups_on_centre's start
// on a ball's centre too). False for a point on the U centre.
template <class S>
bool nominal_leg_start(const Vec3<S>& A1, const Mat3<S>& E, const Vec3<S>& point, S& length, S* sine, S* cosine) {
  Vec3<S> v = E.transpose() * (point - A1);
  length = v.norm();
  if (!(length > S(0))) return false;
  v /= length;
  const S one(1);
  cosine[1] = hybrid_exact_detail::direction(-v(1), v(2), sine[0], cosine[0]);  // x1 = asin v0: cos x1 = √(v1² + v2²)
  sine[1] = v(0) < -one ? -one : v(0) > one ? one : v(0);
  return true;
}

template <class S>
bool nominal_ups_start(const Vec3<S>& A1, const Mat3<S>& E, const Pose<S>& target, S& length, S* sine, S* cosine) {
  if (!nominal_leg_start(A1, E, target.p, length, sine, cosine)) return false;
  using hybrid_exact_detail::direction;
  const S one(1), zero(0);
  sine[2] = zero, cosine[2] = one;
  // R = Ry(−x1)·Rx(−x0)·Eᵀ·R_target = Rx(x3)·Ry(x4)·Rz(x5).
  Mat3<S> Rx, Ry;
  Rx << one, zero, zero, zero, cosine[0], sine[0], zero, -sine[0], cosine[0];
  Ry << cosine[1], zero, -sine[1], zero, one, zero, sine[1], zero, cosine[1];
  const Mat3<S> R = Ry * Rx * (E.transpose() * target.R);
  const S h3 = direction(-R(1, 2), R(2, 2), sine[3], cosine[3]);
  sine[4] = R(0, 2) < -one ? -one : R(0, 2) > one ? one : R(0, 2);  // cos x4 = √(R12² + R22²)
  cosine[4] = h3;
  direction(-R(0, 1), R(0, 0), sine[5], cosine[5]);
  return true;
}

// The chains are built as identify's HybridErrorModel places its frames:
// fixed at the reference configuration (every joint angle zero, c = home
// extension, the platform frame at A64), then the errors folded in.

// UPS limb i, with its Δη block `eta` (36: frame 0's six, then five per
// joint) folded in unless null.
template <class S> void build_ups_limb(const HybridGeometry<S>& g, int i, const S* eta, HybridUpsLimb<S>& limb) {
  using namespace hybrid_exact_detail;
  const Vec3<S> platform_ref(S(0), S(0), g.home.extension);
  const Vec3<S> A1 = g.base_joints.col(i);
  const Vec3<S> A6 = platform_ref + g.platform_joints.col(i);
  limb.links.base = make_pose<S>(Mat3<S>::Identity(), A1);  // {R_0,i}: at A1i, axes of {R0}
  // set_links over the reference frames, one frame at a time (x_ref: every
  // angle zero, the P joint at the leg's length), written out: set_links
  // itself moves along every joint at x_ref through joint_motion, a sin / cos
  // of zero per revolute, which took the controller from 283 k to 300 k
  // instructions per point (examples/firmware/footprint.sh, 2026-11-27).
  Pose<S> previous = limb.links.base;  // the last joint frame after its motion at x_ref
  for (int j = 0; j < 6; ++j) {
    const Pose<S> frame = ups_reference_frame(A1, A6, j);
    limb.links.link[j] = previous.inverse() * frame;
    previous = frame;
    if (kUpsPrismatic[j]) previous.p += (A6 - A1).norm() * frame.R.col(2);
  }
  limb.links.end = Pose<S>();  // the last S frame is the end frame
  limb.attach = make_pose<S>(previous.R, Vec3<S>(A6 - platform_ref));
  limb.origin = A1;
  limb.axes = previous.R;
  if (eta != nullptr) fold_errors(limb.links, kUpsPrismatic, true, eta, /*centre_on_end=*/true);
}

// The UP limb (U at A0 = Rx(θ1)·Ry(θ2), P along w with variable c − e) and
// the wrist (joints 4–6 of limb 4, from the platform frame), with their Δη
// blocks (21, 15) and the tool frame's six errors folded in unless null.
template <class S>
void build_serial_chains(const HybridGeometry<S>& g, S up_split, const S* up_eta, const S* wrist_eta,
                         const S* tool_eta, HybridSerialLinks<S>& up, HybridSerialLinks<S>& wrist) {
  using namespace hybrid_exact_detail;
  const Vec3<S> ex = Vec3<S>::UnitX(), ey = Vec3<S>::UnitY(), ez = Vec3<S>::UnitZ();
  const S c_ref = g.home.extension, e = up_split;
  const Pose<S> world;
  const Pose<S> platform_ref = make_pose<S>(Mat3<S>::Identity(), Vec3<S>(c_ref * ez));
  {
    const auto frame_at = [&](int j) {
      if (j == 0) return make_pose<S>(columns<S>(ez, -ey, ex), Vec3<S>::Zero());  // z = x0
      if (j == 1) return make_pose<S>(columns<S>(ex, -ez, ey), Vec3<S>::Zero());  // z = y0
      return make_pose<S>(Mat3<S>::Identity(), Vec3<S>::Zero());                  // z = z0 (= w), at A0
    };
    const S x_ref[3] = {S(0), S(0), c_ref - e};
    up.base = Pose<S>();
    set_links(up, kUpPrismatic, world, frame_at, x_ref, platform_ref);
    if (up_eta != nullptr) fold_errors(up, kUpPrismatic, true, up_eta);
  }
  {
    const S zq = c_ref + g.platform_to_wrist, zp0 = zq + g.wrist_link;
    const auto frame_at = [&](int j) {
      if (j == 0) return make_pose<S>(columns<S>(ey, -ex, ez), Vec3<S>((c_ref - e) * ez));  // z = w, at A44
      if (j == 1) return make_pose<S>(columns<S>(ez, -ey, ex), Vec3<S>(zq * ez));           // z = F4·x through Q
      return make_pose<S>(columns<S>(ex, -ez, ey), Vec3<S>(zp0 * ez));                      // z = F5·y through P0
    };
    const S x_ref[3] = {S(0), S(0), S(0)};
    wrist.base = Pose<S>();
    set_links(wrist, kWristPrismatic, platform_ref, frame_at, x_ref,
              make_pose<S>(g.tool_offset, Vec3<S>((zp0 + g.tool_length) * ez)));
    if (wrist_eta != nullptr) fold_errors(wrist, kWristPrismatic, false, wrist_eta);
    if (tool_eta != nullptr) wrist.end = wrist.end * error_transform(tool_eta);
  }
}

// Whether UPS limb i's S joint is a ball — its three axes through one
// point, the centre — in the chains built from its Δη block `eta` (null:
// nominal), and if so that centre in the limb's end frame (`centre_in_end`).
// The S axes are joints 3, 4, 5. Joint 4's translations (dx_5_i, dy_5_i,
// dz_5_i) would move its axis off joint 3's; joint 5's Δz (dz_6_i) lies
// along its own axis unless Δα, Δβ tilt that axis (dalpha_6_i, dbeta_6_i).
// Its Δx, Δy act after its motion (fold_errors' `centre_on_end`), on the
// end frame. So with joint 4's translations zero and joint 5 not both moved
// along and tilted, the centre sits at (Δx, Δy, Δz) of joint 5 in the end
// frame: T_end = F·link5·Rz(x5)·Trans(Δx, Δy, 0), F's origin the centre and
// F·link5's offset (0, 0, Δz) along T_end's own z (link5's rotation is the
// nominal one). Identification holds exactly these (docs/
// hybrid-error-model.md §3: they are not identifiable, or tried last and held),
// so every model identify writes on the documented designs has balls.
template <class S> bool hybrid_ups_ball(const S* eta, Vec3<S>& centre_in_end) {
  centre_in_end.setZero();
  if (eta == nullptr) return true;
  const S* joint4 = eta + 6 + 5 * 4;  // (Δx, Δy, Δz, Δα, Δβ)
  const S* joint5 = eta + 6 + 5 * 5;
  if (joint4[0] != S(0) || joint4[1] != S(0) || joint4[2] != S(0)) return false;
  if (joint5[2] != S(0) && (joint5[3] != S(0) || joint5[4] != S(0))) return false;
  centre_in_end = Vec3<S>(joint5[0], joint5[1], joint5[2]);
  return true;
}

// Whether Δχ (and the extra encoder offsets, if given) are all finite.
template <class S> bool finite_source_errors(const S* source_errors, const S* encoder_offsets) {
  for (int k = 0; k < HybridErrorLayout::size(); ++k)
    if (!is_finite(source_errors[k])) return false;
  if (encoder_offsets != nullptr)
    for (int k = 0; k < HybridErrorLayout::kEncoders; ++k)
      if (!is_finite(encoder_offsets[k])) return false;
  return true;
}

// physical − commanded: the nominal offsets, Δξ and the extra encoder offsets.
template <class S> Vec6<S> exact_joint_offset(const HybridGeometry<S>& g, const S* source_errors, const S* encoder_offsets) {
  Vec6<S> o = g.joint_offset;
  for (int k = 0; k < HybridErrorLayout::kEncoders; ++k)
    o(k) += (source_errors != nullptr ? source_errors[k] : S(0)) + (encoder_offsets != nullptr ? encoder_offsets[k] : S(0));
  return o;
}

// The chains of the erroneous machine, built in place in `out` (all of them:
// the host's stored form). `source_errors` is Δχ in HybridErrorLayout (null:
// the nominal machine); `encoder_offsets`, if given, six more (a table's ξ̂,
// kept apart from its Δχ̂). InvalidInput if a value is not finite; `out` is
// written only on Ok.
template <class S>
Status hybrid_exact_chains(const HybridGeometry<S>& g, S up_split, const S* source_errors, HybridChains<S>& out,
                           const S* encoder_offsets = nullptr) {
  if (source_errors != nullptr && !finite_source_errors(source_errors, encoder_offsets)) return Status::InvalidInput;
  const S* chi = source_errors;
  for (int i = 0; i < 3; ++i) {
    const S* eta = chi != nullptr ? chi + HybridErrorLayout::ups(i) : nullptr;
    HybridUpsLimb<S>& limb = out.ups[i];
    build_ups_limb(g, i, eta, limb);
    Vec3<S> centre_in_end;
    out.ups_ball[i] = hybrid_ups_ball(eta, centre_in_end);
    HybridUpsCentreChain<S>& leg = out.ups_centre[i];
    leg.centre = limb.attach.p - limb.attach.R * centre_in_end;  // the end frame's R is the attachment's
    leg.first = limb.links.base * limb.links.link[0];
    leg.b = limb.links.link[2].p + limb.links.link[2].R * limb.links.link[3].p;
    leg.d = limb.links.link[2].R.col(2);
  }
  build_serial_chains(g, up_split, chi != nullptr ? chi + HybridErrorLayout::up() : nullptr,
                      chi != nullptr ? chi + HybridErrorLayout::wrist() : nullptr,
                      chi != nullptr ? chi + HybridErrorLayout::tool() : nullptr, out.up, out.wrist);
  out.joint_offset = exact_joint_offset(g, chi, encoder_offsets);
  out.up_split = up_split;
  return Status::Ok;
}

// Stopping rules of the exact solvers: a chain is closed when its end is
// within `closure` of the target (mm; rotations × characteristic length), or
// when Newton has reached rounding (no longer halving below `floor`).
template <class Scalar> struct HybridExactTolerance;
template <> struct HybridExactTolerance<double> {
  static constexpr double closure = 1e-10;  // mm
  static constexpr double floor = 1e-8;
  static constexpr int max_iterations = 12;
};
template <> struct HybridExactTolerance<float> {
  static constexpr float closure = 1e-4f;  // float rounding of a 1 m chain is ~6e-5 mm
  static constexpr float floor = 2e-3f;
  static constexpr int max_iterations = 12;
};

// A stream's previous solution as the start of the next point's Newton
// (host: hybrid_exact_ik's stored-chains form, through CompensatorState).
// An NC stream moves its tool by well under a millimetre between points;
// from the previous point's joints, whose chain end is the previous target
// (closed to HybridExactTolerance::closure), the residual is known without
// evaluating the chain — target ⊖ previous target — and the LU kept from
// that Newton is the Jacobian there. One step from it lands where a cold
// start lands after two: each closure costs one chain evaluation and one
// LU instead of two of each, and no closed-form start (callgrind, docs/
// benchmarks.md). Results agree with the cold start's to the closure
// tolerance; anything the warm Newton cannot close goes the cold way.
template <class S> struct HybridExactClosureStart {
  bool valid = false;
  S x[6] = {}, sine[6] = {}, cosine[6] = {};  // the solution (revolute joints also as sine and cosine)
  SmallLu<S, 6> lu;     // the Jacobian there (or one step before)
  SmallLu<S, 3> lu3;    // the same for a ball's limb, closed on its centre (close_ups_on_centre)
  bool factorised = false;  // whether `lu` is factorised yet (close_serial's `factorised`)
  Pose<S> target;                             // what the chain was closed on, in {R0}
  std::uint32_t reused = 0;                   // closures started here (a diagnostic, and the tests')
};
template <class S> struct HybridExactWarmStart {
  const void* chains = nullptr;  // the HybridChains the starts belong to (another machine's are not used)
  HybridExactClosureStart<S> serial, ups[3];
  void clear() {
    serial.valid = false;
    for (auto& u : ups) u.valid = false;
  }
};

// How far (the scaled residual: mm, rotations × characteristic length) a
// warm start reaches: a point further from the last one starts cold. 1 mm a
// point is 60 m/min at 1 kHz; the cold start's own residual is ~0.2 mm at
// 0.1 mm / 0.3 mrad errors and ~2 mm at 1 mm / 2 mrad.
template <class S> constexpr S kHybridWarmReach = S(1);

namespace hybrid_exact_detail {

// sin δ and cos δ of a Newton step's angle. A step is mostly below 2⁻¹⁰
// rad (the start is the nominal closed form, the errors small), where the
// series to δ⁵ and δ⁴ is exact in double (the next terms, δ⁷/5040 and
// δ⁶/720, are below 2e-22 of sin δ and of 1): ~28 instructions instead of
// sin_cos's ~70 (its range tests and its series to a¹⁰), ~40 steps a point
// (callgrind: 28.9k -> 26.7k instructions per compensated point).
template <class S> bool step_sin_cos(S d, S& sine, S& cosine) {
  if (d <= S(0.0009765625) && d >= S(-0.0009765625)) {
    const S t = d * d;
    sine = d * (S(1) - t * S(1.0 / 6) * (S(1) - t * S(1.0 / 20)));
    cosine = S(1) - t * S(0.5) * (S(1) - t * S(1.0 / 12));
    return true;
  }
  return sin_cos(d, sine, cosine);
}

// Newton on the joint variables x of a 6-joint serial chain (`ends(x,
// visit)` returns the end pose and tells `visit(j, direction, point)` each
// joint's axis) until its end coincides with `target`. The Jacobian's
// columns are the joints' twists at the end point; revolute columns and
// rotation rows are scaled by the characteristic length L so the LU's pivot
// ratio judges a dimensionless matrix (the singularity test of core). They
// are written during the chain's evaluation into the LU's own storage, as
// Plücker coordinates (p × a, a), and moved to the end point once it is
// known (a × (P − p) = a × P + p × a): no copy of the axes on the stack.
// On Ok `lu` holds a factorisation at the last iterate or the one before
// (δy = J⁻¹·δ(end), revolute y = L·θ) if `keep_factorisation`, for the FK's
// outer Newton; otherwise the IK's last evaluation is not factorised.
// A revolute joint j is carried as its sine and cosine too (`sine[j]`,
// `cosine[j]`, at x[j] on entry), which `ends(x, sine, cosine, visit)`
// evaluates by (chain_end_turned): each step turns them by the step's
// angle (angle addition), whose sin_cos is cheap near a solution (|δθ| ≤
// 1/8: no halvings), instead of a sin_cos of every angle at every evaluation.
// x += a Newton step (revolute joints scaled by L), a revolute joint's sine
// and cosine turned with it; false for a diverged step.
// The stopping rules of both Newtons (close_serial, close_ups_on_centre):
// closed within HybridExactTolerance::closure, or at rounding (from the
// third iterate, below `floor` and no longer halving) ...
template <class S> bool newton_closed(int it, S err, S previous) {
  return err <= HybridExactTolerance<S>::closure ||
         (it >= 2 && err <= HybridExactTolerance<S>::floor && err > S(0.5) * previous);
}
// ... or, just after a step, closed by prediction: Newton converges
// quadratically here, r_{k+1} ≈ K·r_k² with K ≈ r_k / r_{k−1}² seen on the
// last step; when the residual this step leaves, r_k³ / r_{k−1}², is below
// the tolerance (and the last step did shrink it a hundredfold, so the
// regime is quadratic), the chain is closed without evaluating it again —
// one chain evaluation of three saved per closure. The tests check the
// result against the FK to 1e-9 mm.
template <class S> bool newton_predicts_closed(int it, S err, S previous) {
  return it > 0 && err < S(0.01) * previous &&
         err * (err / previous) * (err / previous) <= HybridExactTolerance<S>::closure;
}

template <class S>
inline bool take_newton_step(const Vec6<S>& step, const bool* prismatic, S L, S* x, S* sine, S* cosine) {
  for (int j = 0; j < 6; ++j) {
    if (prismatic[j]) {
      x[j] += step(j);
      continue;
    }
    const S d = step(j) / L;
    x[j] += d;
    S sd, cd;
    if (!step_sin_cos(d, sd, cd)) return false;
    const S s = sine[j], c = cosine[j];
    sine[j] = s * cd + c * sd;
    cosine[j] = c * cd - s * sd;
  }
  return true;
}

// `warm_error`, if given, is the (scaled) residual at x, where `lu` holds
// the Jacobian factorised (HybridExactWarmStart): the first step is taken
// from them without evaluating the chain. `factorised`, if given, says on
// Ok whether `lu` holds a factorisation (at the last iterate or the one
// before) or the Jacobian at the solution, not factorised (closed at an
// evaluation: the next point's warm start factorises it if it needs it).
// Both only with `kStream` (the host's stream, HybridExactWarmStart): the
// controller's instantiation has no code for them (704 B of flash at -Os,
// over the firmware's bar; examples/firmware/footprint.sh, 2026-11-28).
template <bool kStream = false, class S, class Ends>
Status close_serial(Ends ends, const bool* prismatic, const Pose<S>& target, S L, S* x, S* sine, S* cosine,
                    SmallLu<S, 6>& lu, bool keep_factorisation = false, const Vec6<S>* warm_error = nullptr,
                    bool* factorised = nullptr) {
  S previous = S(0);
  int first = 0;
  if constexpr (kStream) {
    if (warm_error != nullptr) {
      previous = warm_error->cwiseAbs().maxCoeff();
      if (!take_newton_step(lu.solve(*warm_error), prismatic, L, x, sine, cosine)) return Status::NotConverged;
      first = 1;
    }
  }
  for (int it = first;; ++it) {
    if constexpr (kStream)
      if (factorised != nullptr) *factorised = false;
    auto J = lu.storage();
    const Pose<S> end = ends(x, sine, cosine, [&J](int j, const auto& a, const auto& p) {
      J.template block<3, 1>(0, j) = p.cross(a);
      J.template block<3, 1>(3, j) = a;
    });
    Vec6<S> e = closure_residual(target, end);
    e.template tail<3>() *= L;
    const S err = e.cwiseAbs().maxCoeff();
    if (!(err == err)) return Status::NotConverged;
    for (int j = 0; j < 6; ++j) {
      if (prismatic[j]) {
        J.template block<3, 1>(0, j) = J.template block<3, 1>(3, j);
        J.template block<3, 1>(3, j).setZero();
      } else {  // (a × (P − p), a)·dθ, with dθ = dy / L and the rows ω × L
        const Vec3<S> a = J.template block<3, 1>(3, j);
        J.template block<3, 1>(0, j) = (a.cross(end.p) + J.template block<3, 1>(0, j)) / L;
      }
    }
    const bool closed = it > 0 && newton_closed(it, err, previous);
    if (closed && !keep_factorisation) return Status::Ok;
    if (!lu.factor() || !(lu.pivot_ratio() > Tolerance<S>::singular_pivot_ratio)) return Status::Singular;
    if constexpr (kStream)
      if (factorised != nullptr) *factorised = true;
    if (closed || (it == 0 && err <= HybridExactTolerance<S>::closure)) return Status::Ok;  // (or the start was the solution)
    if (it >= HybridExactTolerance<S>::max_iterations) return Status::NotConverged;
    if (!take_newton_step(lu.solve(e), prismatic, L, x, sine, cosine)) return Status::NotConverged;  // diverged
    if (newton_predicts_closed(it, err, previous)) return Status::Ok;
    previous = err;
  }
}

// close_serial in a frame of its own: inlined into a UPS limb's closure,
// GCC -Os put the Newton's locals and the start's (nominal_ups_start) on
// the stack together: 4 120 B, over the controller's bar (4 000 B apart;
// examples/firmware/footprint.sh, 2026-11-28).
template <class S, class Ends>
KINCAL_EXACT_NOINLINE Status close_serial_apart(Ends ends, const bool* prismatic, const Pose<S>& target, S L, S* x,
                                                S* sine, S* cosine, SmallLu<S, 6>& lu, bool keep_factorisation) {
  return close_serial(ends, prismatic, target, L, x, sine, cosine, lu, keep_factorisation);
}

// The closure from the stream's previous solution `w` (HybridExactWarmStart):
// Ok with x, sine, cosine at the solution and `w` moved there; anything else
// (no start, a point beyond kHybridWarmReach, a Newton that fails) leaves `w`
// invalid for the caller's cold start.
template <class S, class Ends>
Status close_from_previous(Ends ends, const bool* prismatic, const Pose<S>& target, S L, HybridExactClosureStart<S>& w,
                           S* x, S* sine, S* cosine) {
  if (!w.valid) return Status::NotConverged;
  w.valid = false;
  Vec6<S> e = closure_residual(target, w.target);
  e.template tail<3>() *= L;
  if (!(e.cwiseAbs().maxCoeff() <= kHybridWarmReach<S>)) return Status::NotConverged;
  if (!w.factorised && (!w.lu.factor() || !(w.lu.pivot_ratio() > Tolerance<S>::singular_pivot_ratio)))
    return Status::Singular;
  for (int j = 0; j < 6; ++j) x[j] = w.x[j], sine[j] = w.sine[j], cosine[j] = w.cosine[j];
  const Status s = close_serial<true>(ends, prismatic, target, L, x, sine, cosine, w.lu, false, &e, &w.factorised);
  if (s != Status::Ok) return s;
  for (int j = 0; j < 6; ++j) w.x[j] = x[j], w.sine[j] = sine[j], w.cosine[j] = cosine[j];
  w.target = target;
  w.valid = true;
  ++w.reused;
  return s;
}

// A cold closure's solution kept as the next point's start (its Newton's
// Jacobian is in w.lu, factorised or not as w.factorised says).
template <class S>
void keep_start(HybridExactClosureStart<S>& w, const Pose<S>& target, const S* x, const S* sine, const S* cosine) {
  for (int j = 0; j < 6; ++j) w.x[j] = x[j], w.sine[j] = sine[j], w.cosine[j] = cosine[j];
  w.target = target;
  w.valid = true;
}

// UPS limb `limb` closed on the platform pose `platform` (in {R0}): its
// prismatic variable, the leg's length (written on Ok), Newton from the
// nominal closed form (its angles are never needed: only their sines and
// cosines, nominal_ups_start), or from the stream's previous solution
// `warm` if given and near (`kStream` only: the host's stream).
template <bool kStream = false, class S>
Status close_ups(const HybridUpsLimb<S>& limb, const Pose<S>& platform, S L, S& length, SmallLu<S, 6>& lu,
                 bool keep_factorisation = false, HybridExactClosureStart<S>* warm = nullptr) {
  const Pose<S> target = platform * limb.attach;
  S x[6] = {}, sine[6], cosine[6];
  auto ends = [&](const S* xs, const S* sn, const S* cs, auto&& visit) {
    return chain_end_turned<true>(limb.links, kUpsPrismatic, static_cast<const Pose<S>*>(nullptr), xs, sn, cs, visit);
  };
  if constexpr (kStream) {
    if (warm != nullptr && close_from_previous(ends, kUpsPrismatic, target, L, *warm, x, sine, cosine) == Status::Ok) {
      length = x[2];
      return Status::Ok;
    }
    x[0] = x[1] = x[3] = x[4] = x[5] = S(0);
  }
  if (!nominal_ups_start(limb.origin, limb.axes, target, x[2], sine, cosine)) return Status::Unreachable;
  Status s;
  if constexpr (kStream)
    s = close_serial<true>(ends, kUpsPrismatic, target, L, x, sine, cosine, warm != nullptr ? warm->lu : lu,
                           keep_factorisation, static_cast<const Vec6<S>*>(nullptr),
                           warm != nullptr ? &warm->factorised : nullptr);
  else
    s = close_serial_apart(ends, kUpsPrismatic, target, L, x, sine, cosine, lu, keep_factorisation);
  if (s == Status::Ok) {
    length = x[2];
    if constexpr (kStream)
      if (warm != nullptr) keep_start(*warm, target, x, sine, cosine);
  }
  return s;
}

// A UPS limb whose S joint is a ball (hybrid_ups_ball) closed on its centre
// (in {R0}) alone. The centre is a point of the platform, and the leg from
// the U to it is the U (two R) and the P: three unknowns, not the six of
// close_ups's end frame, since the S angles never move the centre. It
// solves the same chain, so it is as exact as the six-joint closure (the
// host's stored form only; docs/benchmarks.md).
//   C(x) = p1 + R1·Rz(x1)·(b + x2·d),  R1 = F·Rz(x0)·link[1].R,
//   p1 = F.p + F.R·Rz(x0)·link[1].p,   F = base·link[0] (`first`),
// b = link[2].p + link[2].R·link[3].p and d = link[2].R·z (the P axis in
// joint 1's frame; HybridUpsCentreChain). Newton on (x0, x1, x2), columns
// a_j × (C − p_j) for the R joints (scaled by 1/L as in close_serial) and
// the P axis, with close_serial's stopping rules.

// C at (x2, sines, cosines), and the columns of its Jacobian (unscaled).
template <class S>
Vec3<S> ups_centre_at(const HybridUpsLimb<S>& limb, const HybridUpsCentreChain<S>& chain, S x2, const S* sine,
                      const S* cosine, Mat3<S>& J) {
  Mat3<S> M = chain.first.R;  // F.R·Rz(x0)
  turn_about_z(M, sine[0], cosine[0]);
  const Pose<S>& link1 = limb.links.link[1];
  const Vec3<S> p1 = chain.first.p + M * link1.p;
  const Vec3<S> a1 = M * link1.R.col(2);
  const auto rz1 = [&](const Vec3<S>& v) {
    return Vec3<S>(cosine[1] * v(0) - sine[1] * v(1), sine[1] * v(0) + cosine[1] * v(1), v(2));
  };
  const Vec3<S> a2 = M * (link1.R * rz1(chain.d));
  const Vec3<S> C = p1 + M * (link1.R * rz1(chain.b)) + x2 * a2;
  J.col(0) = chain.first.R.col(2).cross(C - chain.first.p);
  J.col(1) = a1.cross(C - p1);
  J.col(2) = a2;
  return C;
}

// From `warm` if given, valid and within kHybridWarmReach of its last
// centre: its first step from the kept factorisation and the known residual
// (the centre's move), as close_from_previous; otherwise from the nominal
// closed form on the centre (nominal_leg_start). The
// solution and the last factorisation are kept in `warm`.
template <class S>
Status close_ups_on_centre(const HybridUpsLimb<S>& limb, const HybridUpsCentreChain<S>& chain,
                           const Pose<S>& platform, S L, S& length, HybridExactClosureStart<S>* warm) {
  const Vec3<S> centre = platform.p + platform.R * chain.centre;
  S x2, sine[2], cosine[2];
  SmallLu<S, 3> local;
  SmallLu<S, 3>& lu = warm != nullptr ? warm->lu3 : local;
  S previous = S(0);
  const auto step = [&](const Vec3<S>& e) {
    const Vec3<S> dy = lu.solve(e);
    for (int j = 0; j < 2; ++j) {
      S sd, cd;
      if (!step_sin_cos(dy(j) / L, sd, cd)) return false;
      const S s = sine[j], c = cosine[j];
      sine[j] = s * cd + c * sd;
      cosine[j] = c * cd - s * sd;
    }
    x2 += dy(2);
    return true;
  };
  bool warmed = false, factored = false;
  if (warm != nullptr && warm->valid) {
    warm->valid = false;
    const Vec3<S> e = centre - warm->target.p;
    if (e.cwiseAbs().maxCoeff() <= kHybridWarmReach<S>) {
      previous = e.cwiseAbs().maxCoeff();
      x2 = warm->x[2];
      for (int j = 0; j < 2; ++j) sine[j] = warm->sine[j], cosine[j] = warm->cosine[j];
      if (!step(e)) return Status::NotConverged;
      warmed = factored = true;
    }
  }
  if (!warmed && !nominal_leg_start(limb.origin, limb.axes, centre, x2, sine, cosine)) return Status::Unreachable;
  for (int it = warmed ? 1 : 0;; ++it) {
    Mat3<S> J;
    const Vec3<S> e = centre - ups_centre_at(limb, chain, x2, sine, cosine, J);
    const S err = e.cwiseAbs().maxCoeff();
    if (!(err == err)) return Status::NotConverged;
    bool closed = newton_closed(it, err, previous);
    if (!closed) {
      if (it >= HybridExactTolerance<S>::max_iterations) return Status::NotConverged;
      J.col(0) /= L;
      J.col(1) /= L;
      if (!lu.factor(J) || !(lu.pivot_ratio() > Tolerance<S>::singular_pivot_ratio)) return Status::Singular;
      factored = true;
      if (!step(e)) return Status::NotConverged;
      closed = newton_predicts_closed(it, err, previous);
      previous = err;
    }
    if (closed) {
      length = x2;
      if (warm != nullptr && factored) {  // a start needs a factorisation to step from
        warm->x[2] = x2;
        for (int j = 0; j < 2; ++j) warm->sine[j] = sine[j], warm->cosine[j] = cosine[j];
        warm->target.p = centre;
        warm->valid = true;
        if (warmed) ++warm->reused;
      }
      return Status::Ok;
    }
  }
}

// The nominal machine's configuration at a tool pose as the serial chain's
// start (θ1, θ2, c − e, θ4, θ5, θ6), with its revolute joints' sines and
// cosines for close_serial (from the atan2 arguments, not a sin_cos of each
// angle: ~0.3k instructions of the host's point, callgrind); not inlined,
// so its frames are off the stack while the Newton runs.
template <class S>
KINCAL_EXACT_NOINLINE Status serial_start(const HybridGeometry<S>& nominal, S up_split, const Pose<S>& tool, S* x,
                                          S* sine, S* cosine) {
  HybridFrames<S> f;
  Vec3<S> angles;
  const Status s = hybrid_frames_at_pose(nominal, tool, f, angles);
  if (s != Status::Ok) return s;
  x[0] = std::atan2(f.Rp(2, 1), f.Rp(1, 1));
  x[1] = std::atan2(f.Rp(0, 2), f.Rp(0, 0));
  x[2] = f.extension - up_split;
  for (int j = 0; j < 3; ++j) x[3 + j] = angles(j);
  // hybrid_frames_at_pose's atan2 arguments: Rp = Rx(θ1)·Ry(θ2); F4·x = x5
  // = Rp·Rz(θ4)·x, F5·z = u = F4·Rx(θ5)·z, F6 = F5·Ry(θ6).
  const Vec3<S> x5 = f.F4.col(0), u = f.F5.col(2);
  direction(f.Rp(2, 1), f.Rp(1, 1), sine[0], cosine[0]);
  direction(f.Rp(0, 2), f.Rp(0, 0), sine[1], cosine[1]);
  sine[2] = S(0), cosine[2] = S(1);
  direction(x5.dot(f.Rp.col(1)), x5.dot(f.Rp.col(0)), sine[3], cosine[3]);
  direction(-u.dot(f.F4.col(1)), u.dot(f.w), sine[4], cosine[4]);
  direction(x5.dot(f.F6.col(2)), x5.dot(f.F6.col(0)), sine[5], cosine[5]);
  return Status::Ok;
}

// The UP limb and the wrist as one serial chain of six joints (θ1, θ2,
// c − e, θ4, θ5, θ6) closed on the tool pose (in {R}), Newton from x and
// its revolute joints' sines and cosines (the nominal machine's closed-form
// configuration there: serial_start, called first by the caller so that its
// frames and the chains are never on the stack together). Writes x (and
// sine, cosine) and the platform pose at the solution. Not inlined: in the
// controller's stage_up_and_wrist its frame and build_serial_chains's are
// then apart (inlined at -Os, the stage's stack was 4 540 B, over the bar;
// examples/firmware/footprint.sh, 2026-11-28).
// With `warm` (the host's stream): `from_previous` closes from the stream's
// previous solution only (NotConverged if it cannot: the caller then starts
// cold), otherwise a cold closure's solution is kept in `warm`.
template <bool kStream = false, class S>
KINCAL_EXACT_NOINLINE Status close_up_and_wrist(const HybridGeometry<S>& nominal, const HybridSerialLinks<S>& up,
                          const HybridSerialLinks<S>& wrist, const Pose<S>& tool, S* x, S* sine, S* cosine,
                          Pose<S>& platform, HybridExactClosureStart<S>* warm = nullptr,
                          bool from_previous = false) {
  // The target in {R0} (the inverse of Eq. (8)'s map into {R}).
  const Mat3<S> Rt = nominal.workpiece_rotation.transpose();
  Pose<S> target;
  target.R = Rt * tool.R;
  target.p = nominal.workpiece_origin + Rt * tool.p;
  auto serial = [&](const S* xs, const S* sn, const S* cs, auto&& visit) {
    platform = chain_end_turned<false>(up, kUpPrismatic, static_cast<const Pose<S>*>(nullptr), xs, sn, cs, visit);
    return chain_end_turned<false>(wrist, kWristPrismatic, &platform, xs + 3, sn + 3, cs + 3,
                                   [&visit](int j, const auto& a, const auto& p) { visit(3 + j, a, p); });
  };
  constexpr bool kSerialPrismatic[6] = {false, false, true, false, false, false};
  const S L = nominal.characteristic_length;
  Status closed;
  if constexpr (kStream) {
    if (from_previous) {
      closed = close_from_previous(serial, kSerialPrismatic, target, L, *warm, x, sine, cosine);
    } else {
      SmallLu<S, 6> lu;
      closed = close_serial<true>(serial, kSerialPrismatic, target, L, x, sine, cosine, warm != nullptr ? warm->lu : lu,
                                  false, static_cast<const Vec6<S>*>(nullptr),
                                  warm != nullptr ? &warm->factorised : nullptr);
      if (closed == Status::Ok && warm != nullptr) keep_start(*warm, target, x, sine, cosine);
    }
  } else {
    SmallLu<S, 6> lu;
    closed = close_serial(serial, kSerialPrismatic, target, L, x, sine, cosine, lu);
  }
  if (closed == Status::Ok)  // the platform at the solution: the UP limb only (the wrist does not move it)
    platform = chain_end_turned<false>(up, kUpPrismatic, static_cast<const Pose<S>*>(nullptr), x, sine, cosine,
                                       [](int, const auto&, const auto&) {});
  return closed;
}

// The commands from the physical joint values, checked against `nominal`'s
// limits (as hybrid_ik).
template <class S>
Status exact_commands(const HybridGeometry<S>& nominal, const Vec6<S>& physical, const Vec6<S>& joint_offset,
                      S extension, Vec6<S>& q) {
  const Vec6<S> cmd = physical - joint_offset;
  if (!all_finite(cmd)) return Status::InvalidInput;
  if (!hybrid_within_limits(nominal, cmd) || extension < nominal.min_extension || extension > nominal.max_extension)
    return Status::OutOfLimits;
  q = cmd;
  return Status::Ok;
}

}  // namespace hybrid_exact_detail

// The commands that put the erroneous machine's tool on `tool` (in {R}):
// the UP limb and the wrist closed on it, then each UPS limb on the platform
// they place, its prismatic variable the leg's physical length. `nominal`
// gives the Newton start (its closed-form configuration), the workpiece
// frame, the characteristic length and the limits; `c` the erroneous chains
// (hybrid_exact_chains). Writes `q` (commanded = physical − c.joint_offset)
// and `passive` only on Ok. InvalidInput (non-finite), Unreachable /
// Singular (as hybrid_ik, or a chain that loses rank), NotConverged,
// OutOfLimits (a command or the UP extension outside `nominal`'s limits).
// `warm`, if given (a stream's HybridExactWarmStart), starts each closure
// from the stream's previous solution where it is near and keeps this one's
// for the next point.
template <class S>
Status hybrid_exact_ik(const HybridGeometry<S>& nominal, const HybridChains<S>& c, const Pose<S>& tool, Vec6<S>& q,
                       NonDeducedT<HybridPassive<S>>* passive = nullptr,
                       NonDeducedT<HybridExactWarmStart<S>>* warm = nullptr) {
  using namespace hybrid_exact_detail;
  if (!tool.finite()) return Status::InvalidInput;
  if (warm != nullptr && warm->chains != &c) {
    warm->clear();
    warm->chains = &c;
  }
  S x[6];
  S sine[6], cosine[6];
  Pose<S> platform;
  Status s = warm != nullptr ? close_up_and_wrist<true>(nominal, c.up, c.wrist, tool, x, sine, cosine, platform,
                                                  &warm->serial, true)
                             : Status::NotConverged;
  if (s != Status::Ok) {
    s = serial_start(nominal, c.up_split, tool, x, sine, cosine);
    if (s != Status::Ok) return s;
    s = close_up_and_wrist<true>(nominal, c.up, c.wrist, tool, x, sine, cosine, platform,
                                 warm != nullptr ? &warm->serial : nullptr);
    if (s != Status::Ok) return s;
  }
  Vec6<S> physical;
  for (int i = 0; i < 3; ++i) {
    HybridExactClosureStart<S>* w = warm != nullptr ? &warm->ups[i] : nullptr;
    if (c.ups_ball[i]) {
      s = close_ups_on_centre(c.ups[i], c.ups_centre[i], platform, nominal.characteristic_length, physical(i), w);
    } else {
      SmallLu<S, 6> lu;
      s = close_ups<true>(c.ups[i], platform, nominal.characteristic_length, physical(i), lu, false, w);
    }
    if (s != Status::Ok) return s;
  }
  for (int j = 0; j < 3; ++j) physical(3 + j) = x[3 + j];
  s = exact_commands(nominal, physical, c.joint_offset, x[2] + c.up_split, q);
  if (s == Status::Ok && passive != nullptr) {
    passive->theta1 = x[0];
    passive->theta2 = x[1];
    passive->extension = x[2] + c.up_split;
  }
  return s;
}


namespace hybrid_exact_detail {

// The controller's form builds each chain from the table's numbers where it
// is needed, on the stack, one stage at a time (each stage its own frame,
// so the worst-case stack is the deeper stage, not their sum).
template <class S>
KINCAL_EXACT_NOINLINE Status stage_up_and_wrist(const HybridGeometry<S>& nominal, S up_split, const S* chi,
                                                const Pose<S>& tool, S* x, S* sine, S* cosine, Pose<S>& platform) {
  HybridSerialLinks<S> up, wrist;
  build_serial_chains(nominal, up_split, chi + HybridErrorLayout::up(), chi + HybridErrorLayout::wrist(),
                      chi + HybridErrorLayout::tool(), up, wrist);
  return close_up_and_wrist(nominal, up, wrist, tool, x, sine, cosine, platform);
}

// A limb's leg length at a platform pose: the closure in its own frame, so
// the limb's construction and its Newton are not on the stack together.
template <class S>
KINCAL_EXACT_NOINLINE Status ups_leg_length(const HybridUpsLimb<S>& limb, const Pose<S>& platform, S L, S& length) {
  SmallLu<S, 6> lu;
  return close_ups(limb, platform, L, length, lu);
}

template <class S>
KINCAL_EXACT_NOINLINE Status stage_ups(const HybridGeometry<S>& nominal, const S* chi, int i, const Pose<S>& platform,
                                       S& length) {
  HybridUpsLimb<S> limb;
  build_ups_limb(nominal, i, chi + HybridErrorLayout::ups(i), limb);
  return ups_leg_length(limb, platform, nominal.characteristic_length, length);
}

}  // namespace hybrid_exact_detail

// The same IK from the numbers themselves (a table's Δχ̂, in place, and its
// ξ̂): no stored chains. Same statuses; `source_errors` must be finite (a
// table's values are checked when it is loaded).
// Not inlined (not even into the compensator's flattened solve()): one
// copy of the Newton code, and its stages' frames apart.
template <class S>
KINCAL_EXACT_NOINLINE Status hybrid_exact_ik(const HybridGeometry<S>& nominal, S up_split, const S* source_errors,
                                             const S* encoder_offsets,
                       const Pose<S>& tool, Vec6<S>& q, NonDeducedT<HybridPassive<S>>* passive = nullptr) {
  using namespace hybrid_exact_detail;
  if (!tool.finite()) return Status::InvalidInput;
  S x[6];
  S sine[6], cosine[6];
  Status s = serial_start(nominal, up_split, tool, x, sine, cosine);
  if (s != Status::Ok) return s;
  Pose<S> platform;
  s = stage_up_and_wrist(nominal, up_split, source_errors, tool, x, sine, cosine, platform);
  if (s != Status::Ok) return s;
  Vec6<S> physical;
  for (int i = 0; i < 3; ++i) {
    s = stage_ups(nominal, source_errors, i, platform, physical(i));
    if (s != Status::Ok) return s;
  }
  for (int j = 0; j < 3; ++j) physical(3 + j) = x[3 + j];
  s = exact_commands(nominal, physical, exact_joint_offset(nominal, source_errors, encoder_offsets), x[2] + up_split, q);
  if (s == Status::Ok && passive != nullptr) {
    passive->theta1 = x[0];
    passive->theta2 = x[1];
    passive->extension = x[2] + up_split;
  }
  return s;
}

// The erroneous machine's tool pose in {R} for commands q, from the UP
// passive `guess`: Newton on s = (θ1, θ2, c) so that each UPS limb, closed on
// the platform the UP limb puts there, has the commanded physical length;
// ∂x_2,i/∂s_k = (J_i⁻¹·twist_k)_2, twist_k the UP joint k's twist at the
// attachment. Writes `tool` (and `passive`) only on Ok.
template <class S>
FkReport<S> hybrid_exact_fk(const HybridGeometry<S>& nominal, const HybridChains<S>& c, const Vec6<S>& q,
                            const HybridPassive<S>& guess, Pose<S>& tool,
                            NonDeducedT<HybridPassive<S>>* passive = nullptr) {
  using namespace hybrid_exact_detail;
  FkReport<S> report;
  if (!all_finite(q) || !is_finite(guess.theta1) || !is_finite(guess.theta2) || !is_finite(guess.extension)) {
    report.status = Status::InvalidInput;
    return report;
  }
  const Vec6<S> physical = q + c.joint_offset;
  const S L = nominal.characteristic_length;
  const S tolerance = Tolerance<S>::fk_residual * physical.template head<3>().cwiseAbs().maxCoeff() +
                      HybridExactTolerance<S>::closure;
  S xs[3] = {guess.theta1, guess.theta2, guess.extension - c.up_split};
  const Pose<S> world;
  for (int it = 0;; ++it) {
    HybridJointAxes<S, 3> axis;
    const Pose<S> platform = chain_end(c.up, kUpPrismatic, world, xs, &axis);
    Vec3<S> r;
    Mat3<S> M;
    for (int i = 0; i < 3; ++i) {
      S length = S(0);
      SmallLu<S, 6> lu;
      const Status s = close_ups(c.ups[i], platform, L, length, lu, true);
      if (s != Status::Ok) {
        report.status = s;
        return report;
      }
      const Vec3<S> P = (platform * c.ups[i].attach).p;
      r(i) = length - physical(i);
      for (int k = 0; k < 3; ++k) {  // the UP joint k's twist at the attachment, in close_serial's scaling
        const Vec3<S>& a = axis.direction[k];
        Vec6<S> t = Vec6<S>::Zero();
        if (kUpPrismatic[k]) {
          t.template head<3>() = a;
        } else {
          const Vec3<S> arm = P - axis.point[k];
          t.template head<3>() = a.cross(arm);
          t.template tail<3>() = L * a;
        }
        M(i, k) = lu.solve(t)(2);  // joint 2 (P) of the limb: unscaled
      }
    }
    report.iterations = it;
    report.residual = r.cwiseAbs().maxCoeff();
    if (report.residual <= tolerance) {
      const Pose<S> T = chain_end(c.wrist, kWristPrismatic, platform, physical.data() + 3,
                                      static_cast<HybridJointAxes<S, 3>*>(nullptr));
      Pose<S> out;
      out.R = nominal.workpiece_rotation * T.R;
      out.p = nominal.workpiece_rotation * (T.p - nominal.workpiece_origin);
      if (!out.finite()) break;
      tool = out;
      if (passive != nullptr) {
        passive->theta1 = xs[0];
        passive->theta2 = xs[1];
        passive->extension = xs[2] + c.up_split;
      }
      report.status = Status::Ok;
      return report;
    }
    if (it == Tolerance<S>::fk_max_iterations || !(report.residual == report.residual)) break;
    SmallLu<S, 3> lu3;
    if (!lu3.factor(M)) {
      report.status = Status::Singular;
      return report;
    }
    const Vec3<S> step = lu3.solve(-r);
    for (int k = 0; k < 3; ++k) xs[k] += step(k);
  }
  report.status = Status::NotConverged;
  return report;
}

}  // namespace kincal
