// Independent simulator of `hybrid-seed000` (seed 000's 3-UPS + UP parallel
// mechanism with a 3R wrist), for testing kincal's identification on data its
// own model did not make.
//
// What it does differently from kincal's model (core/hybrid.hpp,
// identify's HybridErrorModel):
//  - Kinematics is a product of exponentials about joint LINES given in {R0}
//    at one reference configuration (θ1 = θ2 = 0, c = 850 mm, wrist angles
//    0): T = e^[S1]θ1 · e^[S2]θ2 · e^[S3]d · e^[S4]θ4 · e^[S5]θ5 · e^[S6]θ6 · M,
//    d = c − 850. kincal chains Denavit–Hartenberg-like frames with an error
//    transform per frame (docs/hybrid-error-model.md §1).
//  - Errors are PHYSICAL quantities of that description: where a joint centre
//    is, which way an axis points, how far two U axes are apart, how far a
//    prismatic line passes from its U centre, where the tool point and the tool
//    frame sit on joint 6's body, encoder zeros. Not the 150 frame-error
//    components of seed 000 Eq. (7); the two sets are related only through
//    the physics.
//  - Each UPS leg is closed by its own 3-unknown Newton solve (U angles and
//    prismatic value that bring the leg's sphere centre onto the platform's S
//    point), so a leg offset is not a change of a distance; the parallel part
//    is an outer Newton on the UP limb's (θ1, θ2, d) with the legs' ∂x/∂S.
//  - The nominal IK is Newton on the same product of exponentials (6 joint
//    variables to the target tool frame), not core's closed form.
//
// Only Eigen and core's Pose<double> (exchange type / CSV convention) are
// used; the numbers of make_hybrid_seed000() are re-entered here.
//
// Conventions kept from kincal so its tools read the data:
//  - poses (commanded and measured) are the tool frame in the workpiece frame
//    {R}: wR0 = Rot(y, π − β)·Rot(z, π/2), β = π/6 (seed 000 Eq. (8)); origin
//    of {R} at the reference tool point (θ5 = β); the tool frame equals {R}
//    there. {R} and the tool frame's nominal placement C are NOMINAL constants:
//    the errors move the machine, not the workpiece frame.
//  - commands q = (q1, q2, q3, θ4, θ5, θ6); the physical value of each
//    actuated joint is q + encoder offset (kincal's Δξ sign, nominal
//    joint_offset = 0). A UPS "physical value" is the prismatic coordinate x:
//    the sphere centre is at distance x along the prismatic line from the
//    line's foot nearest the U centre (= the leg length with no leg offset).
#pragma once

#include "independent_common.hpp"

namespace kincal::independent {

// ------------------------------------------------------------------ parameters

// The UP limb (U at A0, passive prismatic along the limb).
struct HybridUpLimbErrors {
  V3 u_centre = V3::Zero();                 // mm: the U centre (both axes move with it), {R0}
  std::array<double, 2> axis1_tilt{0, 0};   // rad: axis 1 (x0) turned about y0, z0
  std::array<double, 2> axis2_tilt{0, 0};   // rad: axis 2 (y0) turned about x0, z0
  double axis_offset = 0;                   // mm: axis 2 displaced from axis 1 along z0 (their common normal)
  std::array<double, 2> slide_tilt{0, 0};   // rad: prismatic direction (z0) turned about x0, y0
};

// One wrist revolute's line.
struct HybridWristJointErrors {
  V3 point = V3::Zero();                // mm: displacement of the line (the part along the axis does nothing)
  std::array<double, 2> tilt{0, 0};     // rad: direction turned about the two normals listed below
};

// All fields zero = the nominal machine.
struct HybridErrors {
  // UPS legs i = 1..3 (index 0..2): U centre, U axis directions, the offset
  // between the two U axes, the leg offset (independent_common.hpp UpsLegErrors).
  std::array<UpsLegErrors, 3> ups{};
  std::array<V3, 3> ups_platform_centre{V3::Zero(), V3::Zero(), V3::Zero()};  // mm, S centre, platform frame
  std::array<double, 3> ups_encoder{0, 0, 0};                                 // mm, physical x = q + this
  HybridUpLimbErrors up{};
  // Wrist joints 4, 5, 6 (index 0..2). Tilt normals: joint 4 (z0) about x0, y0;
  // joint 5 (x0) about y0, z0; joint 6 (y0) about z0, x0 (at the reference configuration).
  std::array<HybridWristJointErrors, 3> wrist{};
  std::array<double, 3> wrist_encoder{0, 0, 0};  // rad, physical θ = q + this
  V3 tool_point = V3::Zero();     // mm, tool point on joint 6's body, tool-frame coordinates
  V3 tool_rotation = V3::Zero();  // rad, tool frame turned on joint 6's body: R_tool·exp([δ]×) (tool coordinates)

