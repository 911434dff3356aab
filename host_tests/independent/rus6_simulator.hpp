// Independent simulator of a 6-RUS hexapod (rotary motors, cranks, rods with
// a sphere at each end), for testing kincal's identification on data its own
// model did not make.
//
// Two nominal machines are built in (Rus6Nominal; any other is a struct away):
//  - rus6_ref_nominal(): kincal's built-in `rus6-ref` as docs/reference-
//    machines.md documents it (motor pairs at 0°, 120°, 240° ± 25°, radial
//    shafts, crank 100 mm, rod 300 mm, platform spheres on r = 130 mm, home
//    z = 274.0438 mm with every crank horizontal, limits −80°…+70°). The
//    numbers are re-entered here, not read from core. Data for
//    `kincal … --robot rus6-ref` must come from this one.
//  - rus6_tangential_nominal(): a second 6-RUS of other proportions
//    (tangential shafts at ψ = −15°, 15°, 105°, 135°, 225°, 255° on r = 200 mm,
//    crank 80 mm, rod 300 mm, spheres on r = 100 mm at φ = −45°, 45°, 75°,
//    165°, 195°, 285°, home z = 240 mm with θ ≈ 0.188 rad, limits ±0.9 rad).
//    kincal knows it only through a robot description file. Its pose box is
//    |x|, |y| ≤ 25 mm, z 220…260 mm, |rx|, |ry|, |rz| ≤ 0.08 rad: with ±30 mm
//    in x, y the corners need q = 0.912 rad (past the limit; the closed form
//    agrees) and −0.8995 rad; at ±25 mm q spans −0.770…0.847 rad.
//
// What it does differently from kincal's model (core/rus6.hpp; identify's
// rus6_error_model.hpp: per leg a shaft point + axis, a crank-zero direction,
// crank and rod lengths, a platform sphere and an encoder offset, closure
// |R·p_i + t − C_i(θ_i)| = ℓ_i solved in closed form):
//  - Each motor is a rigid MOTOR FRAME M_i (x = crank zero, y = axis × zero,
//    z = shaft axis, origin on the shaft), and its errors are a small rotation
//    vector and a translation of that frame, both in motor-frame coordinates:
//    M_i' = M_i · (exp(w_i), d_i). Not s, a, z perturbed one by one.
//  - The crank is a rigid link turned about the motor frame's local z:
//    crank frame = M_i' · Rot(z, θ_i). The rod's lower sphere (crank pin) is a
//    point of the crank, (c + δx, δy, δz) in crank coordinates: δx lengthens
//    the crank, δy puts the pin ahead of the crank line, δz puts it beside the
//    crank's plane along the shaft. The tip is found by composing frames.
//  - The rod is a rigid link: its two sphere centres are ℓ_i + δℓ_i apart;
//    the platform sphere is p_i + δp_i (platform frame).
//  - The MEASURED frame is a tool frame on the platform with its own 6-DOF
//    offset (nominal: the platform frame); poses and targets are of it.
//  - Each leg's IK is its own 1-D solve: a scan of g(θ) = |S − C(θ)| − ℓ over
//    one turn about mid-range for the crossing where g falls (the crank tip
//    approaches the sphere as θ grows: lever λ = −dg/dθ > 0, the rod above
//    the crank, the branch continuous with home), then bisection to the last
//    bit. No closed form, no branch sign.
//  - FK is damped Newton on the platform pose with a CENTRAL-DIFFERENCE
//    Jacobian of the six closure residuals, each step applied as
//    (t + v, exp(ω)·R) with Eigen::AngleAxisd.
//
// Only Eigen and core's Pose<double> (exchange type / CSV convention) are
// used. Conventions kept from kincal so its tools read the data: poses are
// (x, y, z, rx, ry, rz) of the platform/tool frame in the base frame (mm,
// rad), R = Rz(rz)·Ry(ry)·Rx(rx); θ turns right-handed about the shaft axis;
// the physical crank angle is the command plus the encoder offset,
// θ_i = q_i + encoder_i; joint limits bound the COMMANDS q.
//
// Hidden physical effects (Rus6Effects; all zero = off, the default, and then
// fk(q, inputs) is bit for bit fk(q): the effect code runs and adds exact
// zeros). The physical angle and rod length the mechanism has for command q_i
// at temperature T (°C) and approach direction dir_i (±1):
//   (a) backlash      θ_i = q_i + encoder_i + b_i·dir_i  (+ (d), then (b))
//                     dir_i = sign of the change of q_i from the previous row,
//                     +1 on the first row, kept while the joint stands still.
//   (c) rod thermal   ℓ_i(T) = (ℓ_i + δℓ_i)·(1 + α·(T − 20)), the rods only
//                     (kincal's `thermal` scales the WHOLE structure).
//   (d) encoder drift OUTSIDE kincal's library: the encoder zero of a motor
//                     drifts with the structure temperature,
//                     θ_i += d_i·(T − 20), d_i rad/°C per motor (e.g. only
//                     motors 1, 3, 5 — one motor type of two). As a kincal
//                     formula effect: kind "joint", joints [1, 3, 5],
//                     per_joint ["d"], formula "d * (temp - 20)". Exact (it
//                     does not depend on q).
//   (b) compliance    θ_i += k_i·τ_i, τ_i the load torque on motor i (N·mm,
//                     positive: it turns the crank towards +θ) of a payload of
//                     weight W (N) along −z of the base frame at a centre of
//                     mass on the platform (platform frame), by virtual work
//                     τ_i = F·∂p_com/∂θ_i with ∂p_com/∂θ_i by central
//                     differences (h = 1e-6 rad) of THIS machine's FK (actual
//                     geometry, rods at T) at the undeflected angles above.
//                     Linear in W. kincal's `compliance` (Δq = k·τ) is the
//                     same law with τ from its NOMINAL Jacobian at the
//                     commanded pose (and a unit weight at the platform origin
//                     unless the description's `payload` says otherwise).
#pragma once

