// Independent simulator of `rus6-ref` (the 6-RUS of docs/reference-machines.md),
// for testing kincal's 6-RUS identification on data its own model did not
// make (issue #33).
//
// What it does differently from kincal's model (core/rus6.hpp and
// identify's rus6_error_model: per motor a shaft point, two sequential
// tilts, a crank zero, crank and rod lengths, a platform sphere):
//  - each motor is a rigid FRAME (origin and rotation) perturbed by a
//    translation and a rotation VECTOR (Eigen::AngleAxisd, all three
//    components at once: the one about the shaft is the crank's zero), and
//    the crank carries its pin beside the crank plane (`pin`, along the
//    shaft), a dimension kincal's model does not have (it moves the tip's
//    circle along the shaft: kincal's shaft point absorbs it);
//  - the rod's length grows with its own temperature coefficient, the rest of
//    the structure does not (kincal's `thermal` scales everything);
//  - the nominal IK (the controller's commands) brackets each leg's angle by
//    a scan and bisection on the closure, not the closed form;
//  - FK is Newton on the pose with a central-difference Jacobian of the six
//    closures, each step applied as (t + v, AngleAxis(ω)·R) — not core's
//    six_distance_fk;
//  - the motors' torques for compliance come from virtual work through THIS
//    machine's FK (central differences of the payload's centre of mass with
//    each crank angle), at the actual geometry.
// Only Eigen and core's Pose<double> (the CSV convention R = Rz·Ry·Rx) are
// used; rus6-ref's numbers are re-entered here.
//
// Hidden physical effects (Rus6Effects; zero = off, and then the machine is
// the effect-free one exactly):
//  - backlash: θ_i += b_i · dir_i (rad), dir_i the sign of the change of q_i
//    from the previous row, kept while it stands still (the gearbox's lost
//    motion);
//  - compliance: θ_i += k_i · τ_i (rad per N·mm), τ_i the torque on motor i of
//    a payload of `weight` N along −z of the base at `com` (platform frame);
//  - rod thermal: every rod's length × (1 + α·(T − 20 °C));
//  - ramp (outside kincal's library): motor `ramp_joint`'s angle gains
//    g·max(0, q − knee)² above a knee of its COMMAND (a worn gear segment);
//    written as a formula: `g * max(0, q - q0)^2` on that joint.
#pragma once

#include <array>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "independent/independent_common.hpp"

namespace kincal::independent {

struct Rus6PhysicalErrors {
  std::array<V3, 6> frame_shift = zero_vectors();  // motor frame origin, base frame, mm
  std::array<V3, 6> frame_turn = zero_vectors();   // motor frame rotation vector, base frame, rad
  std::array<double, 6> crank{}, rod{}, pin{};     // mm
  std::array<V3, 6> sphere = zero_vectors();       // rod's platform sphere, platform frame, mm
};

struct Rus6Effects {
  std::array<double, 6> backlash{};    // rad
  std::array<double, 6> compliance{};  // rad per N·mm of motor torque
  double weight = 0;                   // N, along −z of the base
  V3 com = V3::Zero();                 // payload centre of mass, platform frame, mm
  double rod_alpha = 0;                // 1/°C, rods only
  int ramp_joint = -1;                 // 0-based; −1: none
  double ramp_knee = 0, ramp_gain = 0;  // rad, 1/rad
};

struct Rus6Inputs {
  double temp = 20;
  V6 dir = V6::Ones();
};

struct Rus6Reach {
  bool ok = false;
  Pose<double> pose;
};

// Random physical errors: shifts and the pin of `length` mm, frame turns of
// `angle` rad, lengths of `length` mm.
inline Rus6PhysicalErrors random_rus6_errors(double length, double angle, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Rus6PhysicalErrors e;
  for (int i = 0; i < 6; ++i) {
    for (int k = 0; k < 3; ++k) {
      e.frame_shift[i](k) = uniform(rng, length);
      e.frame_turn[i](k) = uniform(rng, angle);
      e.sphere[i](k) = uniform(rng, length);
    }
    e.crank[i] = uniform(rng, length);
    e.rod[i] = uniform(rng, length);
    e.pin[i] = uniform(rng, length);
  }
  return e;
}

class Rus6PhysicalSimulator {
 public:
  explicit Rus6PhysicalSimulator(const Rus6PhysicalErrors& errors = {}, const Rus6Effects& effects = {})
      : effects_(effects) {
    const double deg = kPi / 180.0;
    for (int pair = 0; pair < 3; ++pair)
      for (int side = 0; side < 2; ++side) {
        const int i = 2 * pair + side;
        const double sign = side == 0 ? -1.0 : 1.0, azimuth = (120.0 * pair + sign * 25.0) * deg;
        const V3 radial(std::cos(azimuth), std::sin(azimuth), 0), tangent(-std::sin(azimuth), std::cos(azimuth), 0);
        // Frame columns: crank at θ = 0 (x), the crank's θ = 90° (y), the shaft (z).
        M3 frame;
        frame.col(0) = sign * tangent;
        frame.col(2) = sign * radial;
        frame.col(1) = frame.col(2).cross(frame.col(0));
        const V3 turn = errors.frame_turn[std::size_t(i)];
        motor_[i].R = (turn.norm() > 0 ? Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix()
                                       : M3::Identity()) *
                      frame;
        motor_[i].p = 200.0 * radial + errors.frame_shift[std::size_t(i)];
        crank_[i] = 100.0 + errors.crank[std::size_t(i)];
        pin_[i] = errors.pin[std::size_t(i)];
        rod_[i] = 300.0 + errors.rod[std::size_t(i)];
        sphere_[i] = 130.0 * radial + errors.sphere[std::size_t(i)];
      }
  }

