// The core checks that run both on the host (GoogleTest) and on the Cortex-M
// target under qemu: pose math, IK/FK round trips over each reference
// machine's workspace, analytic Jacobians against finite differences, and one
// status per failure. Allocation-free and exception-free like core/ itself.
#pragma once

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "portable/check.hpp"

#include <cstdint>
#include <limits>

namespace kincal::test {

// Round-trip tolerances per scalar: float carries ~7 digits on a ~1 m machine.
template <class Scalar> struct RoundTripTolerance;
// (Measured worst cases over 10^4 poses: double 2.4e-11 mm / 1.3e-13 rad on
// the 6-UPS, 4.0e-10 mm on the hybrid; float 1.3e-4 mm / 5.9e-7 rad on the
// 6-UPS and 2.8e-3 mm / 1.7e-6 rad on the hybrid.)
template <> struct RoundTripTolerance<double> {
  static constexpr double position_mm = 1e-10, angle_rad = 1e-12;
};
template <> struct RoundTripTolerance<float> {
  static constexpr double position_mm = 2e-4, angle_rad = 2e-6;
};

constexpr double kDeg = 3.14159265358979323846 / 180.0;

template <class Scalar> Pose<Scalar> random_pose(Random& rng, const double lo[6], const double hi[6]) {
  return Pose<Scalar>::from_xyz_rpy(Scalar(rng.uniform(lo[0], hi[0])), Scalar(rng.uniform(lo[1], hi[1])),
                                    Scalar(rng.uniform(lo[2], hi[2])), Scalar(rng.uniform(lo[3], hi[3])),
                                    Scalar(rng.uniform(lo[4], hi[4])), Scalar(rng.uniform(lo[5], hi[5])));
}

template <class Scalar> bool poses_close(const Pose<Scalar>& a, const Pose<Scalar>& b, double pos_tol, double ang_tol) {
  const Twist<Scalar> e = pose_error(a, b);
  return double(e.template head<3>().norm()) <= pos_tol && double(e.template tail<3>().norm()) <= ang_tol;
}

// --- pose math -------------------------------------------------------------
template <class Scalar> void check_pose_math(Checker& c) {
  Random rng(7);
  const double tol = sizeof(Scalar) == 8 ? 1e-12 : 2e-6;
  for (int k = 0; k < 200; ++k) {
    const Scalar rx = Scalar(rng.uniform(-3.0, 3.0)), ry = Scalar(rng.uniform(-1.5, 1.5)), rz = Scalar(rng.uniform(-3.0, 3.0));
    const Mat3<Scalar> R = rotation_from_rpy(rx, ry, rz);
    KINCAL_CHECK(c, double((R * R.transpose() - Mat3<Scalar>::Identity()).norm()) < tol);
    KINCAL_CHECK(c, double((rpy_from_rotation(R) - Vec3<Scalar>(rx, ry, rz)).norm()) < 10 * tol);
    const Vec3<Scalar> w(Scalar(rng.uniform(-1, 1)), Scalar(rng.uniform(-1, 1)), Scalar(rng.uniform(-1, 1)));
    KINCAL_CHECK(c, double((log_so3(exp_so3(w)) - w).norm()) < 10 * tol);
    const Vec3<Scalar> tiny = w * Scalar(1e-6);
    KINCAL_CHECK(c, double((log_so3(exp_so3(tiny)) - tiny).norm()) < 1e-3 * double(tiny.norm()) + tol * 1e-3);
    Twist<Scalar> t;
    t << Scalar(rng.uniform(-1, 1)), Scalar(rng.uniform(-1, 1)), Scalar(rng.uniform(-1, 1)), w;
    const Pose<Scalar> p = Pose<Scalar>::from_xyz_rpy(Scalar(1), Scalar(2), Scalar(3), rx, ry, rz);
    KINCAL_CHECK(c, double((pose_error(apply_twist(p, t), p) - t).norm()) < 10 * tol);
    // R = Rz·Ry·Rx, checked element-wise against seed 001 Eq. (2) with α=rz, β=ry, γ=rx.
    const Scalar ca = std::cos(rz), sa = std::sin(rz), cb = std::cos(ry), sb = std::sin(ry), cg = std::cos(rx),
                 sg = std::sin(rx);
    KINCAL_CHECK(c, double(std::abs(R(0, 0) - ca * cb)) < tol);
    KINCAL_CHECK(c, double(std::abs(R(0, 1) - (ca * sb * sg - sa * cg))) < tol);
    KINCAL_CHECK(c, double(std::abs(R(1, 2) - (sa * sb * cg - ca * sg))) < tol);
    KINCAL_CHECK(c, double(std::abs(R(2, 0) + sb)) < tol);
  }
}

// --- small LU against Eigen's ------------------------------------------------
template <class Scalar> void check_small_lu(Checker& c) {
  Random rng(5);
  const double tol = sizeof(Scalar) == 8 ? 1e-10 : 1e-3;
  for (int k = 0; k < 100; ++k) {
    Mat6<Scalar> A;
    Vec6<Scalar> b;
    for (int i = 0; i < 6; ++i) {
      b(i) = Scalar(rng.uniform(-1, 1));
      for (int j = 0; j < 6; ++j) A(i, j) = Scalar(rng.uniform(-1, 1));
    }
    SmallLu<Scalar, 6> lu;
    if (!KINCAL_CHECK(c, lu.factor(A))) continue;
    const Vec6<Scalar> x = lu.solve(b);
    const Vec6<Scalar> ref = Eigen::PartialPivLU<Mat6<Scalar>>(A).solve(b);
    KINCAL_CHECK(c, double((x - ref).norm()) < tol * (1 + double(ref.norm())));
    KINCAL_CHECK(c, double((A * lu.inverse() - Mat6<Scalar>::Identity()).norm()) < tol * 10);
  }
  Mat6<Scalar> S = Mat6<Scalar>::Identity();
  S.row(4) = S.row(2) * Scalar(3);  // rank 5
  SmallLu<Scalar, 6> lu;
  KINCAL_CHECK(c, !factor_regular(lu, S));
  S(4, 4) = Scalar(1e-12);  // nearly singular
  KINCAL_CHECK(c, !factor_regular(lu, S));
  S(0, 0) = std::numeric_limits<Scalar>::quiet_NaN();
  KINCAL_CHECK(c, !lu.factor(S));
}

// --- stewart-seed001 ---------------------------------------------------------
// Workspace used for the round trips: ±20 mm in x, y; 190..225 mm in z; ±5°.
constexpr double kStewartLo[6] = {-20, -20, 190, -5 * kDeg, -5 * kDeg, -5 * kDeg};
constexpr double kStewartHi[6] = {20, 20, 225, 5 * kDeg, 5 * kDeg, 5 * kDeg};

template <class Scalar> void check_stewart_round_trip(Checker& c, int count) {
  const StewartGeometry<Scalar> g = make_stewart_seed001<Scalar>();
  Random rng(2026);
  int worst_iterations = 0;
  for (int k = 0; k < count; ++k) {
    const Pose<Scalar> pose = random_pose<Scalar>(rng, kStewartLo, kStewartHi);
    Vec6<Scalar> q;
    if (!KINCAL_CHECK(c, stewart_ik(g, pose, q) == Status::Ok)) continue;
    Pose<Scalar> back;
    const FkReport<Scalar> r = stewart_fk(g, q, back);  // from the home pose
    if (!KINCAL_CHECK(c, r.status == Status::Ok)) continue;
    worst_iterations = r.iterations > worst_iterations ? r.iterations : worst_iterations;
    KINCAL_CHECK(c, poses_close(back, pose, RoundTripTolerance<Scalar>::position_mm, RoundTripTolerance<Scalar>::angle_rad));
  }
  KINCAL_CHECK(c, worst_iterations <= 6);
}

// ∂q/∂twist of an IK against central differences of the same IK (in double;
// the Scalar Jacobian is checked against the double one). `ik(g, pose, q, J*)`
// is the machine's IK; poses are drawn in [lo, hi].
template <class Scalar, class Geometry, class Ik>
void check_ik_jacobian(Checker& c, const Geometry& g, Ik ik, const double lo[6], const double hi[6],
                       std::uint64_t seed, double fd_tolerance, double float_tolerance) {
  const auto gs = g.template cast<Scalar>();
  Random rng(seed);
  for (int k = 0; k < 50; ++k) {
    const Pose<double> pose = random_pose<double>(rng, lo, hi);
    Vec6<double> q;
    Mat6<double> J;
    if (!KINCAL_CHECK(c, ik(g, pose, q, &J) == Status::Ok)) continue;
    const double h = 1e-6;
    Mat6<double> fd;
    for (int j = 0; j < 6; ++j) {
      Twist<double> t = Twist<double>::Zero();
      t(j) = h;
      Vec6<double> qp, qm;
      ik(g, apply_twist(pose, t), qp, static_cast<Mat6<double>*>(nullptr));
      ik(g, apply_twist(pose, Twist<double>(-t)), qm, static_cast<Mat6<double>*>(nullptr));
      fd.col(j) = (qp - qm) / (2 * h);
    }
    KINCAL_CHECK(c, (fd - J).norm() < fd_tolerance * (1 + J.norm()));
    Vec6<Scalar> qs;
    Mat6<Scalar> Js;
    if (!KINCAL_CHECK(c, ik(gs, pose.template cast<Scalar>(), qs, &Js) == Status::Ok)) continue;
    KINCAL_CHECK(c, (Js.template cast<double>() - J).norm() <
                        (sizeof(Scalar) == 8 ? 1e-10 : float_tolerance) * (1 + J.norm()));
  }
}

// The first sign change of f on (0, 3.1] in steps of 0.01, bisected to
// rounding; 0 if there is none. Used to find singular configurations as zeros
// of det(J), an independent route to the Singular status.
template <class F> double first_sign_change(F f) {
  double lo = 0, flo = f(0.0);
  for (double x = 0.01; x < 3.1; x += 0.01) {
    if ((f(x) > 0) != (flo > 0)) {
      double hi = x;
      for (int i = 0; i < 80; ++i) {
        const double mid = 0.5 * (lo + hi);
        if ((f(mid) > 0) == (flo > 0)) lo = mid; else hi = mid;
      }
      return 0.5 * (lo + hi);
    }
    lo = x;
    flo = f(x);
  }
  return 0;
}

struct StewartIk {
  template <class S> Status operator()(const StewartGeometry<S>& g, const Pose<S>& p, Vec6<S>& q, Mat6<S>* J) const {
    return stewart_ik(g, p, q, J);
  }
};
struct HybridIk {
  template <class S> Status operator()(const HybridGeometry<S>& g, const Pose<S>& p, Vec6<S>& q, Mat6<S>* J) const {
    return hybrid_ik(g, p, q, J);
  }
};

template <class Scalar> void check_stewart_jacobian(Checker& c) {
  check_ik_jacobian<Scalar>(c, make_stewart_seed001<double>(), StewartIk(), kStewartLo, kStewartHi, 99, 1e-6, 1e-3);
}

// A pose where the 6-UPS Jacobian is singular: rotate about z at the home
// height until det(J) changes sign, then bisect (the classic torsional
// singularity of a hexapod). Returns the yaw angle, or 0 if none was found.
inline double find_stewart_singular_yaw() {
  const StewartGeometry<double> g = make_stewart_seed001<double>();
  return first_sign_change(
      [&](double yaw) { return stewart_jacobian(g, Pose<double>::from_xyz_rpy(0, 0, 200, 0, 0, yaw)).determinant(); });
}

template <class Scalar> void check_stewart_statuses(Checker& c) {
  StewartGeometry<Scalar> g = make_stewart_seed001<Scalar>();
  const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  Vec6<Scalar> q = Vec6<Scalar>::Constant(Scalar(-7));  // sentinel: must stay untouched on failure
  Mat6<Scalar> J = Mat6<Scalar>::Constant(Scalar(-7));
  auto untouched = [&] { return (q.array() == Scalar(-7)).all() && (J.array() == Scalar(-7)).all(); };
  using P = Pose<Scalar>;
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(nan, 0, 200, 0, 0, 0), q, &J) == Status::InvalidInput);
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(0, 0, 200, 0, inf, 0), q, &J) == Status::InvalidInput);
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(0, 0, 300, 0, 0, 0), q, &J) == Status::OutOfLimits);  // legs too long
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(0, 0, 120, 0, 0, 0), q, &J) == Status::OutOfLimits);  // legs too short
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(0, 0, -150, 0, 0, 0), q, &J) == Status::Unreachable);  // below the base
  KINCAL_CHECK(c, untouched());
  // Singular: widen the stroke so only the singularity can stop the IK.
  const double yaw = find_stewart_singular_yaw();
  KINCAL_CHECK(c, yaw > 0.1);
  g.min_length.setConstant(Scalar(1));
  g.max_length.setConstant(Scalar(1000));
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(0, 0, 200, 0, 0, Scalar(yaw)), q, &J) == Status::Singular);
  KINCAL_CHECK(c, untouched());
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(0, 0, 200, 0, 0, Scalar(yaw)), q) == Status::Ok);  // no Jacobian asked
  // FK failures, each with its own status; the output pose stays untouched.
  g = make_stewart_seed001<Scalar>();
  P out = P::from_xyz_rpy(-7, -7, -7, 0, 0, 0);
  const Vec3<Scalar> sentinel = out.p;
  Vec6<Scalar> good;
  KINCAL_CHECK(c, stewart_ik(g, P::from_xyz_rpy(10, 5, 205, Scalar(2 * kDeg), Scalar(1.5 * kDeg), Scalar(-3 * kDeg)), good) == Status::Ok);
  Vec6<Scalar> bad = good;
  bad(3) = nan;
  KINCAL_CHECK(c, stewart_fk(g, bad, out).status == Status::InvalidInput);
  bad = good;
  bad(0) = Scalar(500);
  KINCAL_CHECK(c, stewart_fk(g, bad, out).status == Status::OutOfLimits);
  FkOptions<Scalar> one_step;
  one_step.max_iterations = 1;
  const FkReport<Scalar> r1 = stewart_fk(g, good, g.home, out, one_step);
  KINCAL_CHECK(c, r1.status == Status::NotConverged && r1.iterations == 1);
  KINCAL_CHECK(c, out.p == sentinel);
  // GUIDE bar: from home to (10, 5, 205, 2°, 1.5°, −3°) in ≤ 5 iterations.
  const FkReport<Scalar> r = stewart_fk(g, good, out);
  KINCAL_CHECK(c, r.status == Status::Ok && r.iterations <= 5);
}