  // Error groups, each filled by fill_group (length scale for mm, angle scale for rad):
  //   ups_joint_centres  UPS base U centres and platform S centres (18 mm)
  //   ups_axes           UPS U axis directions (12 rad) and U axis offsets (3 mm)
  //   leg_offsets        UPS prismatic lines displaced from the U centre (6 mm)
  //   up_limb            UP U centre (3 mm), axis offset (1 mm), U axis directions (4 rad), prismatic direction (2 rad)
  //   wrist_axis_lines   wrist joint lines: points (9 mm), directions (6 rad)
  //   tool               tool point (3 mm), tool frame orientation (3 rad)
  //   encoder_offsets    UPS encoders (3 mm), wrist encoders (3 rad)
  static std::vector<std::string> group_names() {
    return {"ups_joint_centres", "ups_axes", "leg_offsets", "up_limb", "wrist_axis_lines", "tool", "encoder_offsets"};
  }
};

// Uniform values in [−length, length] mm and [−angle, angle] rad for every
// parameter of `group`. Throws std::invalid_argument on an unknown group.
inline void fill_group(HybridErrors& e, const std::string& group, double length, double angle, std::mt19937_64& rng) {
  auto L = [&] { return uniform(rng, length); };
  auto A = [&] { return uniform(rng, angle); };
  auto L3 = [&] { return V3(L(), L(), L()); };
  if (group == "ups_joint_centres") {
    for (auto& leg : e.ups) leg.base_centre = L3();
    for (auto& c : e.ups_platform_centre) c = L3();
  } else if (group == "ups_axes") {
    for (auto& leg : e.ups) {
      leg.axis_a_tilt = {A(), A()};
      leg.axis_b_tilt = {A(), A()};
      leg.axis_offset = L();
    }
  } else if (group == "leg_offsets") {
    for (auto& leg : e.ups) leg.leg_offset = {L(), L()};
  } else if (group == "up_limb") {
    e.up.u_centre = L3();
    e.up.axis_offset = L();
    e.up.axis1_tilt = {A(), A()};
    e.up.axis2_tilt = {A(), A()};
    e.up.slide_tilt = {A(), A()};
  } else if (group == "wrist_axis_lines") {
    for (auto& j : e.wrist) {
      j.point = L3();
      j.tilt = {A(), A()};
    }
  } else if (group == "tool") {
    e.tool_point = L3();
    e.tool_rotation = V3(A(), A(), A());
  } else if (group == "encoder_offsets") {
    for (auto& v : e.ups_encoder) v = L();
    for (auto& v : e.wrist_encoder) v = A();
  } else {
    throw std::invalid_argument("unknown hybrid error group '" + group + "'");
  }
}

// Every group listed (default: all) at the given scales, from one seed.
inline HybridErrors random_hybrid_errors(double length, double angle, std::uint64_t seed,
                                         const std::vector<std::string>& groups = HybridErrors::group_names()) {
  HybridErrors e;
  std::mt19937_64 rng(seed);
  for (const auto& g : groups) fill_group(e, g, length, angle, rng);
  return e;
}

// ------------------------------------------------------------------ physical effects

// Physical effects beyond the geometry (issue #31, "the diagnosis on
// independent data"): this simulator's own implementation, written from the
// physics, not kincal's effect code (core/effects.hpp). All zero = off (the
// default), and then fk(q, inputs) is fk(q). Joints j = 0..5 are the commands
// q1..q6 (UPS legs in mm, wrist angles in rad). Applied in this order to the
// command q_j, giving the joint value the mechanism has before the encoder
// offset is added:
//   scale      the encoder / lead-screw reads short or long: value = q·(1 + s_j)
//   cyclic     screw cyclic error of the three UPS legs, a sinusoid of the
//              commanded length with the screw lead (5 mm, as the robot
//              description's default): + A_i·sin(2π q_i / lead + φ_i)
//   ramp       OUTSIDE the library: a lead error in the upper stroke of one
//              leg, + slope·max(0, q − knee) (a kink no candidate has)
//   backlash   lost motion b_j: the joint stops b_j/2 short of the command in
//              the direction it approached from: − (b_j/2)·dir_j
//   leg_thermal  OUTSIDE the built-in library (issue #32: a formula effect):
//              the three UPS legs alone expand, each with its own
//              coefficient (legs of another material than the frame): the
//              leg value the command sets, x_i = q_i + encoder_i, becomes
//              x_i·(1 + α_i·(T − 20 °C)), i.e. + α_i·(T − 20)·(q_i + encoder_i)
//              after backlash and before compliance (the other effects'
//              micrometres are not scaled). A user writes `a * q * (temp - 20)`
//              for joints [1, 2, 3]; that scales q, not q + encoder: a
//              difference of α·encoder·ΔT (~1e-6 µm). Independent of
//              `thermal` (both may be on).
//   compliance axial deflection of each UPS leg (and torsion of each wrist
//              joint) under a unit weight at the tool point along −z of the
//              base frame {R0}: + k_j·τ_j, τ_j = F·∂p/∂q_j, the static joint
//              load by virtual work, with ∂p/∂q_j by central differences of
//              THIS machine's FK (its actual, erroneous geometry) at the
//              undeflected joint values. kincal's `compliance` uses the same
//              virtual-work load but from its NOMINAL model's analytic
//              Jacobian at the commanded pose; the difference is second
//              order (geometry errors × deflection).
//   thermal    uniform expansion of the whole structure and its actuators
//              (lengths × (1 + c·(T − 20 °C))): the mechanism stays similar
//              to itself, so every point of it moves away from the base
//              origin A0 (origin of {R0}) by that factor, orientations kept.
//              Applied as that similarity to the reached tool frame.
struct HybridEffects {
  std::array<double, 6> scale{0, 0, 0, 0, 0, 0};       // 1
  std::array<double, 6> backlash{0, 0, 0, 0, 0, 0};    // full lost motion, mm (legs) / rad (wrist)
  std::array<double, 6> compliance{0, 0, 0, 0, 0, 0};  // deflection per unit load, mm (rad) per unit weight
  double thermal = 0;                                  // 1/°C
  std::array<double, 3> cyclic_amplitude{0, 0, 0};     // mm, UPS legs
  std::array<double, 3> cyclic_phase{0, 0, 0};         // rad
  double screw_lead = 5.0;                             // mm
  int ramp_joint = -1;                                 // outside the library: joint 0..5, −1 = off
  double ramp_knee = 0, ramp_slope = 0;                // mm (rad), 1
  std::array<double, 3> leg_thermal{0, 0, 0};          // α_i, 1/°C, UPS legs (outside the library)
  bool any() const {
    for (int j = 0; j < 6; ++j)
      if (scale[std::size_t(j)] != 0 || backlash[std::size_t(j)] != 0 || compliance[std::size_t(j)] != 0) return true;
    for (double a : cyclic_amplitude)
      if (a != 0) return true;
    for (double a : leg_thermal)
      if (a != 0) return true;
    return thermal != 0 || (ramp_joint >= 0 && ramp_slope != 0);
  }
};

// What the effects need besides the commands: the structure temperature and
// the approach direction of each joint (+1: the command last increased).
struct HybridInputs {
  double temp = 20;
  V6 dir = V6::Ones();
};

// ------------------------------------------------------------------ simulator

struct HybridFkResult {
  bool ok = false;
  Pose<double> pose;           // tool frame in {R}
  V3 passive = V3::Zero();     // θ1, θ2 (rad), c (mm)
  V3 leg_values = V3::Zero();  // UPS prismatic values x_i reached
  double closure = 0;          // max |x_i − (q_i + encoder_i)|, mm
  double leg_closure = 0;      // max |sphere centre − platform S point|, mm
  int iterations = 0;
};

class HybridSimulator {
 public:
  // make_hybrid_seed000()'s numbers (seed 000 Table 1 as docs/reference-machines.md reads it).
  static constexpr double kBaseRadius = 350.0;      // |A0 A1i|
  static constexpr double kPlatformRadius = 135.0;  // |A64 A6i|
  static constexpr double kPlatformToWrist = 405.0; // |A64 Q|
  static constexpr double kWristLink = 120.0;       // |Q P0|
  static constexpr double kToolLength = 250.0;      // |P0 P|
  static constexpr double kGaugeRadius = 200.0;     // |P0 Pj|
  static constexpr double kReferenceExtension = 850.0;  // c at the reference configuration
  static constexpr double kBeta = kPi / 6.0;