#include <algorithm>
#include <limits>

#include "independent_common.hpp"

namespace kincal::independent {

// ------------------------------------------------------------------ nominal machines

// A nominal 6-RUS: the quantities of a kincal rus6 robot description.
struct Rus6Nominal {
  std::string name;
  std::array<V3, 6> shaft_point = zero_vectors();     // mm, base frame: a point on motor i's shaft line (the crank circle's centre)
  std::array<V3, 6> shaft_axis = zero_vectors();      // unit; θ turns right-handed about it
  std::array<V3, 6> crank_zero = zero_vectors();      // unit ⟂ axis: the crank at θ = 0
  std::array<double, 6> crank_length{};  // mm
  std::array<double, 6> rod_length{};    // mm, sphere to sphere
  std::array<V3, 6> platform_joint = zero_vectors();  // mm, platform frame: rod-end sphere centres
  V6 home = V6::Zero();                // x..rz of the home pose
  V6 min_command = V6::Zero(), max_command = V6::Zero();    // rad: joint limits on q
  V6 workspace_min = V6::Zero(), workspace_max = V6::Zero();  // box of commanded poses (absolute x..rz)
  std::vector<V3> targets;             // default tracker targets, platform (tool) frame, mm
};

// kincal's built-in `rus6-ref` (docs/reference-machines.md "rus6-ref").
inline Rus6Nominal rus6_ref_nominal() {
  const double deg = kPi / 180.0;
  Rus6Nominal n;
  n.name = "rus6-ref";
  for (int pair = 0; pair < 3; ++pair) {
    for (int side = 0; side < 2; ++side) {
      const std::size_t i = std::size_t(2 * pair + side);
      const double sign = side == 0 ? -1.0 : 1.0;
      const double az = (120.0 * pair + sign * 25.0) * deg;
      const V3 r(std::cos(az), std::sin(az), 0.0), t(-std::sin(az), std::cos(az), 0.0);
      n.shaft_point[i] = 200.0 * r;
      n.shaft_axis[i] = sign * r;   // radial
      n.crank_zero[i] = sign * t;   // tangential, away from the pair's other motor: axis × zero = +z
      n.platform_joint[i] = 130.0 * r;
      n.crank_length[i] = 100.0;
      n.rod_length[i] = 300.0;
    }
  }
  // Home: every crank horizontal (θ = 0); the rod's horizontal run h from the
  // crank tip to its sphere, z = √(ℓ² − h²) (the same for all six legs).
  const V3 run = n.platform_joint[0] - (n.shaft_point[0] + n.crank_length[0] * n.crank_zero[0]);
  n.home << 0, 0, std::sqrt(300.0 * 300.0 - run.squaredNorm()), 0, 0, 0;
  n.min_command.setConstant(-80.0 * deg);
  n.max_command.setConstant(70.0 * deg);
  V6 half;
  half << 40, 40, 40, 10 * deg, 10 * deg, 10 * deg;
  n.workspace_min = n.home - half;
  n.workspace_max = n.home + half;
  for (double a : {90.0, 210.0, 330.0}) n.targets.emplace_back(80.0 * std::cos(a * deg), 80.0 * std::sin(a * deg), 40.0);
  return n;
}

// The tangential-shaft 6-RUS (header comment).
inline Rus6Nominal rus6_tangential_nominal() {
  const double deg = kPi / 180.0;
  const double psi[6] = {-15, 15, 105, 135, 225, 255};
  const double phi[6] = {-45, 45, 75, 165, 195, 285};
  Rus6Nominal n;
  n.name = "rus6-tangential";
  for (std::size_t i = 0; i < 6; ++i) {
    const double a = psi[i] * deg, b = phi[i] * deg;
    n.shaft_point[i] = V3(200.0 * std::cos(a), 200.0 * std::sin(a), 0.0);
    n.shaft_axis[i] = V3(std::sin(a), -std::cos(a), 0.0);
    n.crank_zero[i] = V3(std::cos(a), std::sin(a), 0.0);  // radially outward; axis × zero = +z
    n.platform_joint[i] = V3(100.0 * std::cos(b), 100.0 * std::sin(b), 0.0);
    n.crank_length[i] = 80.0;
    n.rod_length[i] = 300.0;
  }
  n.home << 0, 0, 240, 0, 0, 0;
  n.min_command.setConstant(-0.9);
  n.max_command.setConstant(0.9);
  n.workspace_min << -25, -25, 220, -0.08, -0.08, -0.08;  // ±30 mm in x, y reaches q = 0.912 (header)
  n.workspace_max << 25, 25, 260, 0.08, 0.08, 0.08;
  for (double a : {90.0, 210.0, 330.0}) n.targets.emplace_back(60.0 * std::cos(a * deg), 60.0 * std::sin(a * deg), 30.0);
  return n;
}

// ------------------------------------------------------------------ errors

// All fields zero = the nominal machine.
struct Rus6Errors {
  std::array<V3, 6> motor_rotation = zero_vectors();     // rad: rotation vector of motor frame i, motor-frame coordinates
                                          //      (x crank zero, y axis × zero, z shaft axis; z = an encoder-like turn)
  std::array<V3, 6> motor_translation = zero_vectors();  // mm: motor frame i moved, motor-frame coordinates
  std::array<V3, 6> crank_pin = zero_vectors();          // mm: crank pin (rod's lower sphere) moved, crank-frame coordinates
                                          //     (x along the crank: length, y ahead of it, z along the shaft)
  std::array<double, 6> rod{};            // mm: rod length error
  std::array<V3, 6> platform_sphere = zero_vectors();    // mm: rod's upper sphere moved, platform frame
  std::array<double, 6> encoder{};        // rad: θ = q + this
  V3 tool_point = V3::Zero();             // mm: measured frame's origin, platform frame
  V3 tool_rotation = V3::Zero();          // rad: measured frame's orientation on the platform (rotation vector)

