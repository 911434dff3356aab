// 6-RUS hexapod (GUIDE "A third family"): six rotary motors on the base each
// turn a crank; a rod with a sphere at each end joins the crank tip to the
// platform. Inverse kinematics in closed form, its Jacobian, the forward
// Jacobian, and forward kinematics by Newton's method.
//
// Model. Motor i: a point s_i on its shaft line, the unit shaft axis a_i, the
// unit crank direction at θ = 0, z_i ⟂ a_i, and y_i = a_i × z_i (so z_i, y_i,
// a_i is right-handed and θ turns right-handed about a_i). Crank tip
//   C_i(θ) = s_i + c_i (cos θ · z_i + sin θ · y_i),          c_i crank length
// and the rod closes the loop:
//   |R·p_i + t − C_i(θ_i)| = ℓ_i,                              ℓ_i rod length
// with p_i the rod's platform sphere in the platform frame and (R, t) the
// platform pose, R = Rz·Ry·Rx (pose.hpp). The commanded joint is q_i; the
// physical angle is θ_i = q_i + joint_offset_i (the encoder offset, as the
// hybrid's). Joint limits bound the command q.
//
// Closed-form IK. With d_i = R·p_i + t − s_i (shaft point to platform sphere),
//   |d − c (cos θ z + sin θ y)|² = ℓ²
//   |d|² − 2c (cos θ d·z + sin θ d·y) + c² (cos²θ + sin²θ) = ℓ²      (z ⟂ y, unit)
// so
//   A cos θ + B sin θ = C,   A = d·z,  B = d·y,  C = (|d|² + c² − ℓ²) / (2c).
// Writing A = ρ cos φ, B = ρ sin φ (ρ = √(A² + B²), φ = atan2(B, A)) gives
// ρ cos(θ − φ) = C, hence the two branches
//   θ = φ + σ·acos(C/ρ),   σ = ±1,
// real only for |C| ≤ ρ (otherwise the rod cannot reach the crank circle:
// Unreachable). At |C| = ρ the branches meet: the rod is normal to the path
// of its crank tip, a serial singularity (dθ/dpose infinite).
//
// Branch = assembly mode. For θ = φ + σα with α ∈ (0, π), the crank direction
// e = cos θ z + sin θ y is turned by σα from d's projection on the crank plane,
// so σ = sign(a · (d × e)) = −sign(r · (a × e)) with r = d − c e the rod: the
// branch is the side on which the rod meets the crank (the "elbow"), and it
// can change only through |C| = ρ. The rule the IK applies, per leg:
//   1. each branch's command is wrapped into the window centred on the middle
//      of the joint range, [mid − π, mid + π);
//   2. a branch outside [min_joint, max_joint] is never returned; none inside
//      is OutOfLimits;
//   3. if both are inside (limits wider than one branch needs), the one on
//      the machine's home branch `home_branch_i` (σ at the home pose, filled
//      by rus6_home_branches); with home_branch_i = 0 (unknown), the one
//      nearer the middle of the range.
// Reference machines set limits narrow enough that rule 2 alone decides.
//
// Jacobian. Differentiating the closure |r|² = ℓ² with r = R·p + t − C(θ) for
// a platform twist (v at the platform origin, ω; base axes, pose.hpp) and θ̇:
//   r · (v + ω × R·p − C'(θ) θ̇) = 0,   C'(θ) = a × (C − s)  (the tip velocity)
// so, with u = r/|r| the unit rod and the crank's lever λ = u · (a × (C − s))
// (mm of rod per rad of crank):
//   θ̇ = [uᵀ, ((R·p) × u)ᵀ] · (v, ω) / λ.
// Row i of K = [uᵀ, ((R·p) × u)ᵀ] is the 6-UPS leg's actuation wrench
// (stewart.hpp) with the crank tip as base hinge; the inverse Jacobian is
// J = Λ⁻¹·K, Λ = diag(λ_i), and the forward Jacobian (twist per q̇) is
// J⁻¹ = K⁻¹·Λ. λ_i → 0 is the serial singularity above (the branches meet),
// K singular the parallel one. Note λ_i = −σ_i |λ_i|: the lever's sign is
// the branch.
#pragma once