  explicit HybridSimulator(const HybridErrors& e = HybridErrors{}, const HybridEffects& fx = HybridEffects{})
      : errors_(e), effects_(fx) {
    const V3 x0 = V3::UnitX(), y0 = V3::UnitY(), z0 = V3::UnitZ();
    const double c0 = kReferenceExtension;
    // UP limb: U at A0 = Rx(θ1)·Ry(θ2) in core; here two lines through A0.
    const V3 uc = e.up.u_centre;
    joints_[0] = JointLine{true, uc, tilted(x0, y0, z0, e.up.axis1_tilt[0], e.up.axis1_tilt[1])};
    joints_[1] = JointLine{true, uc + e.up.axis_offset * z0, tilted(y0, x0, z0, e.up.axis2_tilt[0], e.up.axis2_tilt[1])};
    joints_[2] = JointLine{false, V3::Zero(), tilted(z0, x0, y0, e.up.slide_tilt[0], e.up.slide_tilt[1])};
    // Wrist: joint 4 along the limb through Q, joint 5 along x0 through Q,
    // joint 6 along y0 through P0 (all at the reference configuration).
    const V3 Q(0, 0, c0 + kPlatformToWrist), P0 = Q + kWristLink * z0;
    const V3 nominal_dir[3] = {z0, x0, y0};
    const V3 normals[3][2] = {{x0, y0}, {y0, z0}, {z0, x0}};
    const V3 through[3] = {Q, Q, P0};
    for (int k = 0; k < 3; ++k) {
      const auto& w = e.wrist[std::size_t(k)];
      joints_[std::size_t(3 + k)] =
          JointLine{true, through[k] + w.point, tilted(nominal_dir[k], normals[k][0], normals[k][1], w.tilt[0], w.tilt[1])};
    }
    // Workpiece frame and the tool frame's nominal placement C (nominal constants).
    wR0_ = rotation_about(y0, kPi - kBeta) * rotation_about(z0, kPi / 2);
    const M3 F6_ref = rotation_about(x0, kBeta);  // joint 5 at β, the others 0
    C_ = F6_ref.transpose() * wR0_.transpose();
    const V3 P_zero = P0 + kToolLength * z0;  // tool point with every joint at zero
    origin_ = Q + rotation_about(x0, kBeta) * (P_zero - Q);  // reference tool point (θ5 = β)
    M_.R = C_ * rotation_vector(e.tool_rotation);
    M_.p = P_zero + C_ * e.tool_point;
    // UPS legs: A1i at 90°, 210°, 330° on r = 350 (limb 1 in the y0–z0 plane);
    // S points on r = 135 about A64 in the platform plane.
    for (int i = 0; i < 3; ++i) {
      const double phi = kPi * (0.5 + 2.0 * i / 3.0);
      const V3 dir(std::cos(phi), std::sin(phi), 0.0);
      const V3 A = kBaseRadius * dir;
      const V3 S_nominal = c0 * z0 + kPlatformRadius * dir;
      base_centre_nominal_[std::size_t(i)] = A;
      sphere_at_zero_[std::size_t(i)] = S_nominal + e.ups_platform_centre[std::size_t(i)];
      legs_[std::size_t(i)] = make_ups_leg(A, (S_nominal - A).normalized(), e.ups[std::size_t(i)]);
    }
  }