  Rus6Errors() {
    for (auto* a : {&motor_rotation, &motor_translation, &crank_pin, &platform_sphere})
      for (auto& v : *a) v.setZero();
  }

  // Groups for fill_group (length scale for mm, angle scale for rad):
  //   motor_frames      motor frame rotations (18 rad) and translations (18 mm)
  //   crank_pins        crank pins (18 mm)
  //   rods              rod lengths (6 mm)
  //   platform_spheres  platform spheres (18 mm)
  //   encoder_offsets   encoders (6 rad)
  //   tool              measured frame on the platform (3 mm, 3 rad)
  static std::vector<std::string> group_names() {
    return {"motor_frames", "crank_pins", "rods", "platform_spheres", "encoder_offsets", "tool"};
  }
};

// Uniform values in [−length, length] mm and [−angle, angle] rad for every
// parameter of `group`. Throws std::invalid_argument on an unknown group.
inline void fill_group(Rus6Errors& e, const std::string& group, double length, double angle, std::mt19937_64& rng) {
  auto L3 = [&] { return V3(uniform(rng, length), uniform(rng, length), uniform(rng, length)); };
  auto A3 = [&] { return V3(uniform(rng, angle), uniform(rng, angle), uniform(rng, angle)); };
  if (group == "motor_frames") {
    for (auto& w : e.motor_rotation) w = A3();
    for (auto& d : e.motor_translation) d = L3();
  } else if (group == "crank_pins") {
    for (auto& c : e.crank_pin) c = L3();
  } else if (group == "rods") {
    for (auto& r : e.rod) r = uniform(rng, length);
  } else if (group == "platform_spheres") {
    for (auto& p : e.platform_sphere) p = L3();
  } else if (group == "encoder_offsets") {
    for (auto& v : e.encoder) v = uniform(rng, angle);
  } else if (group == "tool") {
    e.tool_point = L3();
    e.tool_rotation = A3();
  } else {
    throw std::invalid_argument("unknown 6-RUS error group '" + group + "'");
  }
}

// Every group listed (default: all) at the given scales, from one seed.
inline Rus6Errors random_rus6_errors(double length, double angle, std::uint64_t seed,
                                     const std::vector<std::string>& groups = Rus6Errors::group_names()) {
  Rus6Errors e;
  std::mt19937_64 rng(seed);
  for (const auto& g : groups) fill_group(e, g, length, angle, rng);
  return e;
}

// ------------------------------------------------------------------ effects

// Hidden physical effects (header comment). All zero = off (the default).
struct Rus6Effects {
  std::array<double, 6> backlash{0, 0, 0, 0, 0, 0};       // (a) b_i, rad: θ += b_i·dir_i
  std::array<double, 6> compliance{0, 0, 0, 0, 0, 0};     // (b) k_i, rad per N·mm: θ += k_i·τ_i
  double payload_weight = 1;                              // (b) W, N, along −z of the base frame
  V3 payload_com = V3::Zero();                            // (b) mm, platform frame
  double rod_thermal = 0;                                 // (c) α, 1/°C: rods × (1 + α·(T − 20))
  std::array<double, 6> encoder_drift{0, 0, 0, 0, 0, 0};  // (d) d_i, rad/°C: θ += d_i·(T − 20)

