// Independent simulator of `stewart-seed001` (seed 001's 6-UPS platform,
// Table 2 geometry), for testing kincal's identification on data its own
// model did not make.
//
// What it does differently from kincal's model (core/stewart.hpp, seed 001's
// 42-parameter B_i, P_i, l_i model and identify's StewartErrorModel):
//  - Each leg is a real U-P-S chain: two U revolutes through the base U centre
//    (axes t_i = u_i × z / |u_i × z| and n_i = u_i × t_i, u_i the leg direction
//    at home), a prismatic whose line may pass BESIDE the U centre (leg
//    offset), a sphere centre on it. The leg's physical value x_i is found by
//    its own 3-unknown Newton closure (U angles, x), so with a leg offset o_i
//    the leg is not a distance: x_i = √(|S_i − B_i|² − |o_i|²).
//  - FK is Newton on the platform pose with row i = (∂x_i/∂S_i)ᵀ·[I, −[S_i − p]×]
//    taken from the leg's closure Jacobian, each step applied as
//    (p + v, exp(ω)·R) with Eigen's AngleAxis.
//  - The measured frame is a tool frame on the platform with its own 6-DOF
//    offset (nominal: the platform frame), which seed 001's model lacks.
//
// Only Eigen and core's Pose<double> (exchange type / CSV convention) are
// used; the numbers of make_stewart_seed001() are re-entered here.
//
// Conventions kept from kincal: poses are (x, y, z, rx, ry, rz) of the
// platform / tool frame in the base frame, R = Rz(rz)·Ry(ry)·Rx(rx); the
// physical leg value is the command plus the encoder offset (core's
// length_offset sign; nominal 0), x = q + encoder.
//
// Hidden physical effects (StewartEffects, issue #32; all zero = off, the
// default, and then everything is bit for bit the effect-free machine). None
// of them is one of kincal's built-in effects (core/effects.hpp: its
// `thermal` is ONE coefficient scaling the whole structure, its `compliance`
// a deflection LINEAR in the load, its `scale` linear in q, its `backlash`
// following the approach direction); a user has to write them as formulas in
// the robot description ("Effects written as formulas" in the guide):
//  - leg thermal: leg i alone expands, its physical value (q_i + encoder_i)
//    × (1 + α_i·(T − 20 °C)), one α_i per leg (e.g. legs of two materials);
//    formula `a * q * (temp - 20)` over those joints. The simulator scales
//    q + encoder, the formula q: they differ by α·encoder·ΔT (~1e-6 µm).
//  - ramp: a quadratic lead error in the upper stroke of each leg,
//    + g_i·max(0, q_i − knee_i)², q_i the COMMAND; formula
//    `g * max(0, q - q0)^2` (a shared knee q0 guessed by the user; here each
//    leg may have its own knee).
//  - clearance: play in a leg's joints taken up by the leg's static load,
//    + c_i·sign(τ_i) (c_i: half the total play, the shift from the middle of
//    it). τ_i is leg i's axial load under a payload of weight W along −z of
//    the base frame at a centre of mass given in the PLATFORM frame, by
//    virtual work τ_i = F·∂p_com/∂x_i with ∂p_com/∂x_i by central differences
//    of THIS machine's FK (actual, erroneous geometry) at the leg values the
//    other effects give (τ_i > 0: the weight pulls the leg longer, tension).
//    An off-centre or high centre of mass puts some legs in tension at some
//    poses, so the sign changes across the workspace. kincal's `load` (the
//    formula variable) is the same virtual-work load but from its NOMINAL
//    model's Jacobian at the commanded pose: the two differ by about the
//    geometry errors over the machine's size (~1e-3 relative), so the sign
//    agrees except for poses that close to a zero crossing. Formula
//    `c * sign(load)` with the robot description's `payload` set to the same
//    weight and centre of mass.
// They change the physical leg value the mechanism reaches for command q:
// x_i = q_i + encoder_i + Δ_i, Δ_i = α_i·ΔT·(q_i + encoder_i)
// + g_i·max(0, q_i − knee_i)² + c_i·sign(τ_i) (effective_joints: q + Δ).
#pragma once

#include "independent_common.hpp"