  const HybridErrors& errors() const { return errors_; }
  const HybridEffects& effects() const { return effects_; }

  // The joint values the mechanism has for commands q under the effects
  // (see HybridEffects; the encoder offsets are added by fk).
  V6 effective_joints(const V6& q, const HybridInputs& in) const {
    const HybridEffects& fx = effects_;
    V6 v = q;
    for (int j = 0; j < 6; ++j) {
      v(j) = q(j) * (1.0 + fx.scale[std::size_t(j)]);
      if (j < 3) v(j) += fx.cyclic_amplitude[std::size_t(j)] * std::sin(2.0 * kPi * q(j) / fx.screw_lead + fx.cyclic_phase[std::size_t(j)]);
      if (j == fx.ramp_joint) v(j) += fx.ramp_slope * std::max(0.0, q(j) - fx.ramp_knee);
      v(j) -= 0.5 * fx.backlash[std::size_t(j)] * (in.dir(j) < 0 ? -1.0 : 1.0);
      if (j < 3 && fx.leg_thermal[std::size_t(j)] != 0)
        v(j) += fx.leg_thermal[std::size_t(j)] * (in.temp - 20.0) * (q(j) + errors_.ups_encoder[std::size_t(j)]);
    }
    bool compliant = false;
    for (double k : fx.compliance) compliant = compliant || k != 0;
    if (compliant) {
      const V3 F(0, 0, -1);  // unit weight, −z of {R0}
      const V6 v0 = v;
      for (int j = 0; j < 6; ++j) {
        if (fx.compliance[std::size_t(j)] == 0) continue;
        const double h = j < 3 ? 1e-3 : 1e-6;
        V6 a = v0, b = v0;
        a(j) += h;
        b(j) -= h;
        const auto ra = fk(a), rb = fk(b);
        if (!ra.ok || !rb.ok) return V6::Constant(std::nan(""));
        const V3 dp = wR0_.transpose() * (ra.pose.p - rb.pose.p) / (2 * h);  // ∂p/∂q_j in {R0}
        v(j) += fx.compliance[std::size_t(j)] * F.dot(dp);
      }
    }
    return v;
  }