  static bool any_of(const std::array<double, 6>& a) {
    for (double v : a)
      if (v != 0) return true;
    return false;
  }
  bool any_backlash() const { return any_of(backlash); }
  bool any_compliance() const { return any_of(compliance); }
  bool any_temperature() const { return rod_thermal != 0 || any_of(encoder_drift); }
  bool any() const { return any_backlash() || any_compliance() || any_temperature(); }
};

// What the effects need besides the commands.
struct Rus6Inputs {
  double temp = 20;       // structure temperature, °C
  V6 dir = V6::Ones();    // approach direction of each joint, ±1
};

// ------------------------------------------------------------------ results

struct Rus6FkResult {
  bool ok = false;
  std::string why;         // empty when ok
  Pose<double> pose;       // measured (tool) frame in the base frame
  Pose<double> platform;   // platform frame in the base frame
  V6 theta = V6::Zero();   // physical crank angles used, rad
  V6 rods = V6::Zero();    // rod lengths used, mm
  V6 levers = V6::Zero();  // λ_i = u_i·(a_i × (C_i − o_i)), mm (> 0 on the home branch)
  double closure = 0;      // max | |S_i − C_i| − ℓ_i |, mm
  int iterations = 0;
};

struct Rus6IkResult {
  bool ok = false;         // solved and inside the limits
  bool solved = false;     // every leg closed (limits not yet looked at)
  std::string why;         // empty when ok
  int limit_joint = -1;    // first joint (0-based) whose command is past its limits, −1: none
  V6 q = V6::Zero();       // commands (filled when solved, also when past the limits)
  V6 theta = V6::Zero();   // physical angles
  double closure = 0;      // max |g_i(θ_i)|, mm
};

// ------------------------------------------------------------------ simulator

class Rus6Simulator {
 public:
  explicit Rus6Simulator(const Rus6Nominal& nominal, const Rus6Errors& e = Rus6Errors{},
                         const Rus6Effects& fx = Rus6Effects{})
      : nominal_(nominal), errors_(e), effects_(fx) {
    for (std::size_t i = 0; i < 6; ++i) {
      const V3 a = nominal.shaft_axis[i].normalized();
      const V3 x = nominal.crank_zero[i].normalized();
      Rigid M;
      M.R.col(0) = x;
      M.R.col(1) = a.cross(x);
      M.R.col(2) = a;
      M.p = nominal.shaft_point[i];
      motor_[i] = M * Rigid{rotation_vector(e.motor_rotation[i]), e.motor_translation[i]};
      pin_[i] = V3(nominal.crank_length[i], 0, 0) + e.crank_pin[i];
      rod_[i] = nominal.rod_length[i] + e.rod[i];
      sphere_[i] = nominal.platform_joint[i] + e.platform_sphere[i];
    }
    tool_ = Rigid{rotation_vector(e.tool_rotation), e.tool_point};
    home_ = to_rigid(Pose<double>::from_xyz_rpy(nominal.home));
  }

  const Rus6Nominal& nominal() const { return nominal_; }
  const Rus6Errors& errors() const { return errors_; }
  const Rus6Effects& effects() const { return effects_; }
  const Rigid& motor_frame(int i) const { return motor_[std::size_t(i)]; }
  V3 platform_sphere(int i) const { return sphere_[std::size_t(i)]; }
  double rod_length(int i, double temp = 20) const {
    return rod_[std::size_t(i)] * (1.0 + effects_.rod_thermal * (temp - 20.0));
  }
  const Rigid& tool() const { return tool_; }

