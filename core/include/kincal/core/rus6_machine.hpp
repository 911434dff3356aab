// The 6-RUS hexapod on the controller (GUIDE "A third family"): its part of a
// calibration table, its checks, and its half of the compensator — the whole
// family in one header, reached by core's generic code through the machine
// type (issue #33): validate_table finds machine_values_ok and
// machine_inside by argument-dependent lookup, the Compensator uses
// compensation_detail::Model<Rus6Machine<S>>, table_cast uses Rebind, the
// port controller encoder_offset. A firmware image for a 6-RUS includes this
// header; nothing of the other families is linked.
//
// Compensation is the closed-form IK of the identified geometry (rus6.hpp),
// as seed 001's for the 6-UPS: every error of identify's 6-RUS model (shaft
// line, crank plane and zero, crank and rod lengths, platform sphere) is a
// number of that geometry, so the table carries the nominal and the
// calibrated geometry and the controller solves the calibrated one exactly.
#pragma once

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/core/machine_limits.hpp"
#include "kincal/core/rus6.hpp"

namespace kincal {

// Rus6Geometry as numbers (rus6.hpp names and units). Matrices column-major:
// shaft_points[3*i + k] is coordinate k of s_i.
template <class Scalar> struct Rus6GeometryTable {
  Scalar shaft_points[18];     // s_i, base frame, mm
  Scalar shaft_axes[18];       // a_i, unit
  Scalar crank_zero[18];       // z_i, unit, ⟂ a_i
  Scalar crank_length[6];      // c_i, mm
  Scalar rod_length[6];        // ℓ_i, mm
  Scalar platform_joints[18];  // p_i, platform frame, mm
  Scalar joint_offset[6];      // θ_i − q_i, rad
  Scalar min_joint[6];         // on the command q, rad
  Scalar max_joint[6];
  Scalar home_branch[6];       // σ_i at home: −1, 0 (unknown) or 1
  Scalar home_rotation[9];     // FK's default start pose, R column-major
  Scalar home_position[3];     // mm
  Scalar characteristic_length;  // mm per rad in singularity tests

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    using table_detail::each;
    each(s.shaft_points, f);
    each(s.shaft_axes, f);
    each(s.crank_zero, f);
    each(s.crank_length, f);
    each(s.rod_length, f);
    each(s.platform_joints, f);
    each(s.joint_offset, f);
    each(s.min_joint, f);
    each(s.max_joint, f);
    each(s.home_branch, f);
    each(s.home_rotation, f);
    each(s.home_position, f);
    f(s.characteristic_length);
  }
};

template <class S> struct Rus6Machine {
  using Scalar = S;
  template <class Other> using Rebind = Rus6Machine<Other>;
  static constexpr MachineFamily family = MachineFamily::Rus6;
  static constexpr const char* type_name = "Rus6Machine";
  static constexpr const char* family_name = "Rus6";
  static constexpr const char* header = "kincal/core/rus6_machine.hpp";  // what a generated table includes
  static constexpr bool revolute(int) { return true; }  // six cranks, rad
  Rus6GeometryTable<S> nominal;     // nominal IK: the reference of the correction bound
  Rus6GeometryTable<S> calibrated;  // the identified geometry: its IK is the compensation

  // θ_i = q_i + joint_offset_i: the crank's encoder zero error.
  constexpr S encoder_offset(int i) const { return calibrated.joint_offset[i] - nominal.joint_offset[i]; }

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    Rus6GeometryTable<S>::visit(s.nominal, f);
    Rus6GeometryTable<S>::visit(s.calibrated, f);
  }
};

template <class S> using Rus6CalibrationTable = CalibrationTable<Rus6Machine<S>>;

// ---- checks (validate_table, by argument-dependent lookup) ---------------------