  // FK with the effects: tool pose in {R} for commands q at `in`.
  HybridFkResult fk(const V6& q, const HybridInputs& in) const {
    if (!effects_.any()) return fk(q);
    HybridFkResult r = fk(effective_joints(q, in));
    if (r.ok && effects_.thermal != 0) {
      const double eps = effects_.thermal * (in.temp - 20.0);
      const V3 p0 = wR0_.transpose() * r.pose.p + origin_;  // tool point in {R0}, A0 at its origin
      r.pose.p = wR0_ * ((1.0 + eps) * p0 - origin_);
    }
    return r;
  }
  const UpsLeg& leg(int i) const { return legs_[std::size_t(i)]; }
  const M3& workpiece_rotation() const { return wR0_; }
  const V3& workpiece_origin() const { return origin_; }

  // The three gauge targets of seed 000 Section 3 in tool-frame coordinates:
  // in the plane through P0 normal to the tool axis (tool axis = −z of the
  // tool frame, P0 at +250 mm on z), |P0 Pj| = 200 mm at 90°, 210°, 330° from x.
  static std::vector<V3> gauge_targets() {
    std::vector<V3> t;
    for (double deg : {90.0, 210.0, 330.0}) {
      const double a = deg * kPi / 180.0;
      t.emplace_back(kGaugeRadius * std::cos(a), kGaugeRadius * std::sin(a), kToolLength);
    }
    return t;
  }

  // Platform motion for the UP limb's (θ1, θ2, c) and the motions before each joint.
  PoeState platform(const V3& passive) const {
    Eigen::VectorXd v(3);
    v << passive(0), passive(1), passive(2) - kReferenceExtension;
    return poe({joints_[0], joints_[1], joints_[2]}, v);
  }
  // Platform's S point of leg i in {R0}.
  V3 sphere_point(int i, const V3& passive) const { return platform(passive).product * sphere_at_zero_[std::size_t(i)]; }

  // Tool frame in {R0} for passive (θ1, θ2, c) and physical wrist angles.
  Rigid tool_in_base(const V3& passive, const V3& wrist) const {
    Eigen::VectorXd v(6);
    v << passive(0), passive(1), passive(2) - kReferenceExtension, wrist(0), wrist(1), wrist(2);
    return poe(std::vector<JointLine>(joints_.begin(), joints_.end()), v).product * M_;
  }

  Pose<double> to_workpiece(const Rigid& T) const {
    Pose<double> out;
    out.R = wR0_ * T.R;
    out.p = wR0_ * (T.p - origin_);
    return out;
  }
  Rigid from_workpiece(const Pose<double>& X) const { return Rigid{wR0_.transpose() * X.R, origin_ + wR0_.transpose() * X.p}; }