  // Crank tip (rod's lower sphere centre) of leg i at physical angle θ, base
  // frame: motor frame · Rot(local z, θ) · pin.
  V3 crank_tip(int i, double theta) const {
    const Rigid crank = motor_[std::size_t(i)] * Rigid{rotation_about(V3::UnitZ(), theta), V3::Zero()};
    return crank * pin_[std::size_t(i)];
  }

  // g_i = |S_i − C_i(θ)| − ℓ_i for the platform at X.
  double closure(int i, const Rigid& X, double theta, double rod) const {
    return (X * sphere_[std::size_t(i)] - crank_tip(i, theta)).norm() - rod;
  }

  // λ_i: the rate at which the crank tip approaches the sphere per unit θ.
  double lever(int i, const Rigid& X, double theta) const {
    const Rigid& M = motor_[std::size_t(i)];
    const V3 C = crank_tip(i, theta);
    const V3 u = (X * sphere_[std::size_t(i)] - C).normalized();
    return u.dot(M.R.col(2).cross(C - M.p));
  }

  // ---- IK (no effects; a nominal simulator gives the controller's IK) -----

  // Leg i's physical angle for sphere point S (base frame), rod length `rod`:
  // the falling crossing of g(θ) = |S − C(θ)| − rod nearest mid-range (one
  // turn scanned in 0.02 rad steps), bisected to the last bit. NaN if the rod
  // cannot reach the crank circle.
  double solve_leg(int i, const V3& S, double rod) const {
    const std::size_t k = std::size_t(i);
    const double mid = 0.5 * (nominal_.min_command(i) + nominal_.max_command(i)) + errors_.encoder[k];
    auto g = [&](double t) { return (S - crank_tip(i, t)).norm() - rod; };
    const int steps = 315;  // 2π / 0.02
    const double h = 2.0 * kPi / steps;
    double best_a = std::nan(""), best_distance = 1e300;
    double a = mid - kPi, ga = g(a);
    for (int s = 1; s <= steps; ++s) {
      const double b = mid - kPi + s * h, gb = g(b);
      if (ga > 0 && gb <= 0) {
        const double d = std::abs(0.5 * (a + b) - mid);
        if (d < best_distance) {
          best_distance = d;
          best_a = a;
        }
      }
      a = b;
      ga = gb;
    }
    if (!std::isfinite(best_a)) return std::nan("");
    double lo = best_a, hi = best_a + h;  // g(lo) > 0 ≥ g(hi)
    for (int it = 0; it < 200; ++it) {
      const double m = 0.5 * (lo + hi);
      if (m <= lo || m >= hi) break;
      (g(m) > 0 ? lo : hi) = m;
    }
    return std::abs(g(lo)) < std::abs(g(hi)) ? lo : hi;
  }

  // Commands for the measured (tool) frame at `tool`, rods at `temp`: every
  // leg solved, then the limits checked (a command past them is reported in
  // `why` / `limit_joint`, never returned as ok).
  Rus6IkResult ik_detail(const Pose<double>& tool, double temp = 20) const {
    Rus6IkResult out;
    if (!tool.finite()) {
      out.why = "non-finite pose";
      return out;
    }
    const Rigid X = to_rigid(tool) * tool_.inverse();
    for (int i = 0; i < 6; ++i) {
      const double rod = rod_length(i, temp);
      const double t = solve_leg(i, X * sphere_[std::size_t(i)], rod);
      if (!std::isfinite(t)) {
        out.why = "leg " + std::to_string(i + 1) + " cannot close (the rod does not reach its crank circle)";
        return out;
      }
      out.theta(i) = t;
      out.q(i) = t - errors_.encoder[std::size_t(i)];
      out.closure = std::max(out.closure, std::abs(closure(i, X, t, rod)));
    }
    out.solved = true;
    out.why = limits_violation(out.q, &out.limit_joint);
    out.ok = out.why.empty();
    return out;
  }

  // The interface independent_common's make_dataset_by expects.
  bool ik(const Pose<double>& tool, V6& q) const {
    const Rus6IkResult r = ik_detail(tool);
    if (r.ok) q = r.q;
    return r.ok;
  }

  // "" if every command is inside [min_command, max_command], else which is not.
  std::string limits_violation(const V6& q, int* joint = nullptr) const {
    for (int i = 0; i < 6; ++i) {
      if (!(q(i) >= nominal_.min_command(i) && q(i) <= nominal_.max_command(i))) {
        if (joint != nullptr) *joint = i;
        return "joint " + std::to_string(i + 1) + " command " + csv_number(q(i)) + " rad past its limits [" +
               csv_number(nominal_.min_command(i)) + ", " + csv_number(nominal_.max_command(i)) + "]";
      }
    }
    if (joint != nullptr) *joint = -1;
    return "";
  }