namespace rus6_table_detail {

using table_detail::abs;

template <class Scalar> constexpr Scalar dot3(const Scalar* a, const Scalar* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// rus6_valid_geometry's rules, constexpr (a generated header asserts them):
// unit, orthogonal shaft axes and crank directions (to the precision the
// scalar stores them), positive lengths, ordered limits narrower than a turn,
// branches in {−1, 0, 1}, an orthonormal home rotation.
template <class Scalar> constexpr bool values_ok(const Rus6GeometryTable<Scalar>& g) {
  const Scalar tol = sizeof(Scalar) == 8 ? Scalar(1e-9) : Scalar(1e-5);
  const Scalar two_pi = Scalar(6.283185307179586);
  for (int i = 0; i < 6; ++i) {
    const Scalar* a = g.shaft_axes + 3 * i;
    const Scalar* z = g.crank_zero + 3 * i;
    if (!(abs(dot3(a, a) - Scalar(1)) < tol) || !(abs(dot3(z, z) - Scalar(1)) < tol) || !(abs(dot3(a, z)) < tol))
      return false;
    if (!(g.crank_length[i] > Scalar(0)) || !(g.rod_length[i] > Scalar(0))) return false;
    if (!(g.min_joint[i] < g.max_joint[i]) || !(g.max_joint[i] - g.min_joint[i] < two_pi)) return false;
    const Scalar b = g.home_branch[i];
    if (!(b == Scalar(0) || b == Scalar(1) || b == Scalar(-1))) return false;
  }
  return table_detail::rotation(g.home_rotation) && g.characteristic_length > Scalar(0);
}

}  // namespace rus6_table_detail

template <class Scalar> constexpr bool machine_values_ok(const Rus6Machine<Scalar>& m, const TableBounds<Scalar>& b) {
  if (!rus6_table_detail::values_ok(m.nominal) || !rus6_table_detail::values_ok(m.calibrated)) return false;
  // The encoder offsets act at every point: one above its bound is a corrupt
  // table, not a bad NC point (as the hybrid's).
  for (int i = 0; i < 6; ++i)
    if (!(table_detail::abs(m.encoder_offset(i)) <= b.max_correction[i])) return false;
  return true;
}

// The identified geometry within the caps: lengths and points within
// max_geometry_error of the nominal, the unit shaft axes and crank
// directions within max_angle_error (a difference of unit vectors is the
// angle between them, to first order).
template <class Scalar>
constexpr bool machine_inside(const Rus6Machine<Scalar>& m, const TableBounds<Scalar>&, const MachineLimits<Scalar>& l) {
  using limits_detail::within;
  const auto& c = m.calibrated;
  const auto& n = m.nominal;
  for (int k = 0; k < 18; ++k)
    if (!within(c.shaft_points[k] - n.shaft_points[k], l.max_geometry_error) ||
        !within(c.platform_joints[k] - n.platform_joints[k], l.max_geometry_error) ||
        !within(c.shaft_axes[k] - n.shaft_axes[k], l.max_angle_error) ||
        !within(c.crank_zero[k] - n.crank_zero[k], l.max_angle_error))
      return false;
  for (int i = 0; i < 6; ++i)
    if (!within(c.crank_length[i] - n.crank_length[i], l.max_geometry_error) ||
        !within(c.rod_length[i] - n.rod_length[i], l.max_geometry_error))
      return false;
  return true;  // encoder offsets: machine_values_ok bounds them by max_correction
}

// ---- conversions ---------------------------------------------------------------

template <class Scalar> Rus6Geometry<Scalar> to_core(const Rus6GeometryTable<Scalar>& t) {
  using namespace table_detail;
  Rus6Geometry<Scalar> g;
  g.shaft_points = get<Scalar, 3, 6>(t.shaft_points);
  g.shaft_axes = get<Scalar, 3, 6>(t.shaft_axes);
  g.crank_zero = get<Scalar, 3, 6>(t.crank_zero);
  g.crank_length = get<Scalar, 6, 1>(t.crank_length);
  g.rod_length = get<Scalar, 6, 1>(t.rod_length);
  g.platform_joints = get<Scalar, 3, 6>(t.platform_joints);
  g.joint_offset = get<Scalar, 6, 1>(t.joint_offset);
  g.min_joint = get<Scalar, 6, 1>(t.min_joint);
  g.max_joint = get<Scalar, 6, 1>(t.max_joint);
  g.home_branch = get<Scalar, 6, 1>(t.home_branch);
  g.home.R = get<Scalar, 3, 3>(t.home_rotation);
  g.home.p = get<Scalar, 3, 1>(t.home_position);
  g.characteristic_length = t.characteristic_length;
  return g;
}

template <class Scalar> Rus6GeometryTable<Scalar> to_table(const Rus6Geometry<Scalar>& g) {
  using namespace table_detail;
  Rus6GeometryTable<Scalar> t{};
  put(g.shaft_points, t.shaft_points);
  put(g.shaft_axes, t.shaft_axes);
  put(g.crank_zero, t.crank_zero);
  put(g.crank_length, t.crank_length);
  put(g.rod_length, t.rod_length);
  put(g.platform_joints, t.platform_joints);
  put(g.joint_offset, t.joint_offset);
  put(g.min_joint, t.min_joint);
  put(g.max_joint, t.max_joint);
  put(g.home_branch, t.home_branch);
  put(g.home.R, t.home_rotation);
  put(g.home.p, t.home_position);
  t.characteristic_length = g.characteristic_length;
  return t;
}

// ---- the compensator's half ------------------------------------------------------

// A table's geometry read in place: the members rus6.hpp's IK reads, as maps
// over the table's arrays (a few pointers on the stack, where a copied
// Rus6Geometry<double> is 976 bytes of static RAM per geometry, two of
// which do not fit a 4 KiB controller beside its stream).
template <class Scalar> struct Rus6GeometryRef {
  using Points = Eigen::Map<const Eigen::Matrix<Scalar, 3, 6>>;
  using Values = Eigen::Map<const Vec6<Scalar>>;
  Points shaft_points, shaft_axes, crank_zero;
  Values crank_length, rod_length;
  Points platform_joints;
  Values joint_offset, min_joint, max_joint, home_branch;
  Scalar characteristic_length;

  explicit Rus6GeometryRef(const Rus6GeometryTable<Scalar>& t)
      : shaft_points(t.shaft_points),
        shaft_axes(t.shaft_axes),
        crank_zero(t.crank_zero),
        crank_length(t.crank_length),
        rod_length(t.rod_length),
        platform_joints(t.platform_joints),
        joint_offset(t.joint_offset),
        min_joint(t.min_joint),
        max_joint(t.max_joint),
        home_branch(t.home_branch),
        characteristic_length(t.characteristic_length) {}
};

namespace compensation_detail {

// The table's geometries are read in place (the table outlives the
// compensator, as the hybrid's source errors do); validate_table checked
// them (machine_values_ok: unit, perpendicular axes, positive lengths,
// limits narrower than a turn).
template <class S> struct Model<Rus6Machine<S>> {
  const Rus6Machine<S>* machine = nullptr;
  bool load(const Rus6Machine<S>& m) {
    machine = &m;
    return true;
  }
  Pose<S> home_pose() const {
    Pose<S> home;
    home.R = Eigen::Map<const Mat3<S>>(machine->nominal.home_rotation);
    home.p = Eigen::Map<const Vec3<S>>(machine->nominal.home_position);
    return home;
  }

  // The nominal IK with its Jacobian (∂q/∂twist, rus6.hpp): q_nom, the
  // singularity test (serial and parallel) and the static loads; with
  // `family_values`, the formulas' `rod` and `lever` at the same
  // configuration (rus6_formula_joint_values' numbers: the levers are the
  // IK's own, so the IK runs once a point).
  template <bool kPayload>
  Status nominal_configuration(const Pose<S>& pose, Vec6<S>& nominal_q, bool need_load, const Vec3<S>& g, Vec6<S>& load,
                               S payload_weight, const Vec3<S>& payload_com, Vec6<S>* payload_load,
                               S* family_values) const {
    Mat6<S> J;
    const Rus6GeometryRef<S> nominal(machine->nominal);
    const Status s = rus6_ik(nominal, pose, nominal_q, &J, family_values != nullptr ? family_values + 6 : nullptr);
    if (s != Status::Ok) return s;
    if (family_values != nullptr)
      for (int i = 0; i < 6; ++i) family_values[i] = nominal.rod_length(i);
    return ik_jacobian_loads<kPayload>(J, pose, need_load, g, load, payload_weight, payload_com, payload_load);
  }

  // The calibrated geometry's closed-form IK is the compensation (no
  // iterative model: exact() is false at compile time and solve_exact only
  // keeps Compensator::solve one form).
  static constexpr bool exact() { return false; }
  template <class Warm> Status solve_exact(const Pose<S>& target, Vec6<S>& ideal, Warm*) const {
    return solve_closed_form(target, ideal);
  }
  Status solve_closed_form(const Pose<S>& target, Vec6<S>& ideal) const {
    return rus6_ik(Rus6GeometryRef<S>(machine->calibrated), target, ideal);
  }

};

}  // namespace compensation_detail

// ---- tables on the controller (fallback) and on the host --------------------------

// 0.02 rad per crank (~1.1°), as the hybrid's revolute joints; the limits
// are the description's joint limits.
template <class Scalar> TableBounds<Scalar> default_bounds(const Rus6Geometry<Scalar>& g) {
  TableBounds<Scalar> b{};
  for (int i = 0; i < 6; ++i) {
    b.max_correction[i] = Scalar(0.02);
    b.min_joint[i] = g.min_joint(i);
    b.max_joint[i] = g.max_joint(i);
  }
  return b;
}

template <class Scalar>
Rus6CalibrationTable<Scalar> nominal_table(const Rus6Geometry<Scalar>& g,
                                           const EffectParameters<Scalar>& effects = EffectParameters<Scalar>()) {
  Rus6CalibrationTable<Scalar> t{};
  t.machine.nominal = to_table(g);
  t.machine.calibrated = to_table(g);
  t.effects = to_table(effects);
  t.bounds = default_bounds(g);
  seal(t);
  return t;
}

template <class S>
Rus6CalibrationTable<S> nominal_table_of(const Rus6Machine<S>& m, const EffectParameters<S>& effects) {
  return nominal_table(to_core(m.nominal), effects);
}

}  // namespace kincal