  static Pose<double> home() { return Pose<double>::from_xyz_rpy(0, 0, 274.04379212089, 0, 0, 0); }

  // The nominal machine's commands for a pose (q = θ, no encoder offset):
  // each leg's angle bracketed by a scan over the joint range (−80°…+70°)
  // from its lower end and refined by bisection — the first sign change of
  // the closure, the branch on which the rod meets the crank from above.
  bool ik(const Pose<double>& pose, V6& q) const {
    const Rus6PhysicalSimulator nominal;
    for (int i = 0; i < 6; ++i) {
      const V3 P = pose.R * nominal.sphere_[i] + pose.p;
      auto f = [&](double theta) { return (P - nominal.tip(i, theta)).norm() - nominal.rod_[i]; };
      const double lo = -80.0 * kPi / 180.0, hi = 70.0 * kPi / 180.0;
      const int steps = 300;
      bool found = false;
      double left = lo, f_left = f(lo);
      for (int k = 1; k <= steps && !found; ++k) {
        const double right = lo + (hi - lo) * k / steps, f_right = f(right);
        if ((f_left <= 0) == (f_right <= 0)) {
          left = right;
          f_left = f_right;
          continue;
        }
        double low = left, high = right, f_low = f_left;
        for (int it = 0; it < 80; ++it) {
          const double mid = 0.5 * (low + high), f_mid = f(mid);
          if ((f_low <= 0) == (f_mid <= 0)) {
            low = mid;
            f_low = f_mid;
          } else {
            high = mid;
          }
        }
        q(i) = 0.5 * (low + high);
        found = true;
      }
      if (!found) return false;
    }
    return true;
  }

  // The pose the machine reaches for commands q (and the inputs the effects
  // read), Newton from `guess`.
  Rus6Reach fk(const V6& q, const Rus6Inputs& in = {}, const Pose<double>& guess = home()) const {
    V6 theta = q;
    for (int i = 0; i < 6; ++i) {
      theta(i) += effects_.backlash[std::size_t(i)] * in.dir(i);
      if (i == effects_.ramp_joint) theta(i) += effects_.ramp_gain * std::pow(std::max(0.0, q(i) - effects_.ramp_knee), 2);
    }
    const double stretch = 1.0 + effects_.rod_alpha * (in.temp - 20.0);
    if (effects_.weight != 0) {
      const Rus6Reach rigid = solve(theta, stretch, guess);
      if (!rigid.ok) return rigid;
      // Virtual work: τ_i = F · ∂p_com/∂θ_i, F the weight along −z.
      V6 deflected = theta;
      for (int i = 0; i < 6; ++i) {
        const double h = 1e-6;
        V6 up = theta, down = theta;
        up(i) += h;
        down(i) -= h;
        const Rus6Reach a = solve(up, stretch, rigid.pose), b = solve(down, stretch, rigid.pose);
        if (!a.ok || !b.ok) return {};
        const V3 dcom = (a.pose.R * effects_.com + a.pose.p - b.pose.R * effects_.com - b.pose.p) / (2 * h);
        const double torque = -effects_.weight * dcom.z();
        deflected(i) += effects_.compliance[std::size_t(i)] * torque;
      }
      return solve(deflected, stretch, rigid.pose);
    }
    return solve(theta, stretch, guess);
  }

