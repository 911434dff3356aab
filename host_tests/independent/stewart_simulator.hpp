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
  explicit StewartSimulator(const StewartErrors& e = StewartErrors{}) : errors_(e) {
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
  Rigid home_;
  Rigid tool_;
  std::array<UpsLeg, 6> legs_;
  std::array<V3, 6> platform_point_;  // S centres, platform frame
};

inline Dataset make_stewart_dataset(const StewartErrors& errors, const std::vector<V6>& commanded,
                                    const MeasurementSpec& spec) {
  return make_dataset(StewartSimulator(errors), StewartSimulator(), commanded, spec);
}

}  // namespace kincal::independent