  // ---- FK ------------------------------------------------------------------

  // FK from PHYSICAL angles θ with the rods at `temp` (no limit check): damped
  // Newton on the platform pose from `guess` (home by default), Jacobian of
  // the six closures by central differences (1e-5 mm, 1e-7 rad), until every
  // closure is below 1e-12 mm (or stops falling below 1e-10 mm).
  Rus6FkResult fk_angles(const V6& theta, double temp = 20, const Pose<double>* guess = nullptr) const {
    Rus6FkResult out;
    out.theta = theta;
    if (!theta.allFinite() || !std::isfinite(temp)) {
      out.why = "non-finite input";
      return out;
    }
    std::array<V3, 6> tips;
    for (int i = 0; i < 6; ++i) {
      tips[std::size_t(i)] = crank_tip(i, theta(i));
      out.rods(i) = rod_length(i, temp);
    }
    auto residual = [&](const Rigid& X) {
      V6 r;
      for (int i = 0; i < 6; ++i) r(i) = (X * sphere_[std::size_t(i)] - tips[std::size_t(i)]).norm() - out.rods(i);
      return r;
    };
    auto moved = [](const Rigid& X, const V6& s) {
      return Rigid{rotation_vector(s.tail<3>()) * X.R, X.p + s.head<3>()};
    };
    Rigid X = guess != nullptr ? to_rigid(*guess) * tool_.inverse() : home_;
    V6 r = residual(X);
    double best = r.cwiseAbs().maxCoeff();
    for (int it = 0; it < 100; ++it) {
      out.iterations = it;
      if (!std::isfinite(best)) break;
      if (best < 1e-12) break;
      M6 J;
      for (int k = 0; k < 6; ++k) {
        const double h = k < 3 ? 1e-5 : 1e-7;
        V6 s = V6::Zero();
        s(k) = h;
        J.col(k) = (residual(moved(X, s)) - residual(moved(X, -s))) / (2 * h);
      }
      V6 step = -J.fullPivLu().solve(r);
      if (!step.allFinite()) break;
      // Keep far starts on the assembly continuous with the guess.
      const double big = std::max(step.head<3>().cwiseAbs().maxCoeff() / 20.0, step.tail<3>().cwiseAbs().maxCoeff() / 0.2);
      if (big > 1) step /= big;
      bool improved = false;
      for (int halving = 0; halving < 30; ++halving) {
        const Rigid Y = moved(X, step);
        const V6 rY = residual(Y);
        const double m = rY.cwiseAbs().maxCoeff();
        if (m < best) {
          X = Y;
          r = rY;
          best = m;
          improved = true;
          break;
        }
        step *= 0.5;
      }
      if (!improved) break;  // the rounding floor (or a stall)
    }
    out.closure = best;
    out.ok = best < 1e-10;
    if (!out.ok) {
      out.why = "FK did not converge (closure " + csv_number(best) + " mm)";
      return out;
    }
    for (int i = 0; i < 6; ++i) out.levers(i) = lever(i, X, theta(i));
    out.platform = to_pose(X);
    out.pose = to_pose(X * tool_);
    return out;
  }

  // FK of the effect-free machine for commands q (θ = q + encoder), at 20 °C.
  // Commands past the limits are refused (ok = false, `why` says which).
  Rus6FkResult fk(const V6& q, const Pose<double>* guess = nullptr) const {
    const std::string bad = limits_violation(q);
    if (!bad.empty()) {
      Rus6FkResult out;
      out.why = bad;
      return out;
    }
    return fk_angles(q + encoder(), 20.0, guess);
  }

  // FK with the effects: the pose reached for commands q at `in`.
  Rus6FkResult fk(const V6& q, const Rus6Inputs& in, const Pose<double>* guess = nullptr) const {
    const std::string bad = limits_violation(q);
    if (!bad.empty()) {
      Rus6FkResult out;
      out.why = bad;
      return out;
    }
    V6 theta = physical_angles(q, in, nullptr, guess);
    if (!theta.allFinite()) {
      Rus6FkResult out;
      out.why = "static load: FK failed";
      return out;
    }
    return fk_angles(theta, in.temp, guess);
  }