// --- hybrid-seed000 ----------------------------------------------------------
// The task cuboid 500 × 500 × 120 mm about the reference pose, with the tool
// orientation varied by ±5° (beyond the paper's pure translation, to exercise
// the wrist).
constexpr double kHybridLo[6] = {-250, -250, -60, -5 * kDeg, -5 * kDeg, -5 * kDeg};
constexpr double kHybridHi[6] = {250, 250, 60, 5 * kDeg, 5 * kDeg, 5 * kDeg};

template <class Scalar> void check_hybrid_round_trip(Checker& c, int count) {
  const HybridGeometry<Scalar> g = make_hybrid_seed000<Scalar>();
  Random rng(1949);
  for (int k = 0; k < count; ++k) {
    const Pose<Scalar> pose = random_pose<Scalar>(rng, kHybridLo, kHybridHi);
    Vec6<Scalar> q;
    if (!KINCAL_CHECK(c, hybrid_ik(g, pose, q) == Status::Ok)) continue;
    Pose<Scalar> back;
    const FkReport<Scalar> r = hybrid_fk(g, q, back);  // from the home configuration
    if (!KINCAL_CHECK(c, r.status == Status::Ok)) continue;
    KINCAL_CHECK(c, r.iterations <= 6);
    // The hybrid is ~1.6 m from base to tool: float tolerance scales with it.
    const double scale = sizeof(Scalar) == 8 ? 20.0 : 25.0;
    KINCAL_CHECK(c, poses_close(back, pose, scale * RoundTripTolerance<Scalar>::position_mm,
                                scale * RoundTripTolerance<Scalar>::angle_rad));
  }
  // The reference pose is the task-cuboid centre with z5 ∥ y and z6 ∥ x of {R}.
  Vec6<Scalar> q;
  HybridPassive<Scalar> s;
  KINCAL_CHECK(c, hybrid_ik(g, Pose<Scalar>(), q, nullptr, &s) == Status::Ok);
  const HybridFrames<Scalar> f = hybrid_frames(g, s, Vec3<Scalar>(q.template tail<3>()));
  const double tol = sizeof(Scalar) == 8 ? 1e-12 : 1e-5;
  KINCAL_CHECK(c, double((g.workpiece_rotation * f.F5.col(0) - Vec3<Scalar>::UnitY()).norm()) < tol);
  KINCAL_CHECK(c, double((g.workpiece_rotation * f.F6.col(1) - Vec3<Scalar>::UnitX()).norm()) < tol);
  KINCAL_CHECK(c, std::abs(double(q(4)) - 3.14159265358979323846 / 6) < tol);  // θ5 = β turns the tool vertical
}