namespace kincal::independent {

// All fields zero = the nominal machine.
struct StewartErrors {
  std::array<V3, 6> base_centre{};       // mm: U centre displacement, base frame
  std::array<V3, 6> platform_centre{};   // mm: S centre displacement, platform frame
  std::array<std::array<double, 2>, 6> leg_offset{};  // mm: prismatic line beside the U centre, along (t_i, n_i)
  std::array<double, 6> encoder{};       // mm: physical x = q + this
  V3 tool_point = V3::Zero();            // mm: tool frame origin in the platform frame
  V3 tool_rotation = V3::Zero();         // rad: tool frame orientation on the platform (rotation vector)

  StewartErrors() {
    for (auto& v : base_centre) v.setZero();
    for (auto& v : platform_centre) v.setZero();
  }

  // Groups for fill_group:
  //   joint_centres    base U centres and platform S centres (36 mm)
  //   leg_offsets      prismatic lines beside the U centres (12 mm)
  //   encoder_offsets  leg encoders (6 mm)
  //   tool             tool frame on the platform (3 mm, 3 rad)
  static std::vector<std::string> group_names() { return {"joint_centres", "leg_offsets", "encoder_offsets", "tool"}; }
};

inline void fill_group(StewartErrors& e, const std::string& group, double length, double angle, std::mt19937_64& rng) {
  auto L = [&] { return uniform(rng, length); };
  if (group == "joint_centres") {
    for (auto& v : e.base_centre) v = V3(L(), L(), L());
    for (auto& v : e.platform_centre) v = V3(L(), L(), L());
  } else if (group == "leg_offsets") {
    for (auto& o : e.leg_offset) o = {L(), L()};
  } else if (group == "encoder_offsets") {
    for (auto& v : e.encoder) v = L();
  } else if (group == "tool") {
    e.tool_point = V3(L(), L(), L());
    e.tool_rotation = V3(uniform(rng, angle), uniform(rng, angle), uniform(rng, angle));
  } else {
    throw std::invalid_argument("unknown 6-UPS error group '" + group + "'");
  }
}

inline StewartErrors random_stewart_errors(double length, double angle, std::uint64_t seed,
                                           const std::vector<std::string>& groups = StewartErrors::group_names()) {
  StewartErrors e;
  std::mt19937_64 rng(seed);
  for (const auto& g : groups) fill_group(e, g, length, angle, rng);
  return e;
}

// ------------------------------------------------------------------ physical effects

// Hidden physical effects (header comment). All zero = off (the default).
// Legs i = 0..5 are the commands q1..q6.
struct StewartEffects {
  std::array<double, 6> thermal{0, 0, 0, 0, 0, 0};    // α_i, 1/°C: leg i's value × (1 + α_i·(T − 20 °C))
  std::array<double, 6> ramp_gain{0, 0, 0, 0, 0, 0};  // g_i, 1/mm: + g_i·max(0, q_i − knee_i)² (mm)
  std::array<double, 6> ramp_knee{0, 0, 0, 0, 0, 0};  // knee_i, mm (command)
  std::array<double, 6> clearance{0, 0, 0, 0, 0, 0};  // c_i, mm: + c_i·sign(τ_i)
  double payload_weight = 1;                          // W (any force unit; only sign(τ) is used), along −z of the base
  V3 payload_com = V3::Zero();                        // mm: centre of mass, platform frame
  bool any() const { return any_thermal() || any_ramp() || any_clearance(); }
  bool any_thermal() const {
    for (double a : thermal)
      if (a != 0) return true;
    return false;
  }
  bool any_ramp() const {
    for (double g : ramp_gain)
      if (g != 0) return true;
    return false;
  }
  bool any_clearance() const {
    for (double c : clearance)
      if (c != 0) return true;
    return false;
  }
};

// What the effects need besides the commands: the structure temperature, °C.
// (No approach directions: no effect here follows them.)
struct StewartInputs {
  double temp = 20;
};

struct StewartFkResult {
  bool ok = false;
  Pose<double> pose;      // tool frame in the base frame (= platform when the tool error is zero)
  Pose<double> platform;  // platform frame in the base frame
  V6 leg_values = V6::Zero();
  double closure = 0;      // max |x_i − (q_i + encoder_i)|, mm
  double leg_closure = 0;  // max |sphere centre − platform S point|, mm
  int iterations = 0;
};

class StewartSimulator {
 public:
  explicit StewartSimulator(const StewartErrors& e = StewartErrors{}, const StewartEffects& fx = StewartEffects{})
      : errors_(e), effects_(fx) {
    // Seed 001 Table 2 (mm), as in make_stewart_seed001().
    const double B[6][2] = {{120, -140},        {120, 140},          {61.243557, 173.92305},
                            {-181.24356, 33.92305}, {-181.24356, -33.92305}, {61.243557, -173.92305}};
    const double P[6][2] = {{120, -20},           {120, 20},             {-42.679489, 113.92304},
                            {-77.320511, 93.923042}, {-77.320511, -93.923042}, {-42.679489, -113.92304}};
    home_.p = V3(0, 0, 200);
    for (std::size_t i = 0; i < 6; ++i) {
      const V3 b(B[i][0], B[i][1], 0.0), p(P[i][0], P[i][1], 0.0);
      platform_point_[i] = p + e.platform_centre[i];
      UpsLegErrors le;
      le.base_centre = e.base_centre[i];
      le.leg_offset = e.leg_offset[i];
      legs_[i] = make_ups_leg(b, (home_ * p - b).normalized(), le);
    }
    tool_ = Rigid{rotation_vector(e.tool_rotation), e.tool_point};
  }