  // The physical angles for commands q at `in` (header comment: (a), (d), then
  // (b) at those). `torques` (optional) receives τ (zero without compliance).
  V6 physical_angles(const V6& q, const Rus6Inputs& in, V6* torques = nullptr,
                     const Pose<double>* guess = nullptr) const {
    const Rus6Effects& fx = effects_;
    V6 theta;
    for (int i = 0; i < 6; ++i) {
      const std::size_t k = std::size_t(i);
      theta(i) = q(i) + errors_.encoder[k];
      theta(i) += fx.backlash[k] * (in.dir(i) < 0 ? -1.0 : 1.0);
      theta(i) += fx.encoder_drift[k] * (in.temp - 20.0);
    }
    if (torques != nullptr) torques->setZero();
    if (fx.any_compliance()) {
      const V6 tau = motor_torques(theta, in.temp, guess);
      if (!tau.allFinite()) return V6::Constant(std::nan(""));
      for (int i = 0; i < 6; ++i) theta(i) += fx.compliance[std::size_t(i)] * tau(i);
      if (torques != nullptr) *torques = tau;
    }
    return theta;
  }

  // Load torque τ_i (N·mm) of the payload on each motor at physical angles θ,
  // rods at `temp`: τ_i = F·∂p_com/∂θ_i, F = (0, 0, −W), by central
  // differences (h = 1e-6 rad) of fk_angles, each started at the FK at θ.
  // NaN if an FK fails.
  V6 motor_torques(const V6& theta, double temp = 20, const Pose<double>* guess = nullptr) const {
    const Rus6FkResult r0 = fk_angles(theta, temp, guess);
    if (!r0.ok) return V6::Constant(std::nan(""));
    const V3 F(0, 0, -effects_.payload_weight);
    const double h = 1e-6;
    V6 tau;
    for (int j = 0; j < 6; ++j) {
      V6 a = theta, b = theta;
      a(j) += h;
      b(j) -= h;
      const Rus6FkResult ra = fk_angles(a, temp, &r0.pose), rb = fk_angles(b, temp, &r0.pose);
      if (!ra.ok || !rb.ok) return V6::Constant(std::nan(""));
      const V3 dp =
          (ra.platform.transform(effects_.payload_com) - rb.platform.transform(effects_.payload_com)) / (2 * h);
      tau(j) = F.dot(dp);
    }
    return tau;
  }

  V6 encoder() const {
    V6 e;
    for (int i = 0; i < 6; ++i) e(i) = errors_.encoder[std::size_t(i)];
    return e;
  }