#include "kincal/core/atan2.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/small_lu.hpp"
#include "kincal/core/status.hpp"
#include "kincal/core/stewart.hpp"  // FkReport, FkOptions, stewart_jacobian_into

namespace kincal {

template <class Scalar> struct Rus6Geometry {
  Eigen::Matrix<Scalar, 3, 6> shaft_points = Eigen::Matrix<Scalar, 3, 6>::Zero();  // s_i, base frame, mm
  Eigen::Matrix<Scalar, 3, 6> shaft_axes = Eigen::Matrix<Scalar, 3, 6>::Zero();    // a_i, unit
  Eigen::Matrix<Scalar, 3, 6> crank_zero = Eigen::Matrix<Scalar, 3, 6>::Zero();    // z_i, unit, ⟂ a_i
  Vec6<Scalar> crank_length = Vec6<Scalar>::Zero();  // c_i, mm
  Vec6<Scalar> rod_length = Vec6<Scalar>::Zero();    // ℓ_i, mm
  Eigen::Matrix<Scalar, 3, 6> platform_joints = Eigen::Matrix<Scalar, 3, 6>::Zero();  // p_i, platform frame, mm
  Vec6<Scalar> joint_offset = Vec6<Scalar>::Zero();  // θ_i − q_i (encoder offset), rad
  Vec6<Scalar> min_joint = Vec6<Scalar>::Constant(-pi<Scalar>());  // on the command q, rad
  Vec6<Scalar> max_joint = Vec6<Scalar>::Constant(pi<Scalar>());
  // σ_i of the home assembly (+1, −1; 0 = unknown): decides only when both
  // IK branches are inside the limits (rule 3 at the top).
  Vec6<Scalar> home_branch = Vec6<Scalar>::Zero();
  Pose<Scalar> home;  // FK's default starting pose
  // Radians → millimetres when judging how singular a Jacobian is (about the
  // platform radius), as for the 6-UPS.
  Scalar characteristic_length = Scalar(200);

  template <class Other> Rus6Geometry<Other> cast() const {
    Rus6Geometry<Other> g;
    g.shaft_points = shaft_points.template cast<Other>();
    g.shaft_axes = shaft_axes.template cast<Other>();
    g.crank_zero = crank_zero.template cast<Other>();
    g.crank_length = crank_length.template cast<Other>();
    g.rod_length = rod_length.template cast<Other>();
    g.platform_joints = platform_joints.template cast<Other>();
    g.joint_offset = joint_offset.template cast<Other>();
    g.min_joint = min_joint.template cast<Other>();
    g.max_joint = max_joint.template cast<Other>();
    g.home_branch = home_branch.template cast<Other>();
    g.home = home.template cast<Other>();
    g.characteristic_length = Other(characteristic_length);
    return g;
  }
};
using Rus6Geometryd = Rus6Geometry<double>;
using Rus6Geometryf = Rus6Geometry<float>;

// A parameter set the kinematics can use: finite; unit shaft axes and crank
// directions (to 1e-6, relative rounding of a hand-written file), orthogonal;
// positive crank and rod lengths; ordered limits no wider than one turn
// (otherwise a command and the same command + 2π would both be legal);
// branches in {−1, 0, 1}. Not checked per call (the controller path): a
// port checks it once, identify when it builds a machine.
template <class Scalar> bool rus6_valid_geometry(const Rus6Geometry<Scalar>& g) {
  if (!all_finite(g.shaft_points) || !all_finite(g.shaft_axes) || !all_finite(g.crank_zero) ||
      !all_finite(g.crank_length) || !all_finite(g.rod_length) || !all_finite(g.platform_joints) ||
      !all_finite(g.joint_offset) || !all_finite(g.min_joint) || !all_finite(g.max_joint) ||
      !all_finite(g.home_branch) || !g.home.finite() || !is_finite(g.characteristic_length) ||
      !(g.characteristic_length > Scalar(0)))
    return false;
  const Scalar unit_tol = Scalar(1e-6);
  for (int i = 0; i < 6; ++i) {
    const Vec3<Scalar> a = g.shaft_axes.col(i), z = g.crank_zero.col(i);
    if (!(std::abs(a.norm() - Scalar(1)) < unit_tol) || !(std::abs(z.norm() - Scalar(1)) < unit_tol) ||
        !(std::abs(a.dot(z)) < unit_tol))
      return false;
    if (!(g.crank_length(i) > Scalar(0)) || !(g.rod_length(i) > Scalar(0))) return false;
    if (!(g.min_joint(i) < g.max_joint(i)) || !(g.max_joint(i) - g.min_joint(i) < Scalar(2) * pi<Scalar>()))
      return false;
    const Scalar b = g.home_branch(i);
    if (!(b == Scalar(0) || b == Scalar(1) || b == Scalar(-1))) return false;
  }
  return true;
}

// The kinematics below take a Rus6Geometry or anything with its members
// under the same names (G): a controller reads its table's numbers in place
// through Eigen maps (core/rus6_machine.hpp's Rus6GeometryRef), so two
// geometries need not be copied into its static RAM.

// Crank tip C_i(θ) for the physical angle θ. By components, y_i = a_i × z_i
// included: on a Cortex-M at -Os the Eigen expression kept 400 bytes of
// temporaries on the controller's deepest stack path (under cos's argument
// reduction).
template <class G, class Scalar> Vec3<Scalar> rus6_crank_tip(const G& g, int i, Scalar theta) {
  const Scalar c = std::cos(theta) * g.crank_length(i), s = std::sin(theta) * g.crank_length(i);
  const Scalar ax = g.shaft_axes(0, i), ay = g.shaft_axes(1, i), az = g.shaft_axes(2, i);
  const Scalar zx = g.crank_zero(0, i), zy = g.crank_zero(1, i), zz = g.crank_zero(2, i);
  return Vec3<Scalar>(g.shaft_points(0, i) + c * zx + s * (ay * zz - az * zy),
                      g.shaft_points(1, i) + c * zy + s * (az * zx - ax * zz),
                      g.shaft_points(2, i) + c * zz + s * (ax * zy - ay * zx));
}

// One leg at a pose and its crank's physical angle θ: the platform arm R·p_i,
// the crank tip C_i, the rod's unit u_i and length, and the lever
// λ_i = u_i · (a_i × (C_i − s_i)) (header comment; mm/rad). No checks: the
// one place these are written (rus6_legs_at, the IK's checked Jacobian and
// the formulas' `lever` read it). Always inlined: at -Os its own frame
// (280 B) sat on the controller's deepest path, under checked_jacobian
// (examples/firmware/footprint.sh, 2026-11-29).
template <class Scalar> struct Rus6Leg {
  Vec3<Scalar> arm, tip, unit;
  Scalar length, lever;
};
template <class G, class Scalar>
KINCAL_ALWAYS_INLINE Rus6Leg<Scalar> rus6_leg_at(const G& g, const Pose<Scalar>& pose, int i, Scalar theta) {
  Rus6Leg<Scalar> leg;
  leg.arm = pose.R * Vec3<Scalar>(g.platform_joints.col(i));
  leg.tip = rus6_crank_tip(g, i, theta);
  const Vec3<Scalar> rod = leg.arm + pose.p - leg.tip;
  leg.length = rod.norm();
  leg.unit = rod / leg.length;
  const Vec3<Scalar> tip_velocity =
      Vec3<Scalar>(g.shaft_axes.col(i)).cross(Vec3<Scalar>(leg.tip - g.shaft_points.col(i)));
  leg.lever = leg.unit.dot(tip_velocity);
  return leg;
}

// What the Jacobians are built from, at one (pose, θ): the caller's scratch.
template <class Scalar> struct Rus6Legs {
  Eigen::Matrix<Scalar, 3, 6> arms;        // R·p_i, base axes
  Eigen::Matrix<Scalar, 3, 6> crank_tips;  // C_i(θ_i), base frame
  Eigen::Matrix<Scalar, 3, 6> rod_units;   // u_i = (R·p_i + t − C_i) / |…|
  Vec6<Scalar> rod_lengths;                // |R·p_i + t − C_i| (= ℓ_i where the loop closes)
  Vec6<Scalar> levers;                     // λ_i = u_i · (a_i × (C_i − s_i)), mm/rad
};

// Legs at a pose and the physical angles θ. No checks: a building block.
template <class G, class Scalar>
void rus6_legs_at(const G& g, const Pose<Scalar>& pose, const Vec6<Scalar>& theta, Rus6Legs<Scalar>& legs) {
  for (int i = 0; i < 6; ++i) {
    const Rus6Leg<Scalar> leg = rus6_leg_at(g, pose, i, theta(i));
    legs.arms.col(i) = leg.arm;
    legs.crank_tips.col(i) = leg.tip;
    legs.rod_units.col(i) = leg.unit;
    legs.rod_lengths(i) = leg.length;
    legs.levers(i) = leg.lever;
  }
}

// The branch σ_i of each leg (−sign λ_i; header comment).
template <class Scalar> Vec6<Scalar> rus6_branches(const Rus6Legs<Scalar>& legs) {
  Vec6<Scalar> sigma;
  for (int i = 0; i < 6; ++i) sigma(i) = legs.levers(i) < Scalar(0) ? Scalar(1) : Scalar(-1);
  return sigma;
}

// K: row i = [u_iᵀ, ((R·p_i) × u_i)ᵀ], the rods' actuation wrenches (header
// comment), written into any 6×6 destination (the LU's storage in FK).
template <class Scalar, class Out> void rus6_wrenches_into(Out&& K, const Rus6Legs<Scalar>& legs) {
  for (int i = 0; i < 6; ++i) {
    const Vec3<Scalar> u = legs.rod_units.col(i);
    K.template block<1, 3>(i, 0) = u.transpose();
    K.template block<1, 3>(i, 3) = Vec3<Scalar>(legs.arms.col(i)).cross(u).transpose();
  }
}

// Inverse Jacobian J = ∂q/∂twist = Λ⁻¹·K (header comment), into any 6×6
// destination. No checks.
template <class Scalar, class Out> void rus6_jacobian_into(Out&& J, const Rus6Legs<Scalar>& legs) {
  for (int i = 0; i < 6; ++i) {
    const Vec3<Scalar> u = legs.rod_units.col(i);
    const Scalar inv_lever = Scalar(1) / legs.levers(i);
    J.template block<1, 3>(i, 0) = inv_lever * u.transpose();
    J.template block<1, 3>(i, 3) = inv_lever * Vec3<Scalar>(legs.arms.col(i)).cross(u).transpose();
  }
}

template <class Scalar> Mat6<Scalar> rus6_jacobian(const Rus6Legs<Scalar>& legs) {
  Mat6<Scalar> J;
  rus6_jacobian_into(J, legs);
  return J;
}

// Serial singularity: a lever below this fraction of its crank length (the
// sine of the angle between rod and crank tangent) makes the command's
// sensitivity to the pose unbounded.
template <class G, class Scalar> bool rus6_levers_regular(const G& g, const Rus6Legs<Scalar>& legs) {
  for (int i = 0; i < 6; ++i)
    if (!(std::abs(legs.levers(i)) > Tolerance<Scalar>::singular_pivot_ratio * g.crank_length(i))) return false;
  return true;
}

// The one singularity test of the family: false at a serial singularity (a
// lever λ_i ≈ 0, where J⁻¹ loses rank) or a parallel one (K singular). K is
// factorised with its angular columns scaled by 1/L (dimensionless, as the
// 6-UPS's): K = K_s·S⁻¹, S = diag(1, 1, 1, 1/L, 1/L, 1/L); `lu` holds K_s.
template <class G, class Scalar>
bool rus6_factor_regular(const G& g, const Rus6Legs<Scalar>& legs, SmallLu<Scalar, 6>& lu) {
  if (!rus6_levers_regular(g, legs)) return false;
  rus6_wrenches_into(lu.storage(), legs);
  lu.storage().template rightCols<3>() *= Scalar(1) / g.characteristic_length;
  return lu.factor() && lu.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio;
}

// Forward Jacobian ∂twist/∂q = K⁻¹·Λ = S·K_s⁻¹·Λ (header comment): column j
// is λ_j K_s⁻¹ e_j with its angular part scaled by 1/L. Singular (and
// `forward` untouched) where rus6_factor_regular fails.
template <class Scalar>
Status rus6_forward_jacobian(const Rus6Geometry<Scalar>& g, const Rus6Legs<Scalar>& legs, Mat6<Scalar>& forward) {
  SmallLu<Scalar, 6> lu;
  if (!rus6_factor_regular(g, legs, lu)) return Status::Singular;
  for (int j = 0; j < 6; ++j) forward.col(j) = legs.levers(j) * lu.solve(Vec6<Scalar>::Unit(j));
  forward.template bottomRows<3>() *= Scalar(1) / g.characteristic_length;
  return Status::Ok;
}

namespace rus6_detail {
// x − 2π·k wrapped into [mid − π, mid + π). The IK's x is an atan2 less an
// encoder offset, a turn at most from mid: one comparison each way, no
// division or floor (the general form only past that).
template <class Scalar> Scalar wrap_about(Scalar x, Scalar mid) {
  const Scalar two_pi = Scalar(2) * pi<Scalar>();
  if (x < mid - pi<Scalar>()) x += two_pi;
  else if (x >= mid + pi<Scalar>()) x -= two_pi;
  if (x >= mid - pi<Scalar>() && x < mid + pi<Scalar>()) return x;
  return x - two_pi * std::floor((x - mid + pi<Scalar>()) / two_pi);
}

// rus6_ik's Jacobian and legs at the physical angles θ (for a caller that
// wants the legs), in a frame of its own. Writes only on Ok.
template <class G, class Scalar>
KINCAL_NOINLINE Status jacobian_and_legs(const G& g, const Pose<Scalar>& pose, const Vec6<Scalar>& theta,
                                         Mat6<Scalar>* jacobian, Rus6Legs<Scalar>* legs) {
  Rus6Legs<Scalar> at;
  rus6_legs_at(g, pose, theta, at);
  if (!all_finite(at.rod_units) || !all_finite(at.levers)) return Status::InvalidInput;
  if (jacobian != nullptr) {
    SmallLu<Scalar, 6> lu;
    if (!rus6_factor_regular(g, at, lu)) return Status::Singular;
    rus6_jacobian_into(*jacobian, at);
  }
  if (legs != nullptr) *legs = at;
  return Status::Ok;
}

// rus6_ik's Jacobian alone: the numbers of rus6_legs_at, rus6_factor_regular
// and rus6_jacobian_into, leg by leg, without the legs' 6-leg scratch (528 B
// in double) and in a frame of its own. The controller's compensator asks
// for it on its deepest stack path (the nominal configuration): a 6-RUS
// image with formula effects needed 4 224 B of stack with the legs in the
// IK's frame, over the 4 KiB bar (docs/benchmarks.md). `levers`, if given,
// the six λ_i (the formulas' `lever`: the compensator's nominal
// configuration hands them on instead of running the IK again; written as
// they are found, also where the status is not Ok). Writes `jacobian` only
// on Ok.
template <class G, class Scalar>
KINCAL_NOINLINE Status checked_jacobian(const G& g, const Pose<Scalar>& pose, const Vec6<Scalar>& theta,
                                        Mat6<Scalar>& jacobian, Scalar* levers = nullptr) {
  SmallLu<Scalar, 6> lu;
  auto K = lu.storage();  // K_s: rus6_factor_regular's scaled wrenches
  Mat6<Scalar> J;
  bool finite = true, regular = true;
  for (int i = 0; i < 6; ++i) {
    const Rus6Leg<Scalar> leg = rus6_leg_at(g, pose, i, theta(i));
    if (levers != nullptr) levers[i] = leg.lever;
    finite = finite && all_finite(leg.unit) && is_finite(leg.lever);
    regular = regular && std::abs(leg.lever) > Tolerance<Scalar>::singular_pivot_ratio * g.crank_length(i);
    const Vec3<Scalar> moment = leg.arm.cross(leg.unit);
    const Scalar inv_lever = Scalar(1) / leg.lever;
    K.template block<1, 3>(i, 0) = leg.unit.transpose();
    K.template block<1, 3>(i, 3) = moment.transpose();
    J.template block<1, 3>(i, 0) = inv_lever * leg.unit.transpose();
    J.template block<1, 3>(i, 3) = inv_lever * moment.transpose();
  }
  if (!finite) return Status::InvalidInput;
  if (!regular) return Status::Singular;
  K.template rightCols<3>() *= Scalar(1) / g.characteristic_length;
  if (!lu.factor() || !(lu.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio)) return Status::Singular;
  jacobian = J;
  return Status::Ok;
}
}  // namespace rus6_detail

namespace rus6_detail {
// The IK's commands, closed form per leg (rus6_ik below).
template <class G, class Scalar> Status closed_form_commands(const G& g, const Pose<Scalar>& pose, Vec6<Scalar>& cmd) {
  if (!pose.finite()) return Status::InvalidInput;
  for (int i = 0; i < 6; ++i) {
    const Vec3<Scalar> d = pose.R * g.platform_joints.col(i) + pose.p - g.shaft_points.col(i);
    const Vec3<Scalar> z = g.crank_zero.col(i);
    const Vec3<Scalar> y = Vec3<Scalar>(g.shaft_axes.col(i)).cross(z);
    const Scalar c = g.crank_length(i), l = g.rod_length(i);
    const Scalar A = d.dot(z), B = d.dot(y);
    const Scalar C = (d.squaredNorm() + c * c - l * l) / (Scalar(2) * c);
    const Scalar rho2 = A * A + B * B;
    if (!is_finite(C) || !is_finite(rho2)) return Status::InvalidInput;
    if (!(C * C <= rho2)) return Status::Unreachable;
    if (!(rho2 > Scalar(0))) return Status::Singular;
    // θ = φ + σα with cos α = C/ρ, sin α = S/ρ, S = √(ρ² − C²) ≥ 0:
    //   cos θ = cos φ cos α − σ sin φ sin α = (A·C − σ B·S)/ρ²
    //   sin θ = sin φ cos α + σ cos φ sin α = (B·C + σ A·S)/ρ²
    // so one atan2 per branch (ρ² > 0 drops out), no acos, and a second
    // atan2 only when the first branch tried is not the answer; libm's
    // atan2 was two fifths of the IK (atan2.hpp: within an ulp of it).
    const Scalar S = std::sqrt(std::max(Scalar(0), rho2 - C * C));
    const Scalar lo = g.min_joint(i), hi = g.max_joint(i), mid = Scalar(0.5) * (lo + hi);
    const Scalar offset = g.joint_offset(i);
    auto branch_command = [&](Scalar sigma) {
      return rus6_detail::wrap_about(atan2_rational(B * C + sigma * A * S, A * C - sigma * B * S) - offset, mid);
    };
    auto inside = [&](Scalar x) { return x >= lo && x <= hi; };
    // The rule at the top: a branch inside the limits, the home branch when
    // both are (so with a known home branch, try it first: if it is inside it
    // is the answer whatever the other does), else the one nearer mid-range.
    const Scalar home = g.home_branch(i);
    if (home != Scalar(0)) {
      const Scalar first = branch_command(home);
      if (inside(first)) {
        cmd(i) = first;
        continue;
      }
      const Scalar second = branch_command(-home);
      if (!inside(second)) return Status::OutOfLimits;
      cmd(i) = second;
    } else {
      const Scalar plus = branch_command(Scalar(1)), minus = branch_command(Scalar(-1));
      const bool plus_in = inside(plus), minus_in = inside(minus);
      if (plus_in && minus_in) cmd(i) = std::abs(plus - mid) <= std::abs(minus - mid) ? plus : minus;
      else if (plus_in) cmd(i) = plus;
      else if (minus_in) cmd(i) = minus;
      else return Status::OutOfLimits;
    }
  }
  if (!all_finite(cmd)) return Status::InvalidInput;
  return Status::Ok;
}
}  // namespace rus6_detail

// IK: commands q for a platform pose, closed form per leg (header comment).
// Writes `q` (and `jacobian` = ∂q/∂twist, and `legs`, if given) only on Ok.
//   InvalidInput  non-finite pose (or geometry)
//   Unreachable   some leg has |C| > ρ: the rod cannot reach its crank circle
//   Singular      ρ = 0 with C = 0 (the sphere on the shaft line: every θ
//                 closes), or, when the Jacobian is requested, a serial
//                 (λ_i ≈ 0) or parallel (K singular) singularity
//   OutOfLimits   neither branch of some leg inside [min_joint, max_joint]
// Two overloads, so that a caller without `legs` (the controller) has no
// path to the legs' scratch: a static stack bound counts every call a
// function can make, taken or not. The first also gives the six levers λ_i
// with the Jacobian (`levers`, if given with `jacobian`).
template <class G, class Scalar>
Status rus6_ik(const G& g, const Pose<Scalar>& pose, Vec6<Scalar>& q, NonDeducedT<Mat6<Scalar>>* jacobian = nullptr,
               NonDeducedT<Scalar>* levers = nullptr) {
  Vec6<Scalar> cmd;
  const Status s = rus6_detail::closed_form_commands(g, pose, cmd);
  if (s != Status::Ok) return s;
  if (jacobian != nullptr) {
    const Status js = rus6_detail::checked_jacobian(g, pose, Vec6<Scalar>(cmd + g.joint_offset), *jacobian, levers);
    if (js != Status::Ok) return js;
  }
  q = cmd;
  return Status::Ok;
}

template <class G, class Scalar>
Status rus6_ik(const G& g, const Pose<Scalar>& pose, Vec6<Scalar>& q, NonDeducedT<Mat6<Scalar>>* jacobian,
               NonDeducedT<Rus6Legs<Scalar>>* legs) {
  if (legs == nullptr) return rus6_ik(g, pose, q, jacobian, static_cast<Scalar*>(nullptr));
  Vec6<Scalar> cmd;
  const Status s = rus6_detail::closed_form_commands(g, pose, cmd);
  if (s != Status::Ok) return s;
  const Status ls = rus6_detail::jacobian_and_legs(g, pose, Vec6<Scalar>(cmd + g.joint_offset), jacobian, legs);
  if (ls != Status::Ok) return ls;
  q = cmd;
  return Status::Ok;
}

// σ_i at the home pose, for Rus6Geometry::home_branch: the branch the IK picks
// at home with home_branch unknown (rule 3: the one nearer mid-range when
// both fit). Status of that IK on failure, `branches` untouched.
template <class Scalar> Status rus6_home_branches(const Rus6Geometry<Scalar>& g, Vec6<Scalar>& branches) {
  Rus6Geometry<Scalar> unknown = g;
  unknown.home_branch.setZero();
  Vec6<Scalar> q;
  Rus6Legs<Scalar> legs;
  const Status st = rus6_ik(unknown, g.home, q, nullptr, &legs);
  if (st != Status::Ok) return st;
  branches = rus6_branches(legs);
  return Status::Ok;
}

// The numbers the 6-RUS offers its formula effects per joint (GUIDE
// "Effects written as formulas", `kincal effects --robot R`), at the
// nominal configuration of a commanded pose: values[i] = `rod` ℓ_i (mm),
// values[6 + i] = `lever` λ_i (header comment: mm of rod per rad of crank,
// signed by the branch). A rod longer by δℓ moves the platform as a crank
// turned by δℓ / λ_i does (r·ṙ = 0 with |r| = ℓ + δℓ: λ dθ = δℓ), so rods
// expanding with temperature are the joint effect
//   a · rod · (temp − 20) / lever.
// Status of the IK where it fails (the host passes a geometry with its
// limits opened for measured rows, as for the rest of a node). Leg by leg
// (rus6_leg_at), without the 6-leg scratch. The controller's compensator
// takes the same levers from its nominal IK's Jacobian (rus6_ik's `levers`,
// the same rus6_leg_at at the same angles) instead of calling this.
template <class G, class Scalar> Status rus6_formula_joint_values(const G& g, const Pose<Scalar>& pose, Scalar* values) {
  Vec6<Scalar> q;
  const Status s = rus6_ik(g, pose, q);
  if (s != Status::Ok) return s;
  for (int i = 0; i < 6; ++i) {
    values[i] = g.rod_length(i);
    values[6 + i] = rus6_leg_at(g, pose, i, Scalar(q(i) + g.joint_offset(i))).lever;
  }
  return Status::Ok;
}

template <class Scalar> bool rus6_within_limits(const Rus6Geometry<Scalar>& g, const Vec6<Scalar>& q) {
  return !((q.array() < g.min_joint.array()).any() || (q.array() > g.max_joint.array()).any());
}

// FK: platform pose for commands q. The commands fix the crank tips C_i, so
// what is left is a 6-UPS with base hinges C_i and legs ℓ_i: Newton's method
// on |R·p_i + t − C_i| − ℓ_i = 0 with K (header comment) as its Jacobian,
// each step a twist applied with apply_twist (stays on SE(3)), starting from
// `guess` (the last pose in a controller, `home` otherwise). Stops when every
// rod residual is below relative_residual × the longest rod (double: 3e-11
// mm on a 300 mm rod; float: ~1.4e-4 mm). Writes `pose` only on Ok.
// Status: InvalidInput (non-finite q or guess), OutOfLimits (q outside the
// limits), Singular (K singular on the way), NotConverged.
// Newton converges to the assembly nearest the guess; which IK branch each
// leg is on at the result is not checked here (rus6_branches of the legs
// says it).
template <class Scalar>
FkReport<Scalar> rus6_fk(const Rus6Geometry<Scalar>& g, const Vec6<Scalar>& q, const Pose<Scalar>& guess,
                         Pose<Scalar>& pose, const NonDeducedT<FkOptions<Scalar>>& options = FkOptions<Scalar>()) {
  FkReport<Scalar> report;
  if (!all_finite(q) || !guess.finite()) {
    report.status = Status::InvalidInput;
    return report;
  }
  if (!rus6_within_limits(g, q)) {
    report.status = Status::OutOfLimits;
    return report;
  }
  Eigen::Matrix<Scalar, 3, 6> tips;
  for (int i = 0; i < 6; ++i) tips.col(i) = rus6_crank_tip(g, i, q(i) + g.joint_offset(i));
  // The 6-UPS's Newton with the crank tips as the anchors and the rods as
  // the distances (stewart.hpp six_distance_fk).
  return six_distance_fk(tips, g.platform_joints, g.rod_length, g.characteristic_length,
                         options.relative_residual * g.rod_length.cwiseAbs().maxCoeff(), options.max_iterations,
                         guess, pose);
}

template <class Scalar>
FkReport<Scalar> rus6_fk(const Rus6Geometry<Scalar>& g, const Vec6<Scalar>& q, Pose<Scalar>& pose) {
  return rus6_fk(g, q, g.home, pose);
}

}  // namespace kincal