  const StewartErrors& errors() const { return errors_; }
  const StewartEffects& effects() const { return effects_; }
  const UpsLeg& leg(int i) const { return legs_[std::size_t(i)]; }
  V3 platform_point(int i) const { return platform_point_[std::size_t(i)]; }

  // FK of this machine: Newton on the platform pose from `guess` (home by
  // default) until every leg's x_i equals q_i + encoder_i to 1e-12 mm.
  StewartFkResult fk(const V6& q, const Pose<double>* guess = nullptr) const {
    StewartFkResult out;
    if (!q.allFinite()) return out;
    Rigid X = guess != nullptr ? to_rigid(*guess) : home_;
    std::array<V3, 6> warm;
    for (auto& w : warm) w = V3(0, 0, -1);
    double best = 1e300;
    for (int it = 0; it < 60; ++it) {
      M6 J;
      V6 r;
      double leg_closure = 0;
      for (std::size_t i = 0; i < 6; ++i) {
        const V3 S = X * platform_point_[i];
        const LegSolution sol = solve_leg(legs_[i], S, warm[i]);
        if (!sol.ok) return out;
        warm[i] = V3(sol.theta_a, sol.theta_b, sol.x);
        leg_closure = std::max(leg_closure, sol.closure);
        const Eigen::Index row = Eigen::Index(i);
        out.leg_values(row) = sol.x;
        r(row) = sol.x - (q(row) + errors_.encoder[i]);
        // S moves by v + ω × (S − p) for the twist (v at p, ω).
        J.block<1, 3>(row, 0) = sol.dx_dS.transpose();
        J.block<1, 3>(row, 3) = (S - X.p).cross(sol.dx_dS).transpose();
      }
      out.iterations = it;
      out.closure = r.cwiseAbs().maxCoeff();
      out.leg_closure = leg_closure;
      if (out.closure < 1e-12 || (out.closure < 1e-10 && out.closure >= best)) {
        out.ok = std::isfinite(out.closure);
        out.platform = to_pose(X);
        out.pose = to_pose(X * tool_);
        return out;
      }
      best = std::min(best, out.closure);
      const V6 step = -J.partialPivLu().solve(r);
      if (!step.allFinite()) return out;
      X.p += step.head<3>();
      X.R = rotation_vector(step.tail<3>()) * X.R;
    }
    return out;
  }

  // Static axial load of every leg under the payload (StewartEffects:
  // weight W along −z of the base frame at payload_com, platform frame) with
  // the legs at the command-equivalent values v (physical x = v + encoder):
  // τ_i = F·∂p_com/∂v_i by virtual work, ∂p_com/∂v_i by central differences
  // (h = 1e-3 mm) of this machine's FK, each started from the FK at v.
  // τ_i > 0: the weight pulls leg i longer (tension). NaN if an FK fails.
  V6 leg_loads(const V6& v) const {
    const StewartFkResult r0 = fk(v);
    if (!r0.ok) return V6::Constant(std::nan(""));
    const V3 F(0, 0, -effects_.payload_weight);
    const double h = 1e-3;
    V6 tau;
    for (int j = 0; j < 6; ++j) {
      V6 a = v, b = v;
      a(j) += h;
      b(j) -= h;
      const StewartFkResult ra = fk(a, &r0.platform), rb = fk(b, &r0.platform);
      if (!ra.ok || !rb.ok) return V6::Constant(std::nan(""));
      const V3 dp = (ra.platform.transform(effects_.payload_com) - rb.platform.transform(effects_.payload_com)) / (2 * h);
      tau(j) = F.dot(dp);
    }
    return tau;
  }