 private:
  Rus6Nominal nominal_;
  Rus6Errors errors_;
  Rus6Effects effects_;
  std::array<Rigid, 6> motor_;
  std::array<V3, 6> pin_;        // crank pin, crank frame
  std::array<double, 6> rod_{};  // rod lengths at 20 °C
  std::array<V3, 6> sphere_;     // platform spheres, platform frame
  Rigid tool_;
  Rigid home_;                   // platform at the nominal home pose
};

// ------------------------------------------------------------------ poses, temperatures, measurement

// `count` poses uniform in the nominal's workspace box, from one seed.
inline std::vector<V6> rus6_random_poses(const Rus6Nominal& n, int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<V6> out;
  for (int k = 0; k < count; ++k) {
    V6 v;
    for (int j = 0; j < 6; ++j)
      v(j) = std::uniform_real_distribution<double>(n.workspace_min(j), n.workspace_max(j))(rng);
    out.push_back(v);
  }
  return out;
}

// A grid over the workspace box: counts[j] evenly spaced values of pose
// component j from workspace_min to workspace_max (1: the home value),
// x varying fastest. counts {2, 2, 2, 2, 2, 2} gives the 64 corners.
inline std::vector<V6> rus6_grid_poses(const Rus6Nominal& n, const std::array<int, 6>& counts) {
  std::vector<V6> out;
  std::array<int, 6> idx{0, 0, 0, 0, 0, 0};
  for (int c : counts)
    if (c < 1) throw std::invalid_argument("grid counts must be at least 1");
  while (true) {
    V6 v;
    for (int j = 0; j < 6; ++j) {
      const int c = counts[std::size_t(j)];
      v(j) = c == 1 ? n.home(j)
                    : n.workspace_min(j) + (n.workspace_max(j) - n.workspace_min(j)) * idx[std::size_t(j)] / (c - 1);
    }
    out.push_back(v);
    int j = 0;
    while (j < 6 && ++idx[std::size_t(j)] == counts[std::size_t(j)]) idx[std::size_t(j++)] = 0;
    if (j == 6) break;
  }
  return out;
}

// One temperature per row, uniform in [lo, hi] °C, from one seed.
inline std::vector<double> rus6_random_temperatures(std::size_t count, double lo, double hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<double> t(count);
  for (double& v : t) v = std::uniform_real_distribution<double>(lo, hi)(rng);
  return t;
}

// A MeasurementSpec with the noise in µm and µrad: full poses when `targets`
// is empty, else those targets (tool frame, mm) seen from `instrument_from_base`.
inline MeasurementSpec rus6_measurement(double sigma_um, double sigma_urad, std::uint64_t seed,
                                        const std::vector<V3>& targets = {},
                                        const Pose<double>& instrument_from_base = Pose<double>()) {
  MeasurementSpec s;
  s.targets = targets;
  s.instrument_from_base = instrument_from_base;
  s.sigma_mm = sigma_um * 1e-3;
  s.sigma_rad = sigma_urad * 1e-6;
  s.seed = seed;
  return s;
}

// ------------------------------------------------------------------ datasets

// A gross error: the row of commanded pose `pose_index` is measured displaced
// by `displacement` (mm, base frame): the measured pose's position and every
// target move by it (targets: turned into the instrument frame).
struct Rus6Blunder {
  std::size_t pose_index = 0;
  V3 displacement = V3::Zero();
};

struct Rus6DatasetOptions {
  std::vector<double> temps;          // °C per commanded pose (empty: 20 °C, no `temp` column)
  std::vector<std::string> roles;     // per commanded pose (empty: cal, no `role` column)
  std::vector<Rus6Blunder> blunders;
  bool write_dir = false;             // dir1..dir6 even without backlash (always with it)
};

// Dataset of the machine `errors` + `effects`, commanded in motion order by
// the NOMINAL machine's IK (controller at 20 °C). Poses whose nominal commands
// are past the limits, or whose actual FK fails, are listed in `skipped`
// ("index: why") and left out; the approach directions follow the commands
// actually sent (+1 on the first, kept while a joint stands still). Row ids
// "n<index + 1>". Columns: id, x..rz, [mx..mrz], [t1x..], [q1..q6], [role],
// [temp], [dir1..dir6]. Noise from spec.seed as make_dataset draws it.
inline Dataset make_rus6_dataset(const Rus6Nominal& nominal, const Rus6Errors& errors, const Rus6Effects& effects,
                                 const std::vector<V6>& commanded, const MeasurementSpec& spec,
                                 const Rus6DatasetOptions& options = {}) {
  if (spec.targets.size() > 3) throw std::invalid_argument("at most three targets");
  if (!options.temps.empty() && options.temps.size() != commanded.size())
    throw std::invalid_argument("one temperature per pose");
  if (!options.roles.empty() && options.roles.size() != commanded.size())
    throw std::invalid_argument("one role per pose");
  if (effects.any_temperature() && options.temps.empty())
    throw std::invalid_argument("a temperature effect is on but no temperatures were given");
  const Rus6Simulator actual(nominal, errors, effects), controller(nominal);
  Dataset out;
  out.target_count = int(spec.targets.size());
  out.has_measured = spec.targets.empty() || spec.pose_and_targets;
  out.has_q = spec.write_q;
  out.has_role = !options.roles.empty();
  out.has_temp = !options.temps.empty();
  out.has_dir = options.write_dir || effects.any_backlash();
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  auto noise = [&](double sigma) { return sigma > 0 ? sigma * unit(rng) : 0.0; };
  V6 previous = V6::Zero(), dir = V6::Ones();
  bool first = true;
  for (std::size_t i = 0; i < commanded.size(); ++i) {
    DatasetRow row;
    row.id = "n" + std::to_string(i + 1);
    row.commanded = commanded[i];
    const Rus6IkResult cmd = controller.ik_detail(Pose<double>::from_xyz_rpy(commanded[i]));
    if (!cmd.ok) {
      out.skipped.push_back(std::to_string(i) + ": nominal IK: " + cmd.why);
      continue;
    }
    row.q = cmd.q;
    if (!first)
      for (int j = 0; j < 6; ++j)
        if (row.q(j) != previous(j)) dir(j) = row.q(j) > previous(j) ? 1.0 : -1.0;
    first = false;
    previous = row.q;
    Rus6Inputs in;
    in.dir = dir;
    if (!options.temps.empty()) in.temp = options.temps[i];
    row.temp = in.temp;
    row.dir = dir;
    if (!options.roles.empty()) row.role = options.roles[i];
    const Pose<double> start = Pose<double>::from_xyz_rpy(commanded[i]);
    const Rus6FkResult reached = actual.fk(row.q, in, &start);
    if (!reached.ok) {
      out.skipped.push_back(std::to_string(i) + ": actual FK: " + reached.why);
      continue;
    }
    Pose<double> seen = reached.pose;
    for (const Rus6Blunder& b : options.blunders)
      if (b.pose_index == i) seen.p += b.displacement;
    measure_row(row, seen, spec, out.has_measured, noise);
    row.actual = reached.pose;
    out.rows.push_back(row);
  }
  return out;
}

}  // namespace kincal::independent