  // FK of this machine: tool pose in {R} for commands q. The parallel part:
  // Newton on s = (θ1, θ2, d) so that each UPS leg's required prismatic value
  // x_i(S_i(s)) equals q_i + encoder_i; ∂x_i/∂s_k = (∂x_i/∂S_i)·(∂S_i/∂s_k),
  // the first from the leg's own closure Jacobian, the second the UP joint's
  // point velocity at S_i (seed 000 Eq. (5) in spirit, here numerically from
  // the lines). Then the wrist is serial. Converged to 1e-12 mm.
  HybridFkResult fk(const V6& q, const V3& passive_guess = V3(0, 0, kReferenceExtension)) const {
    HybridFkResult out;
    if (!q.allFinite()) return out;
    V3 target;
    for (int i = 0; i < 3; ++i) target(i) = q(i) + errors_.ups_encoder[std::size_t(i)];
    V3 wrist;
    for (int k = 0; k < 3; ++k) wrist(k) = q(3 + k) + errors_.wrist_encoder[std::size_t(k)];
    V3 s = passive_guess;
    std::array<V3, 3> warm{V3(0, 0, -1), V3(0, 0, -1), V3(0, 0, -1)};
    double best = 1e300;
    for (int it = 0; it < 60; ++it) {
      const PoeState P = platform(s);
      M3 J;
      V3 r;
      double leg_closure = 0;
      for (int i = 0; i < 3; ++i) {
        const V3 S = P.product * sphere_at_zero_[std::size_t(i)];
        const LegSolution sol = solve_leg(legs_[std::size_t(i)], S, warm[std::size_t(i)]);
        if (!sol.ok) return out;
        warm[std::size_t(i)] = V3(sol.theta_a, sol.theta_b, sol.x);
        leg_closure = std::max(leg_closure, sol.closure);
        out.leg_values(i) = sol.x;
        r(i) = sol.x - target(i);
        for (int k = 0; k < 3; ++k) J(i, k) = sol.dx_dS.dot(point_rate(joints_[std::size_t(k)], P.before[std::size_t(k)], S));
      }
      out.iterations = it;
      out.closure = r.cwiseAbs().maxCoeff();
      out.leg_closure = leg_closure;
      const V3 step = -J.partialPivLu().solve(r);
      // Done at 1e-12 mm; or when Newton has reached the rounding floor (the
      // residual stops falling) below 1e-10 mm.
      const bool converged = out.closure < 1e-12 || (out.closure < 1e-10 && out.closure >= best);
      if (converged) {
        out.ok = std::isfinite(out.closure);
        out.passive = s;
        out.pose = to_workpiece(tool_in_base(s, wrist));
        return out;
      }
      best = std::min(best, out.closure);
      if (!step.allFinite()) return out;
      s += step;
    }
    return out;
  }