  // The command-equivalent leg values the mechanism has for commands q under
  // the effects: q + Δ (header comment), so the physical leg value is this
  // plus the encoder offset. Effects off (or T = 20 °C, below the knees, zero
  // clearance): q exactly. `loads` (optional) receives τ (zero without
  // clearance).
  V6 effective_joints(const V6& q, const StewartInputs& in, V6* loads = nullptr) const {
    const StewartEffects& fx = effects_;
    const double dT = in.temp - 20.0;
    V6 v = q;
    for (int i = 0; i < 6; ++i) {
      const std::size_t k = std::size_t(i);
      double d = 0;
      if (fx.thermal[k] != 0) d += fx.thermal[k] * dT * (q(i) + errors_.encoder[k]);
      if (fx.ramp_gain[k] != 0) {
        const double over = std::max(0.0, q(i) - fx.ramp_knee[k]);
        d += fx.ramp_gain[k] * over * over;
      }
      v(i) = q(i) + d;
    }
    if (loads != nullptr) loads->setZero();
    if (fx.any_clearance()) {
      const V6 tau = leg_loads(v);
      if (!tau.allFinite()) return V6::Constant(std::nan(""));
      for (int i = 0; i < 6; ++i) {
        const double c = fx.clearance[std::size_t(i)];
        if (c != 0 && tau(i) != 0) v(i) += tau(i) > 0 ? c : -c;
      }
      if (loads != nullptr) *loads = tau;
    }
    return v;
  }

  // FK with the effects: the pose reached for commands q at `in`.
  StewartFkResult fk(const V6& q, const StewartInputs& in) const {
    if (!effects_.any()) return fk(q);
    return fk(effective_joints(q, in));
  }

  // IK of this machine (a nominal simulator gives the nominal IK): the
  // platform is the tool pose with the tool offset taken off; each leg's
  // required x_i from its closure; q_i = x_i − encoder_i. No stroke limits.
  bool ik(const Pose<double>& tool, V6& q) const {
    if (!tool.finite()) return false;
    const Rigid X = to_rigid(tool) * tool_.inverse();
    for (std::size_t i = 0; i < 6; ++i) {
      const LegSolution sol = solve_leg(legs_[i], X * platform_point_[i]);
      if (!sol.ok) return false;
      q(Eigen::Index(i)) = sol.x - errors_.encoder[i];
    }
    return true;
  }

 private:
  StewartErrors errors_;
  StewartEffects effects_;
  Rigid home_;
  Rigid tool_;
  std::array<UpsLeg, 6> legs_;
  std::array<V3, 6> platform_point_;  // S centres, platform frame
};

inline Dataset make_stewart_dataset(const StewartErrors& errors, const std::vector<V6>& commanded,
                                    const MeasurementSpec& spec) {
  return make_dataset(StewartSimulator(errors), StewartSimulator(), commanded, spec);
}

// Dataset of the erroneous machine with effects, commanded by the nominal IK
// in the order given: `temps[k]` row k's structure temperature, °C (empty:
// 20 °C, and no `temp` column), `roles[k]` its role (empty: cal, no `role`
// column). No `dir` columns (no effect here follows the approach direction).
// Noise as make_dataset (the same draws for the same seed and rows); with the
// effects off and no temps / roles the rows equal make_stewart_dataset's.
inline Dataset make_stewart_effect_dataset(const StewartErrors& errors, const StewartEffects& effects,
                                           const std::vector<V6>& commanded, const MeasurementSpec& spec,
                                           const std::vector<double>& temps = {},
                                           const std::vector<std::string>& roles = {}) {
  if (!temps.empty() && temps.size() != commanded.size()) throw std::invalid_argument("one temperature per pose");
  if (!roles.empty() && roles.size() != commanded.size()) throw std::invalid_argument("one role per pose");
  const StewartSimulator actual(errors, effects), nominal;
  Dataset out = make_dataset_by(nominal, commanded, spec, [&](std::size_t i, DatasetRow& row) {
    StewartInputs in;
    if (!temps.empty()) in.temp = temps[i];
    row.temp = in.temp;
    if (!roles.empty()) row.role = roles[i];
    return actual.fk(row.q, in);
  });
  out.has_role = !roles.empty();
  out.has_temp = !temps.empty();
  return out;
}

}  // namespace kincal::independent
