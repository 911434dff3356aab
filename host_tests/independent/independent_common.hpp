// Shared pieces of the independent simulators (hybrid_simulator.hpp,
// stewart_simulator.hpp): rigid motions, joint LINES and their exponentials,
// the UPS leg closure, measurement with noise and the measurement-CSV writer.
//
// Nothing here calls kincal's kinematics: only Eigen, and core's Pose<double>
// as an exchange type (Pose::from_xyz_rpy / to_xyz_rpy give the CSV's
// R = Rz(rz)·Ry(ry)·Rx(rx) convention). Rotations are built with
// Eigen::AngleAxisd, not core's exp_so3 / rot_x.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <optional>
#include <ostream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "kincal/core/pose.hpp"

namespace kincal::independent {

using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;
using V6 = Eigen::Matrix<double, 6, 1>;
using M6 = Eigen::Matrix<double, 6, 6>;

constexpr double kPi = 3.14159265358979323846;

// ------------------------------------------------------------------ rigid motions

struct Rigid {
  M3 R = M3::Identity();
  V3 p = V3::Zero();
  Rigid operator*(const Rigid& b) const { return Rigid{R * b.R, R * b.p + p}; }
  V3 operator*(const V3& x) const { return R * x + p; }
  Rigid inverse() const { return Rigid{R.transpose(), -(R.transpose() * p)}; }
};

inline M3 rotation_about(const V3& unit_axis, double angle) { return Eigen::AngleAxisd(angle, unit_axis).toRotationMatrix(); }

// Rotation by a rotation vector (axis · angle).
inline M3 rotation_vector(const V3& w) {
  const double n = w.norm();
  if (n == 0.0) return M3::Identity();
  return Eigen::AngleAxisd(n, w / n).toRotationMatrix();
}

// Rotation vector of R (|angle| < π).
inline V3 rotation_log(const M3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

inline Rigid to_rigid(const Pose<double>& p) { return Rigid{p.R, p.p}; }
inline Pose<double> to_pose(const Rigid& r) {
  Pose<double> out;
  out.R = r.R;
  out.p = r.p;
  return out;
}

// A unit direction turned by two small angles about two fixed directions
// normal to it (the two DOF a direction error has): rotation vector a·e1 + b·e2.
inline V3 tilted(const V3& direction, const V3& e1, const V3& e2, double a, double b) {
  return (rotation_vector(a * e1 + b * e2) * direction).normalized();
}

// Two unit vectors normal to `d` (and to each other), chosen deterministically:
// e1 is the component of the coordinate axis least aligned with d normal to d.
inline std::array<V3, 2> normal_basis(const V3& d) {
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(d(i)) < std::abs(d(k))) k = i;
  V3 e1 = V3::Unit(k) - d(k) * d;
  e1.normalize();
  return {e1, d.cross(e1)};
}

// ------------------------------------------------------------------ joint lines

// A 1-DOF joint given by its line in the space frame at the reference
// configuration (all joint variables zero): a revolute turns about the line
// (point, unit direction), a prismatic translates along the direction (its
// point is irrelevant).
struct JointLine {
  bool revolute = true;
  V3 point = V3::Zero();
  V3 direction = V3::UnitZ();
};

// exp([S]·value) for the joint's screw S, as a rigid motion of the space frame.
inline Rigid joint_motion(const JointLine& j, double value) {
  Rigid m;
  if (j.revolute) {
    m.R = rotation_about(j.direction, value);
    m.p = j.point - m.R * j.point;  // rotation about the line, not about the origin
  } else {
    m.p = j.direction * value;
  }
  return m;
}

// Product of exponentials Π exp([S_k] x_k) and, per joint, the motion of the
// joints before it (T_{<k}), which carries joint k's reference line to its
// current place: the Jacobian columns below need those.
struct PoeState {
  Rigid product;
  std::vector<Rigid> before;  // before[k] = Π_{j<k} exp([S_j] x_j)
};

inline PoeState poe(const std::vector<JointLine>& joints, const Eigen::VectorXd& values) {
  PoeState s;
  s.before.reserve(joints.size());
  for (std::size_t k = 0; k < joints.size(); ++k) {
    s.before.push_back(s.product);
    s.product = s.product * joint_motion(joints[k], values(Eigen::Index(k)));
  }
  return s;
}

// Velocity of a point at current position x (space frame) per unit rate of
// joint k: ω' × (x − q') for a revolute (ω', q' its current line), R_{<k}·v
// for a prismatic.
inline V3 point_rate(const JointLine& j, const Rigid& before, const V3& x) {
  if (j.revolute) return (before.R * j.direction).cross(x - before * j.point);
  return before.R * j.direction;
}
// Angular velocity per unit rate of joint k.
inline V3 angular_rate(const JointLine& j, const Rigid& before) {
  return j.revolute ? V3(before.R * j.direction) : V3::Zero();
}

// ------------------------------------------------------------------ UPS leg

// One U-P-S leg as joint lines at the reference configuration (leg along its
// reference direction u): U = revolute a (on the base) then revolute b, then
// the prismatic along u; the sphere centre is a point on the prismatic's
// moving part. With every error zero: a through the U centre A along t,
// b through A along n, sphere centre at A (+ x·u): the centre lies at distance
// x from A, the classic leg length.
struct UpsLeg {
  JointLine a, b;  // U joint axes
  V3 slide = V3::UnitZ();            // prismatic direction u (on the U's second body)
  V3 centre_at_zero = V3::Zero();    // sphere centre at θa = θb = x = 0
  V3 u_centre = V3::Zero();          // U centre (for the starting guess only)
};

struct LegSolution {
  bool ok = false;
  double x = 0;        // prismatic value (leg command + offsets)
  double theta_a = 0, theta_b = 0;
  V3 dx_dS = V3::Zero();  // ∂x/∂S: row 3 of the closure Jacobian's inverse
  double closure = 0;  // |centre − S| at the end, mm
  int iterations = 0;
};

// Sphere centre of the leg for (θa, θb, x) and the closure Jacobian
// [∂c/∂θa ∂c/∂θb ∂c/∂x].
inline V3 leg_centre(const UpsLeg& leg, double ta, double tb, double x, M3* J = nullptr) {
  const Rigid Ta = joint_motion(leg.a, ta);
  const Rigid Tb = joint_motion(leg.b, tb);
  const Rigid Tab = Ta * Tb;
  const V3 c = Tab * (leg.centre_at_zero + x * leg.slide);
  if (J != nullptr) {
    J->col(0) = point_rate(leg.a, Rigid{}, c);
    J->col(1) = point_rate(leg.b, Ta, c);
    J->col(2) = Tab.R * leg.slide;
  }
  return c;
}

// The leg's required prismatic value so that its sphere centre meets the
// platform's sphere point S: Newton on (θa, θb, x), 3 equations, 3 unknowns
// (seed 000's UPS limb closure, Section 2, solved numerically per leg here
// rather than as a distance). `guess` (θa, θb, x) warm-starts it; x ≤ 0 in the
// guess means "start from the distance".
inline LegSolution solve_leg(const UpsLeg& leg, const V3& S, const V3& guess = V3(0, 0, -1)) {
  LegSolution out;
  double ta = guess(0), tb = guess(1), x = guess(2);
  if (!(x > 0)) {
    ta = tb = 0;
    x = (S - leg.u_centre).norm();
  }
  M3 J;
  double best = 1e300;
  V3 best_x(ta, tb, x);
  for (int it = 0; it < 60; ++it) {
    const double closure = (leg_centre(leg, ta, tb, x) - S).norm();
    if (!std::isfinite(closure)) break;
    // Quadratic convergence reaches the rounding floor (~1e-13 mm on
    // ~1000 mm) a step after the closure drops below a micrometre; keep
    // stepping while it still falls and keep the best point.
    if (closure < best) {
      best = closure;
      best_x = V3(ta, tb, x);
    } else if (best < 1e-9) {
      break;
    }
    out.iterations = it;
    if (best == 0.0) break;
    const V3 r = leg_centre(leg, ta, tb, x, &J) - S;
    const V3 step = -J.partialPivLu().solve(r);
    if (!step.allFinite()) break;
    ta += step(0);
    tb += step(1);
    x += step(2);
  }
  out.theta_a = best_x(0);
  out.theta_b = best_x(1);
  out.x = best_x(2);
  out.closure = best;
  leg_centre(leg, out.theta_a, out.theta_b, out.x, &J);
  out.dx_dS = J.inverse().row(2).transpose();
  out.ok = best < 1e-9;
  return out;
}

// Builds the leg from its nominal U centre A, the reference leg direction u and
// the physical errors. The U axes: a = t = u × z / |u × z| (horizontal), b =
// n = u × t (docs/hybrid-error-model.md §2's frames R_1,i, R_2,i).
struct UpsLegErrors {
  V3 base_centre = V3::Zero();        // U centre displacement, base frame, mm
  std::array<double, 2> axis_a_tilt{0, 0};  // rad, rotations of t about (n, u)
  std::array<double, 2> axis_b_tilt{0, 0};  // rad, rotations of n about (t, u)
  double axis_offset = 0;             // axis b displaced from axis a along u (their common normal), mm
  std::array<double, 2> leg_offset{0, 0};   // prismatic line displaced from the U centre along (t, n), mm
};

inline UpsLeg make_ups_leg(const V3& A, const V3& u, const UpsLegErrors& e) {
  // A vertical leg (not on these machines) takes t = x instead.
  const V3 t = u.cross(V3::UnitZ()).norm() > 1e-9 ? V3(u.cross(V3::UnitZ()).normalized()) : V3(V3::UnitX());
  const V3 n = u.cross(t);
  UpsLeg leg;
  const V3 A1 = A + e.base_centre;
  leg.u_centre = A1;
  leg.a = JointLine{true, A1, tilted(t, n, u, e.axis_a_tilt[0], e.axis_a_tilt[1])};
  leg.b = JointLine{true, A1 + e.axis_offset * u, tilted(n, t, u, e.axis_b_tilt[0], e.axis_b_tilt[1])};
  leg.slide = u;
  leg.centre_at_zero = A1 + e.leg_offset[0] * t + e.leg_offset[1] * n;
  return leg;
}

// Six zero vectors: Eigen's default constructor leaves a vector
// uninitialised, so a member `std::array<V3, 6> x{}` is NOT zeros (the
// sanitizer build's clang showed it); initialise such members with this.
inline std::array<V3, 6> zero_vectors() {
  std::array<V3, 6> a;
  a.fill(V3::Zero());
  return a;
}

// ------------------------------------------------------------------ random errors

inline double uniform(std::mt19937_64& rng, double scale) {
  return std::uniform_real_distribution<double>(-scale, scale)(rng);
}

// ------------------------------------------------------------------ measurement

// What the instrument sees. With `targets` empty the full tool pose is
// measured (mx..mrz, in the base / workpiece frame the commanded poses use);
// with 1–3 targets (tool-frame coordinates, mm) their positions are measured,
// y_k = T_IB · X · t_k with T_IB = `instrument_from_base` (identity: the
// base frame; kincal's registration convention, target_measurement.hpp).
// `pose_and_targets` writes both (what `kincal simulate` writes for the
// hybrid's gauge). Noise: N(0, σ_mm) on every coordinate, N(0, σ_rad) added to
// mrx, mry, mrz (as `kincal simulate` does), from std::mt19937_64(seed).
struct MeasurementSpec {
  std::vector<V3> targets;
  bool pose_and_targets = false;
  Pose<double> instrument_from_base;
  double sigma_mm = 0;
  double sigma_rad = 0;
  std::uint64_t seed = 1;
  bool write_q = true;  // q1..q6: the commands actually sent (nominal IK)
};

struct DatasetRow {
  std::string id;
  V6 commanded = V6::Zero();  // x, y, z, rx, ry, rz
  V6 q = V6::Zero();          // commands sent
  Pose<double> actual;        // noise-free pose the erroneous machine reached
  std::optional<V6> measured;
  std::vector<V3> targets;    // measured target positions
  // Optional covariates (written only where the Dataset's flags below say so):
  std::string role;           // "cal" / "test" (`role` column)
  double temp = 20;           // structure temperature, °C (`temp` column)
  V6 dir = V6::Ones();        // approach direction of each joint, ±1 (`dir1..dir6` columns)
};

struct Dataset {
  std::vector<DatasetRow> rows;
  std::vector<std::string> skipped;  // "index: why" for poses the nominal IK or the actual FK refused
  int target_count = 0;
  bool has_measured = false, has_q = true;
  bool has_role = false, has_temp = false, has_dir = false;  // extra columns (default: none, as before)
};

// What the instrument reads of a row whose tool reached `reached`: the noisy
// pose (if measured) and the noisy targets, seen from the instrument frame.
template <class Noise>
void measure_row(DatasetRow& row, const Pose<double>& reached, const MeasurementSpec& spec, bool measured,
                 Noise& noise) {
  row.actual = reached;
  if (measured) {
    V6 m = reached.to_xyz_rpy();
    for (int k = 0; k < 3; ++k) m(k) += noise(spec.sigma_mm);
    for (int k = 3; k < 6; ++k) m(k) += noise(spec.sigma_rad);
    row.measured = m;
  }
  const Pose<double> seen = spec.instrument_from_base * reached;
  for (const V3& t : spec.targets) {
    V3 y = seen.transform(t);
    for (int k = 0; k < 3; ++k) y(k) += noise(spec.sigma_mm);
    row.targets.push_back(y);
  }
}

// Runs `commanded` poses through nominal IK → `reach(i, row)` → instrument.
// `nominal` needs `bool ik(const Pose<double>&, V6& q) const` (the commands for
// a pose); `reach` drives the actual machine with row.q (it may fill the
// row's inputs: temperature, directions, role) and returns its FK result
// (`.ok`, `.pose`).
template <class Nominal, class Reach>
Dataset make_dataset_by(const Nominal& nominal, const std::vector<V6>& commanded, const MeasurementSpec& spec,
                        Reach reach) {
  if (spec.targets.size() > 3) throw std::invalid_argument("at most three targets");
  Dataset out;
  out.target_count = int(spec.targets.size());
  out.has_measured = spec.targets.empty() || spec.pose_and_targets;
  out.has_q = spec.write_q;
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  auto noise = [&](double sigma) { return sigma > 0 ? sigma * unit(rng) : 0.0; };
  for (std::size_t i = 0; i < commanded.size(); ++i) {
    DatasetRow row;
    row.id = "n" + std::to_string(i + 1);
    row.commanded = commanded[i];
    const Pose<double> target = Pose<double>::from_xyz_rpy(commanded[i]);
    if (!nominal.ik(target, row.q)) {
      out.skipped.push_back(std::to_string(i) + ": nominal IK failed");
      continue;
    }
    const auto reached = reach(i, row);
    if (!reached.ok) {
      out.skipped.push_back(std::to_string(i) + ": actual FK failed");
      continue;
    }
    measure_row(row, reached.pose, spec, out.has_measured, noise);
    out.rows.push_back(row);
  }
  return out;
}

// The same with `actual.fk(q)` (both simulators have it).
template <class Actual, class Nominal>
Dataset make_dataset(const Actual& actual, const Nominal& nominal, const std::vector<V6>& commanded,
                     const MeasurementSpec& spec) {
  return make_dataset_by(nominal, commanded, spec, [&](std::size_t, DatasetRow& row) { return actual.fk(row.q); });
}

// ------------------------------------------------------------------ CSV writer

// kincal's measurement CSV v1 (docs/formats.md), the column groups in the order
// identify's write_pose_table uses: id, x..rz, [mx..mrz], [t1x..tkz], [q1..q6];
// then, where the Dataset's flags ask, [role], [temp], [dir1..dir6].
// Numbers with 17 significant digits (read back to the same double).
inline std::string csv_number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

inline void write_measurement_csv(std::ostream& out, const Dataset& d) {
  out << "id,x,y,z,rx,ry,rz";
  if (d.has_measured) out << ",mx,my,mz,mrx,mry,mrz";
  for (int k = 1; k <= d.target_count; ++k) out << ",t" << k << "x,t" << k << "y,t" << k << "z";
  if (d.has_q) out << ",q1,q2,q3,q4,q5,q6";
  if (d.has_role) out << ",role";
  if (d.has_temp) out << ",temp";
  if (d.has_dir) out << ",dir1,dir2,dir3,dir4,dir5,dir6";
  out << "\n";
  for (const DatasetRow& r : d.rows) {
    out << r.id;
    for (int k = 0; k < 6; ++k) out << "," << csv_number(r.commanded(k));
    if (d.has_measured)
      for (int k = 0; k < 6; ++k) out << "," << csv_number((*r.measured)(k));
    for (const V3& t : r.targets)
      for (int k = 0; k < 3; ++k) out << "," << csv_number(t(k));
    if (d.has_q)
      for (int k = 0; k < 6; ++k) out << "," << csv_number(r.q(k));
    if (d.has_role) out << "," << (r.role.empty() ? "cal" : r.role);
    if (d.has_temp) out << "," << csv_number(r.temp);
    if (d.has_dir)
      for (int k = 0; k < 6; ++k) out << "," << (r.dir(k) < 0 ? "-1" : "1");
    out << "\n";
  }
}

// The same, to a file (plain write; a test tool, not kincal's atomic writer).
inline void write_measurement_csv_file(const std::string& path, const Dataset& d) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  write_measurement_csv(out, d);
  if (!out) throw std::runtime_error("write failed: " + path);
}

}  // namespace kincal::independent