template <class Scalar> void check_hybrid_jacobian(Checker& c) {
  check_ik_jacobian<Scalar>(c, make_hybrid_seed000<double>(), HybridIk(), kHybridLo, kHybridHi, 4242, 1e-5, 2e-2);
}

// A wrist configuration where the hybrid's forward Jacobian loses rank: scan
// θ5 at the reference until det changes sign, then bisect. Returns θ5 or 0.
inline double find_hybrid_singular_theta5() {
  const HybridGeometry<double> g = make_hybrid_seed000<double>();
  return first_sign_change([&](double t5) {
    Mat6<double> J;
    hybrid_forward_jacobian(g, hybrid_frames(g, g.home, Vec3<double>(0, t5, 0)), J);
    return J.determinant();
  });
}

template <class Scalar> void check_hybrid_statuses(Checker& c) {
  HybridGeometry<Scalar> g = make_hybrid_seed000<Scalar>();
  const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  Vec6<Scalar> q = Vec6<Scalar>::Constant(Scalar(-7));
  Mat6<Scalar> J = Mat6<Scalar>::Constant(Scalar(-7));
  auto untouched = [&] { return (q.array() == Scalar(-7)).all() && (J.array() == Scalar(-7)).all(); };
  using P = Pose<Scalar>;
  KINCAL_CHECK(c, hybrid_ik(g, P::from_xyz_rpy(0, nan, 0, 0, 0, 0), q, &J) == Status::InvalidInput);
  KINCAL_CHECK(c, hybrid_ik(g, P::from_xyz_rpy(0, 0, -400, 0, 0, 0), q, &J) == Status::OutOfLimits);  // UPS too long
  KINCAL_CHECK(c, hybrid_ik(g, P::from_xyz_rpy(600, 0, 0, 0, 0, 0), q, &J) == Status::OutOfLimits);
  // Unreachable: a tool pose whose wrist centre P0 sits at A0, so the limb
  // line is undefined.
  {
    const Mat3<Scalar> F6 = g.workpiece_rotation.transpose() * g.tool_offset.transpose();  // orientation 0
    const Vec3<Scalar> tip = F6.col(2) * g.tool_length;  // P0 = P − l_t·F6·z = A0
    P pose;
    pose.p = g.workpiece_rotation * (tip - g.workpiece_origin);
    KINCAL_CHECK(c, hybrid_ik(g, pose, q, &J) == Status::Unreachable);
  }
  KINCAL_CHECK(c, untouched());
  // Singular: at a wrist angle where det(J_f) changes sign (limits widened so
  // that only the singularity can stop the IK).
  const double t5 = find_hybrid_singular_theta5();
  KINCAL_CHECK(c, t5 > 0.1);
  g.min_joint.setConstant(Scalar(-1e4));
  g.max_joint.setConstant(Scalar(1e4));
  const P singular = hybrid_tool_pose(g, hybrid_frames(g, g.home, Vec3<Scalar>(Scalar(0), Scalar(t5), Scalar(0))));
  KINCAL_CHECK(c, hybrid_ik(g, singular, q, &J) == Status::Singular);
  KINCAL_CHECK(c, untouched());
  // FK failures.
  g = make_hybrid_seed000<Scalar>();
  Vec6<Scalar> good;
  KINCAL_CHECK(c, hybrid_ik(g, P::from_xyz_rpy(100, -50, 20, 0, 0, 0), good) == Status::Ok);
  P out = P::from_xyz_rpy(-7, -7, -7, 0, 0, 0);
  Vec6<Scalar> bad = good;
  bad(4) = nan;
  KINCAL_CHECK(c, hybrid_fk(g, bad, out).status == Status::InvalidInput);
  bad = good;
  bad(1) = Scalar(2000);
  KINCAL_CHECK(c, hybrid_fk(g, bad, out).status == Status::OutOfLimits);
  FkOptions<Scalar> one_step;
  one_step.max_iterations = 1;
  KINCAL_CHECK(c, hybrid_fk(g, good, g.home, out, nullptr, one_step).status == Status::NotConverged);
  KINCAL_CHECK(c, out.p == Vec3<Scalar>(Scalar(-7), Scalar(-7), Scalar(-7)));
}