  // The closure residual of leg i at a pose (mm), for the test's checks.
  double closure(int i, const Pose<double>& pose, double theta, double stretch = 1.0) const {
    return (pose.R * sphere_[i] + pose.p - tip(i, theta)).norm() - rod_[i] * stretch;
  }

 private:
  V3 tip(int i, double theta) const {
    return motor_[i].p + motor_[i].R * V3(crank_[i] * std::cos(theta), crank_[i] * std::sin(theta), pin_[i]);
  }

  V6 residual(const V6& theta, double stretch, const Pose<double>& pose) const {
    V6 r;
    for (int i = 0; i < 6; ++i) r(i) = closure(i, pose, theta(i), stretch);
    return r;
  }

  static Pose<double> moved(const Pose<double>& pose, const V6& step) {
    Pose<double> out;
    const V3 w = step.tail<3>();
    out.R = (w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() : M3::Identity()) * pose.R;
    out.p = pose.p + step.head<3>();
    return out;
  }

  Rus6Reach solve(const V6& theta, double stretch, const Pose<double>& guess) const {
    Rus6Reach out;
    Pose<double> pose = guess;
    for (int it = 0; it < 60; ++it) {
      const V6 r = residual(theta, stretch, pose);
      if (!r.allFinite()) return out;
      if (r.cwiseAbs().maxCoeff() < 1e-11) {
        out.ok = true;
        out.pose = pose;
        return out;
      }
      M6 J;
      for (int k = 0; k < 6; ++k) {
        const double h = k < 3 ? 1e-5 : 1e-7;
        V6 e = V6::Zero();
        e(k) = h;
        J.col(k) = (residual(theta, stretch, moved(pose, e)) - residual(theta, stretch, moved(pose, -e))) / (2 * h);
      }
      const Eigen::FullPivLU<M6> lu(J);
      if (lu.rank() < 6) return out;
      pose = moved(pose, -lu.solve(r));
    }
    return out;
  }

  std::array<Rigid, 6> motor_;
  std::array<double, 6> crank_{}, pin_{}, rod_{};
  std::array<V3, 6> sphere_{};
  Rus6Effects effects_;
};

// A data set in motion order: the nominal IK's commands, each row's
// temperature and role, the approach directions from the command sequence
// (dir columns written), the machine's pose measured.
inline Dataset make_rus6_dataset(const Rus6PhysicalSimulator& machine, const std::vector<V6>& poses,
                                 const MeasurementSpec& spec, const std::vector<double>& temps,
                                 const std::vector<std::string>& roles) {
  const Rus6PhysicalSimulator nominal;
  V6 previous;
  nominal.ik(Rus6PhysicalSimulator::home(), previous);
  Rus6Inputs in;
  Dataset d = make_dataset_by(nominal, poses, spec, [&](std::size_t k, DatasetRow& row) {
    for (int j = 0; j < 6; ++j)
      if (row.q(j) != previous(j)) in.dir(j) = row.q(j) > previous(j) ? 1.0 : -1.0;
    previous = row.q;
    in.temp = temps[k];
    row.temp = temps[k];
    row.dir = in.dir;
    row.role = roles[k];
    return machine.fk(row.q, in, Pose<double>::from_xyz_rpy(row.commanded));
  });
  d.has_temp = d.has_dir = d.has_role = true;
  return d;
}

}  // namespace kincal::independent