  // IK of this machine (errors included; a nominal simulator gives the nominal
  // IK the tests command): Newton on the product of exponentials for
  // (θ1, θ2, d, θ4, θ5, θ6) to the tool frame, error (Δp at P, rotation
  // vector) against the joint twists at P; then each leg's required prismatic
  // value. Starts at the reference configuration (θ5 = β) unless given
  // `guess` (θ1, θ2, c, θ4, θ5, θ6). No joint limits. False if Newton fails.
  bool ik(const Pose<double>& tool_in_R, V6& q, V3* passive = nullptr, const V6* guess = nullptr) const {
    if (!tool_in_R.finite()) return false;
    const Rigid goal = from_workpiece(tool_in_R);
    V6 x;
    if (guess != nullptr) {
      x = *guess;
      x(2) -= kReferenceExtension;
    } else {
      x << 0, 0, 0, 0, kBeta, 0;
    }
    const std::vector<JointLine> chain(joints_.begin(), joints_.end());
    bool done = false;
    for (int it = 0; it < 100 && !done; ++it) {
      const PoeState st = poe(chain, x);
      const Rigid T = st.product * M_;
      V6 err;
      err.head<3>() = goal.p - T.p;
      err.tail<3>() = rotation_log(goal.R * T.R.transpose());
      M6 J;
      for (int k = 0; k < 6; ++k) {
        J.block<3, 1>(0, k) = point_rate(chain[std::size_t(k)], st.before[std::size_t(k)], T.p);
        J.block<3, 1>(3, k) = angular_rate(chain[std::size_t(k)], st.before[std::size_t(k)]);
      }
      V6 step = J.partialPivLu().solve(err);
      if (!step.allFinite()) return false;
      const bool small = err.head<3>().norm() < 1e-9 && err.tail<3>().norm() < 1e-12;
      // Quadratic convergence: one more step from "small" lands on the
      // rounding floor (~1e-13 mm); stop when the step stops mattering.
      V6 scaled = step;
      scaled(2) /= 1000.0;  // mm → the angles' scale (about the machine's size)
      if (small && scaled.cwiseAbs().maxCoeff() < 1e-14) {
        done = true;
        break;
      }
      // Keep far starts on the branch through the reference configuration.
      const double big = std::max(step.head<2>().cwiseAbs().maxCoeff(), step.tail<3>().cwiseAbs().maxCoeff());
      if (big > 0.3) step *= 0.3 / big;
      x += step;
      if (small && it > 60) done = true;  // rounding floor above 1e-14
    }
    if (!done) return false;
    const V3 s(x(0), x(1), x(2) + kReferenceExtension);
    const PoeState P = platform(s);
    for (int i = 0; i < 3; ++i) {
      const LegSolution sol = solve_leg(legs_[std::size_t(i)], P.product * sphere_at_zero_[std::size_t(i)]);
      if (!sol.ok) return false;
      q(i) = sol.x - errors_.ups_encoder[std::size_t(i)];
    }
    for (int k = 0; k < 3; ++k) q(3 + k) = x(3 + k) - errors_.wrist_encoder[std::size_t(k)];
    if (passive != nullptr) *passive = s;
    return true;
  }

 private:
  HybridErrors errors_;
  HybridEffects effects_;
  std::array<JointLine, 6> joints_;  // S1 (U, x0), S2 (U, y0), S3 (P), S4, S5, S6 (wrist)
  Rigid M_;                          // tool frame at the reference configuration, {R0}
  M3 wR0_, C_;
  V3 origin_;
  std::array<UpsLeg, 3> legs_;
  std::array<V3, 3> base_centre_nominal_;
  std::array<V3, 3> sphere_at_zero_;  // platform S points at the reference configuration, {R0}
};

// Dataset of the erroneous machine `actual` commanded by the nominal IK.
inline Dataset make_hybrid_dataset(const HybridErrors& errors, const std::vector<V6>& commanded,
                                   const MeasurementSpec& spec) {
  return make_dataset(HybridSimulator(errors), HybridSimulator(), commanded, spec);
}

// Dataset of the erroneous machine with effects, commanded in the order given
// (motion order) by the nominal IK: each row's approach directions are the
// signs of the command change from the previous row (kept while a joint
// stands still; +1 from the home pose, the reference pose, as kincal's
// controller starts), `temps[k]` its temperature (empty: 20 °C), `roles[k]`
// its role (empty: cal). The CSV then carries role, temp and dir1..dir6.
// Noise as make_dataset (the same draws for the same seed and rows).
inline Dataset make_hybrid_effect_dataset(const HybridErrors& errors, const HybridEffects& effects,
                                          const std::vector<V6>& commanded, const MeasurementSpec& spec,
                                          const std::vector<double>& temps = {},
                                          const std::vector<std::string>& roles = {}) {
  const HybridSimulator actual(errors, effects), nominal;
  V6 previous;
  if (!nominal.ik(Pose<double>(), previous)) throw std::runtime_error("no home pose");
  V6 dir = V6::Ones();
  Dataset out = make_dataset_by(nominal, commanded, spec, [&](std::size_t i, DatasetRow& row) {
    // The approach direction: the sign of the command change, kept while a
    // joint stands still (+1 from home).
    for (int j = 0; j < 6; ++j)
      if (row.q(j) != previous(j)) dir(j) = row.q(j) > previous(j) ? 1.0 : -1.0;
    previous = row.q;
    HybridInputs in;
    in.dir = dir;
    if (!temps.empty()) in.temp = temps[i];
    row.temp = in.temp;
    row.dir = dir;
    if (!roles.empty()) row.role = roles[i];
    return actual.fk(row.q, in);
  });
  out.has_role = !roles.empty();
  out.has_temp = !temps.empty();
  out.has_dir = true;
  return out;
}

}  // namespace kincal::independent