// --- compensation (core/compensation.hpp) -------------------------------------
// The parameter table's CRC computed at run time on this target equals the
// compile-time value (byte order, IEEE layout), and the hybrid's compensation
// with encoder offsets: each command driven through the controller geometry's
// FK reaches the requested pose; a NaN point and a corrupt table each give
// their status and hold the output.
struct CompensationCheckValues {
  double v[table_value_count<StewartMachine<double>>()];
};
constexpr CompensationCheckValues compensation_check_values() {
  CompensationCheckValues c{};
  for (int k = 0; k < int(table_value_count<StewartMachine<double>>()); ++k) c.v[k] = double(k % 7 - 3) * 0.125 + double(k) * 1e-3;
  return c;
}
constexpr CompensationCheckValues kCompensationCheckValues = compensation_check_values();

template <class Scalar> void check_compensation(Checker& c) {
  using CS = CompensationStatus;
  {
    static constexpr StewartCalibrationTable<Scalar> fixed =
        table_from_values<StewartMachine<Scalar>>(kCompensationCheckValues.v, 0u);
    constexpr std::uint32_t compile_time = table_crc(fixed);
    static StewartCalibrationTable<Scalar> copy;  // static: tables stay off the stack
    copy = fixed;
    volatile Scalar touch = copy.bounds.max_joint[5];  // keep the run-time CRC a run-time one
    copy.bounds.max_joint[5] = touch;
    KINCAL_CHECK(c, table_crc(copy) == compile_time);
  }
  // Static and built in place: a table is 1.1 (float) to 2.3 KiB (double).
  static HybridCalibrationTable<Scalar> table = nominal_table(make_hybrid_seed000<Scalar>());
  table.machine.source_errors[77] = Scalar(0);
  const Scalar xi[6] = {Scalar(0.3), Scalar(-0.25), Scalar(0.2), Scalar(5e-4), Scalar(-4e-4), Scalar(3e-4)};
  for (int i = 0; i < 6; ++i) table.machine.encoder_offsets[i] = xi[i];
  seal(table);
  KINCAL_CHECK(c, validate_table(table) == CS::Ok);
  const HybridCompensator<Scalar> comp(table, trust_table_bounds);
  HybridGeometry<Scalar> controller = to_core(table.machine.nominal);
  for (int i = 0; i < 6; ++i) controller.joint_offset(i) += xi[i];
  Vec6<Scalar> home, q;
  KINCAL_CHECK(c, comp.home_command(home) == CS::Ok);
  CompensatorState<Scalar> state = comp.start(home);
  Random rng(5);
  for (int k = 0; k < 20; ++k) {
    const Pose<Scalar> pose = random_pose<Scalar>(rng, kHybridLo, kHybridHi);
    if (!KINCAL_CHECK(c, comp.compensate(state, pose, q) == CS::Ok)) continue;
    Pose<Scalar> reached;
    if (!KINCAL_CHECK(c, hybrid_fk(controller, q, reached).status == Status::Ok)) continue;
    const double scale = sizeof(Scalar) == 8 ? 20.0 : 25.0;
    KINCAL_CHECK(c, poses_close(reached, pose, scale * RoundTripTolerance<Scalar>::position_mm,
                                scale * RoundTripTolerance<Scalar>::angle_rad));
  }
  const Vec6<Scalar> held = state.command;
  const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  KINCAL_CHECK(c, comp.compensate(state, Pose<Scalar>::from_xyz_rpy(nan, 0, 0, 0, 0, 0), q) == CS::InvalidInput);
  KINCAL_CHECK(c, q == held && state.count(CS::InvalidInput) == 1u && state.count(CS::Ok) == 20u);
  table.machine.source_errors[77] = Scalar(1e-3);  // not resealed: corrupt
  KINCAL_CHECK(c, validate_table(table) == CS::TableCrc);
  // (A compensator on it reports TableCrc and holds: core_compensation_test.)
  table.machine.source_errors[77] = Scalar(0);
  seal(table);
}

// Everything for one scalar; `round_trips` poses per machine.
template <class Scalar> void run_core_checks(Checker& c, int round_trips) {
  check_pose_math<Scalar>(c);
  check_small_lu<Scalar>(c);
  check_stewart_round_trip<Scalar>(c, round_trips);
  check_stewart_jacobian<Scalar>(c);
  check_stewart_statuses<Scalar>(c);
  check_hybrid_round_trip<Scalar>(c, round_trips);
  check_hybrid_jacobian<Scalar>(c);
  check_hybrid_statuses<Scalar>(c);
  check_compensation<Scalar>(c);
}

}  // namespace kincal::test
