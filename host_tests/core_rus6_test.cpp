// 6-RUS kinematics (core/rus6.hpp) on `rus6-ref` and on a custom machine of
// another size with irregular motor axes: IK → FK round trips over the
// workspace, the closed-form IK against a 1-D root search on each leg's
// closure written here from the model's definition, both Jacobians against
// finite differences and each other, one status per failure with outputs
// untouched, the branch rule, and no heap — in double and in float.
#include <cstdio>
#include <cstdlib>

#include "eigen_no_malloc.hpp"  // first: before anything includes Eigen

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "kincal/core/reference_machines.hpp"

using namespace kincal;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Explicit instantiation: every template compiles for both scalars.
}  // namespace
namespace kincal {
template struct Rus6Geometry<double>;
template struct Rus6Geometry<float>;
template Status rus6_ik<Rus6Geometry<double>, double>(const Rus6Geometry<double>&, const Pose<double>&, Vec6<double>&, Mat6<double>*,
                                Rus6Legs<double>*);
template Status rus6_ik<Rus6Geometry<float>, float>(const Rus6Geometry<float>&, const Pose<float>&, Vec6<float>&, Mat6<float>*,
                               Rus6Legs<float>*);
template Status rus6_ik<Rus6Geometry<double>, double>(const Rus6Geometry<double>&, const Pose<double>&, Vec6<double>&,
                                                      Mat6<double>*, double*);
template Status rus6_ik<Rus6Geometry<float>, float>(const Rus6Geometry<float>&, const Pose<float>&, Vec6<float>&,
                                                    Mat6<float>*, float*);
template FkReport<double> rus6_fk<double>(const Rus6Geometry<double>&, const Vec6<double>&, const Pose<double>&,
                                          Pose<double>&, const FkOptions<double>&);
template FkReport<float> rus6_fk<float>(const Rus6Geometry<float>&, const Vec6<float>&, const Pose<float>&,
                                        Pose<float>&, const FkOptions<float>&);
template Status rus6_forward_jacobian<double>(const Rus6Geometry<double>&, const Rus6Legs<double>&, Mat6<double>&);
template Status rus6_forward_jacobian<float>(const Rus6Geometry<float>&, const Rus6Legs<float>&, Mat6<float>&);
}  // namespace kincal

namespace {

struct HeapForbidden {
  HeapForbidden() { Eigen::internal::set_is_malloc_allowed(false); }
  ~HeapForbidden() { Eigen::internal::set_is_malloc_allowed(true); }
};

// The workspace the reference machine is sized for: ±40 mm, ±10° about home.
constexpr double kBoxMm = 40.0, kBoxRad = 10.0 * kDeg;

template <class Scalar> Pose<Scalar> offset_pose(const Pose<double>& home, const double off[6]) {
  const Pose<double> p = Pose<double>::from_xyz_rpy(home.p.x() + off[0], home.p.y() + off[1], home.p.z() + off[2],
                                                    off[3], off[4], off[5]);
  return p.cast<Scalar>();
}

// The 64 corners of the box, then uniform random poses inside it.
std::vector<std::array<double, 6>> box_offsets(int random_count, double mm, double rad, unsigned seed) {
  std::vector<std::array<double, 6>> out;
  for (int corner = 0; corner < 64; ++corner) {
    std::array<double, 6> o;
    for (int k = 0; k < 6; ++k) o[k] = ((corner >> k) & 1 ? 1.0 : -1.0) * (k < 3 ? mm : rad);
    out.push_back(o);
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int n = 0; n < random_count; ++n) {
    std::array<double, 6> o;
    for (int k = 0; k < 6; ++k) o[k] = unit(rng) * (k < 3 ? mm : rad);
    out.push_back(o);
  }
  return out;
}

double position_error(const Pose<double>& a, const Pose<double>& b) { return (a.p - b.p).norm(); }
double angle_error(const Pose<double>& a, const Pose<double>& b) { return log_so3(Mat3<double>(a.R * b.R.transpose())).norm(); }

// ---- an IK written from the model's definition, independently of rus6.hpp ---
// The crank tip by Rodrigues' rotation of crank_zero about the shaft axis
// (not the cos/sin-in-a-basis form rus6.hpp uses), the closure residual
// f(θ) = |R·p + t − C(θ)| − ℓ, every sign change on a fine grid over the
// joint range refined by bisection. Returns the roots inside the limits, as
// commands q = θ − offset.
Vec3<double> tip_by_rodrigues(const Rus6Geometry<double>& g, int i, double theta) {
  const Vec3<double> a = g.shaft_axes.col(i), z = g.crank_zero.col(i);
  const Vec3<double> turned = std::cos(theta) * z + std::sin(theta) * a.cross(z) + (1 - std::cos(theta)) * a.dot(z) * a;
  return g.shaft_points.col(i) + g.crank_length(i) * turned;
}

std::vector<double> closure_roots(const Rus6Geometry<double>& g, const Pose<double>& pose, int i) {
  const Vec3<double> sphere = pose.R * g.platform_joints.col(i) + pose.p;
  auto f = [&](double q) { return (sphere - tip_by_rodrigues(g, i, q + g.joint_offset(i))).norm() - g.rod_length(i); };
  std::vector<double> roots;
  const int steps = 2000;
  const double lo = g.min_joint(i), hi = g.max_joint(i), h = (hi - lo) / steps;
  double a = lo, fa = f(a);
  for (int k = 1; k <= steps; ++k) {
    const double b = lo + k * h, fb = f(b);
    if (fa == 0) roots.push_back(a);
    else if (fa * fb < 0) {
      double x0 = a, x1 = b, f0 = fa;
      for (int it = 0; it < 80; ++it) {
        const double m = 0.5 * (x0 + x1), fm = f(m);
        if ((fm < 0) == (f0 < 0)) x0 = m, f0 = fm;
        else x1 = m;
      }
      roots.push_back(0.5 * (x0 + x1));
    }
    a = b, fa = fb;
  }
  return roots;
}

// ---- a custom machine: twice the size, irregular, per-leg dimensions ------
// Built from the reference layout ×2, each shaft axis tilted by up to 12°
// about a random direction (crank_zero re-orthogonalised to it), spheres
// moved by up to 15 mm, crank lengths 170–230 mm, home angles θ_home of up
// to ±15° and encoder offsets of up to ±0.05 rad; each rod is then cut to
// close the loop at the home pose with those angles, and the limits are
// θ_home ± 60° on the command.
Rus6Geometry<double> make_custom_machine(Vec6<double>* home_commands) {
  Rus6Geometry<double> g = make_rus6_ref<double>();
  std::mt19937 rng(33);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  g.shaft_points *= 2.0;
  g.platform_joints *= 2.0;
  g.home.p *= 2.0;
  g.home = Pose<double>::from_xyz_rpy(5.0, -8.0, g.home.p.z(), 2 * kDeg, -1 * kDeg, 3 * kDeg);
  g.characteristic_length = 260.0;
  Vec6<double> q_home = Vec6<double>::Zero();
  for (int i = 0; i < 6; ++i) {
    const Vec3<double> tilt_axis = Vec3<double>(unit(rng), unit(rng), unit(rng)).normalized();
    const Vec3<double> a = (exp_so3(Vec3<double>(tilt_axis * (12 * kDeg * unit(rng)))) * g.shaft_axes.col(i)).normalized();
    Vec3<double> z = g.crank_zero.col(i);
    z = (z - z.dot(a) * a).normalized();
    g.shaft_axes.col(i) = a;
    g.crank_zero.col(i) = z;
    g.shaft_points.col(i) += Vec3<double>(unit(rng), unit(rng), unit(rng)) * 10.0;
    g.platform_joints.col(i) += Vec3<double>(unit(rng), unit(rng), unit(rng)) * 15.0;
    g.crank_length(i) = 200.0 + 30.0 * unit(rng);
    g.joint_offset(i) = 0.05 * unit(rng);
    const double theta_home = 15 * kDeg * unit(rng);
    q_home(i) = theta_home - g.joint_offset(i);
    const Vec3<double> sphere = g.home.R * g.platform_joints.col(i) + g.home.p;
    g.rod_length(i) = (sphere - tip_by_rodrigues(g, i, theta_home)).norm();
    g.min_joint(i) = q_home(i) - 60 * kDeg;
    g.max_joint(i) = q_home(i) + 60 * kDeg;
  }
  g.home_branch.setZero();
  Vec6<double> branches = Vec6<double>::Zero();
  if (rus6_home_branches(g, branches) == Status::Ok) g.home_branch = branches;
  if (home_commands != nullptr) *home_commands = q_home;
  return g;
}

// ---- round trip over a box, one scalar ----------------------------------
struct RoundTripStats {
  int ok = 0, total = 0, max_iterations = 0;
  double worst_mm = 0, worst_rad = 0;
};

template <class Scalar>
RoundTripStats round_trip(const Rus6Geometry<double>& gd, double mm, double rad, int count, unsigned seed) {
  const Rus6Geometry<Scalar> g = gd.cast<Scalar>();
  RoundTripStats s;
  for (const auto& off : box_offsets(count, mm, rad, seed)) {
    const Pose<Scalar> target = offset_pose<Scalar>(gd.home, off.data());
    Vec6<Scalar> q = Vec6<Scalar>::Zero();
    ++s.total;
    if (rus6_ik(g, target, q) != Status::Ok) continue;
    Pose<Scalar> found;
    const FkReport<Scalar> r = rus6_fk(g, q, g.home, found);
    if (r.status != Status::Ok) continue;
    ++s.ok;
    s.max_iterations = std::max(s.max_iterations, r.iterations);
    const Pose<double> fd = found.template cast<double>(), td = target.template cast<double>();
    s.worst_mm = std::max(s.worst_mm, position_error(fd, td));
    s.worst_rad = std::max(s.worst_rad, angle_error(fd, td));
  }
  return s;
}

}  // namespace

// ---- the reference machine -------------------------------------------------

TEST(CoreRus6, ReferenceMachineIsValidAndHomeHasHorizontalCranks) {
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  ASSERT_TRUE(rus6_valid_geometry(g));
  EXPECT_NEAR(g.home.p.z(), 274.0438, 1e-4);
  Vec6<double> q = Vec6<double>::Zero();
  Rus6Legs<double> legs;
  ASSERT_EQ(rus6_ik(g, g.home, q, nullptr, &legs), Status::Ok);
  EXPECT_LT(q.cwiseAbs().maxCoeff(), 1e-12);  // θ = 0: cranks horizontal
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR((legs.crank_tips.col(i) - g.shaft_points.col(i)).z(), 0.0, 1e-12);
    EXPECT_NEAR(legs.rod_lengths(i), 300.0, 1e-10);
    EXPECT_EQ(g.home_branch(i), -1.0);  // rod above the crank: λ > 0
    EXPECT_GT(legs.levers(i), 0.0);
  }
}

TEST(CoreRus6, WorkspaceBoxReachableInsideLimits) {
  // Every corner of the ±40 mm / ±10° box and 5000 poses inside it have an IK
  // solution inside the limits, with margin to the limits and to the serial
  // singularity, and with the other branch outside the limits (so the limits
  // alone pick the branch).
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  double lowest = 0, highest = 0, smallest_lever = 1e9, other_branch_nearest = 1e9;
  for (const auto& off : box_offsets(5000, kBoxMm, kBoxRad, 1)) {
    const Pose<double> pose = offset_pose<double>(g.home, off.data());
    Vec6<double> q = Vec6<double>::Zero();
    Rus6Legs<double> legs;
    Mat6<double> J;
    ASSERT_EQ(rus6_ik(g, pose, q, &J, &legs), Status::Ok);
    lowest = std::min(lowest, q.minCoeff());
    highest = std::max(highest, q.maxCoeff());
    smallest_lever = std::min(smallest_lever, legs.levers.minCoeff() / 100.0);
    for (int i = 0; i < 6; ++i) {
      const std::vector<double> roots = closure_roots(g, pose, i);
      ASSERT_EQ(roots.size(), 1u) << "leg " << i;  // one branch inside the limits
    }
    Rus6Geometry<double> wide = g;
    wide.min_joint.setConstant(-3.14159);
    wide.max_joint.setConstant(3.14159);
    for (int i = 0; i < 6; ++i) {
      const std::vector<double> all = closure_roots(wide, pose, i);
      for (double r : all)
        if (std::abs(r - q(i)) > 1e-6) other_branch_nearest = std::min(other_branch_nearest, std::abs(r));
    }
  }
  std::printf("box: theta %.2f..%.2f deg, min lever/crank %.3f, other branch >= %.1f deg\n", lowest / kDeg,
              highest / kDeg, smallest_lever, other_branch_nearest / kDeg);
  EXPECT_GT(lowest, g.min_joint(0) + 5 * kDeg);
  EXPECT_LT(highest, g.max_joint(0) - 5 * kDeg);
  EXPECT_GT(smallest_lever, 0.2);
  EXPECT_GT(other_branch_nearest, 100 * kDeg);
}

TEST(CoreRus6, ClosedFormIkAgreesWithRootSearchOnEachLeg) {
  for (int machine = 0; machine < 2; ++machine) {
    const Rus6Geometry<double> g = machine == 0 ? make_rus6_ref<double>() : make_custom_machine(nullptr);
    const double mm = machine == 0 ? kBoxMm : 30.0, rad = machine == 0 ? kBoxRad : 6 * kDeg;
    int compared = 0;
    for (const auto& off : box_offsets(300, mm, rad, 7)) {
      const Pose<double> pose = offset_pose<double>(g.home, off.data());
      Vec6<double> q = Vec6<double>::Zero();
      const Status st = rus6_ik(g, pose, q);
      for (int i = 0; i < 6; ++i) {
        const std::vector<double> roots = closure_roots(g, pose, i);
        if (st == Status::Ok) {
          ASSERT_GE(roots.size(), 1u);
          double nearest = 1e9;
          for (double r : roots) nearest = std::min(nearest, std::abs(r - q(i)));
          EXPECT_LT(nearest, 1e-9) << "machine " << machine << " leg " << i;
          ++compared;
        }
      }
      if (st == Status::OutOfLimits) {  // then some leg has no root inside its limits
        bool some_leg_without = false;
        for (int i = 0; i < 6; ++i) some_leg_without |= closure_roots(g, pose, i).empty();
        EXPECT_TRUE(some_leg_without);
      }
    }
    EXPECT_GT(compared, 6 * 300) << "machine " << machine;
  }
}

TEST(CoreRus6, RoundTripDouble) {
  const RoundTripStats s = round_trip<double>(make_rus6_ref<double>(), kBoxMm, kBoxRad, 5000, 11);
  std::printf("double: %d/%d, worst %.3g mm %.3g rad, max %d iterations from home\n", s.ok, s.total, s.worst_mm,
              s.worst_rad, s.max_iterations);
  EXPECT_EQ(s.ok, s.total);
  EXPECT_LE(s.worst_mm, 1e-9);
  EXPECT_LE(s.worst_rad, 1e-11);
}

TEST(CoreRus6, RoundTripFloat) {
  const RoundTripStats s = round_trip<float>(make_rus6_ref<double>(), kBoxMm, kBoxRad, 5000, 12);
  std::printf("float: %d/%d, worst %.3g mm %.3g rad, max %d iterations from home\n", s.ok, s.total, s.worst_mm,
              s.worst_rad, s.max_iterations);
  EXPECT_EQ(s.ok, s.total);
  EXPECT_LE(s.worst_mm, 1e-3);
  EXPECT_LE(s.worst_rad, 1e-5);
}

TEST(CoreRus6, FloatReferenceMatchesDouble) {
  // make_rus6_ref<float> is the double machine rounded, and its IK agrees
  // with the double IK to float precision.
  const Rus6Geometry<double> gd = make_rus6_ref<double>();
  const Rus6Geometry<float> gf = make_rus6_ref<float>();
  EXPECT_TRUE(rus6_valid_geometry(gf));
  EXPECT_LT((gf.shaft_points.cast<double>() - gd.shaft_points).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_EQ(gf.home_branch.cast<double>(), gd.home_branch);
  double worst = 0;
  for (const auto& off : box_offsets(500, kBoxMm, kBoxRad, 13)) {
    Vec6<double> qd = Vec6<double>::Zero();
    Vec6<float> qf = Vec6<float>::Zero();
    ASSERT_EQ(rus6_ik(gd, offset_pose<double>(gd.home, off.data()), qd), Status::Ok);
    ASSERT_EQ(rus6_ik(gf, offset_pose<float>(gd.home, off.data()), qf), Status::Ok);
    worst = std::max(worst, (qf.cast<double>() - qd).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 2e-5);  // rad; float carries ~7 digits of a 300 mm loop
}

TEST(CoreRus6, FkFromPreviousPoseTracksAPath) {
  // A controller calls FK with the last pose as the guess: along a 1 mm /
  // 0.05° step path it needs few iterations.
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  Pose<double> previous = g.home;
  int worst_iterations = 0;
  for (int k = 1; k <= 200; ++k) {
    const double s = k / 200.0;
    const double off[6] = {30 * std::sin(6.28 * s), 30 * std::cos(6.28 * s) - 30, 20 * s, 8 * kDeg * s, -5 * kDeg * s,
                           7 * kDeg * std::sin(3.14 * s)};
    const Pose<double> target = offset_pose<double>(g.home, off);
    Vec6<double> q = Vec6<double>::Zero();
    ASSERT_EQ(rus6_ik(g, target, q), Status::Ok);
    Pose<double> found;
    const FkReport<double> r = rus6_fk(g, q, previous, found);
    ASSERT_EQ(r.status, Status::Ok);
    EXPECT_LT(position_error(found, target), 1e-9);
    worst_iterations = std::max(worst_iterations, r.iterations);
    previous = found;
  }
  std::printf("tracking: at most %d iterations per step\n", worst_iterations);
  EXPECT_LE(worst_iterations, 3);
}

TEST(CoreRus6, FkFromHomeToGuideBarPose) {
  // The GUIDE's 6-UPS FK bar pose moved to this machine's home height:
  // (10, 5, home + 5, 2°, 1.5°, −3°) from home.
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  const Pose<double> target =
      Pose<double>::from_xyz_rpy(10, 5, g.home.p.z() + 5, 2 * kDeg, 1.5 * kDeg, -3 * kDeg);
  Vec6<double> q = Vec6<double>::Zero();
  ASSERT_EQ(rus6_ik(g, target, q), Status::Ok);
  Pose<double> found;
  const FkReport<double> r = rus6_fk(g, q, found);
  ASSERT_EQ(r.status, Status::Ok);
  std::printf("FK home -> bar pose: %d iterations, residual %.3g mm, error %.3g mm\n", r.iterations, r.residual,
              position_error(found, target));
  EXPECT_LE(r.iterations, 5);
  EXPECT_LT(position_error(found, target), 1e-10);
}

TEST(CoreRus6, FkFromHomeOverTheBoxInAtMostFiveStepsToTheIkPose) {
  // Random poses over the whole test box, each solved from home (a cold
  // start): the chord steps near the solution (six_distance_fk) must not
  // cost a step or accuracy anywhere, in double and in float.
  const Rus6Geometry<double> gd = make_rus6_ref<double>();
  const Rus6Geometry<float> gf = gd.cast<float>();
  int worst_d = 0, worst_f = 0;
  double error_d = 0, error_f = 0;
  for (const auto& off : box_offsets(300, kBoxMm, kBoxRad, 29)) {
    const Pose<double> target = offset_pose<double>(gd.home, off.data());
    Vec6<double> qd = Vec6<double>::Zero();
    ASSERT_EQ(rus6_ik(gd, target, qd), Status::Ok);
    Pose<double> found;
    const FkReport<double> rd = rus6_fk(gd, qd, found);
    ASSERT_EQ(rd.status, Status::Ok);
    worst_d = std::max(worst_d, rd.iterations);
    error_d = std::max(error_d, position_error(found, target));
    Pose<float> found_f;
    const FkReport<float> rf = rus6_fk(gf, Vec6<float>(qd.cast<float>()), found_f);
    ASSERT_EQ(rf.status, Status::Ok);
    worst_f = std::max(worst_f, rf.iterations);
    error_f = std::max(error_f, position_error(found_f.template cast<double>(), target));
  }
  std::printf("FK from home over the box: double <= %d steps, %.3g mm; float <= %d steps, %.3g mm\n", worst_d, error_d,
              worst_f, error_f);
  EXPECT_LE(worst_d, 5);
  EXPECT_LE(worst_f, 4);
  EXPECT_LT(error_d, 1e-9);
  EXPECT_LT(error_f, 5e-4);  // float: ~7 digits of a 300 mm loop, through q rounded to float
}

// ---- Jacobians ---------------------------------------------------------------

template <class Scalar> void check_inverse_jacobian_against_differences(double h, double tol) {
  // Column k of ∂q/∂twist by central differences of the IK along the twist
  // e_k applied with apply_twist (the twist convention of pose.hpp).
  const Rus6Geometry<double> gd = make_rus6_ref<double>();
  const Rus6Geometry<Scalar> g = gd.cast<Scalar>();
  double worst = 0;
  for (const auto& off : box_offsets(100, kBoxMm, kBoxRad, 21)) {
    const Pose<Scalar> pose = offset_pose<Scalar>(gd.home, off.data());
    Vec6<Scalar> q = Vec6<Scalar>::Zero();
    Mat6<Scalar> J;
    ASSERT_EQ(rus6_ik(g, pose, q, &J), Status::Ok);
    for (int k = 0; k < 6; ++k) {
      // h in mm for v, in rad (× 1/100 mm) for ω: similar joint changes.
      const Scalar step = Scalar(k < 3 ? h : h / 100);
      Vec6<Scalar> qp = Vec6<Scalar>::Zero(), qm = Vec6<Scalar>::Zero();
      ASSERT_EQ(rus6_ik(g, apply_twist(pose, Twist<Scalar>(Twist<Scalar>::Unit(k) * step)), qp), Status::Ok);
      ASSERT_EQ(rus6_ik(g, apply_twist(pose, Twist<Scalar>(Twist<Scalar>::Unit(k) * -step)), qm), Status::Ok);
      const Vec6<double> numeric = ((qp - qm) / (Scalar(2) * step)).template cast<double>();
      const Vec6<double> analytic = J.col(k).template cast<double>();
      worst = std::max(worst, (numeric - analytic).cwiseAbs().maxCoeff() / (1e-3 + analytic.cwiseAbs().maxCoeff()));
    }
  }
  std::printf("%s inverse Jacobian vs differences: worst relative %.3g\n", sizeof(Scalar) == 8 ? "double" : "float",
              worst);
  EXPECT_LT(worst, tol);
}

TEST(CoreRus6, InverseJacobianMatchesFiniteDifferencesDouble) {
  check_inverse_jacobian_against_differences<double>(1e-4, 1e-7);
}
TEST(CoreRus6, InverseJacobianMatchesFiniteDifferencesFloat) {
  check_inverse_jacobian_against_differences<float>(0.5, 2e-2);
}

// The numbers the family offers formulas (rus6_formula_joint_values):
// `rod` is the geometry's rod, and `lever` is what the IK says a rod's
// length is worth in crank angle — central differences of the closed-form
// IK in each rod's length (another route: no lever is computed there), at
// the box's corners and random poses, on both machines. A rod longer by δ
// is commanded δ/λ less: dq_i/dℓ_i = −1/λ_i.
TEST(CoreRus6, FormulaLeverIsTheIksSensitivityToTheRod) {
  for (int machine = 0; machine < 2; ++machine) {
    const Rus6Geometry<double> g = machine == 0 ? make_rus6_ref<double>() : make_custom_machine(nullptr);
    double worst = 0;
    int used = 0;
    for (const auto& o : box_offsets(40, kBoxMm, kBoxRad, 71 + machine)) {
      const Pose<double> pose = offset_pose<double>(g.home, o.data());
      double values[12];
      // The values exist where the IK does: a corner of the box can lie a
      // rounding past a joint limit (clang's Debug build), and then both
      // say OutOfLimits.
      Vec6<double> q = Vec6<double>::Zero();
      const Status ik = rus6_ik(g, pose, q);
      ASSERT_EQ(rus6_formula_joint_values(g, pose, values), ik);
      if (ik != Status::Ok) continue;
      ++used;
      for (int i = 0; i < 6; ++i) {
        EXPECT_EQ(values[i], g.rod_length(i));
        const double h = 1e-4;
        Rus6Geometry<double> longer = g, shorter = g;
        longer.rod_length(i) += h;
        shorter.rod_length(i) -= h;
        Vec6<double> qp = Vec6<double>::Zero(), qm = Vec6<double>::Zero();
        ASSERT_EQ(rus6_ik(longer, pose, qp), Status::Ok);
        ASSERT_EQ(rus6_ik(shorter, pose, qm), Status::Ok);
        const double dq_dl = (qp(i) - qm(i)) / (2 * h);
        worst = std::max(worst, std::abs(dq_dl * values[6 + i] + 1));
      }
      // The compensator takes the levers from its nominal IK's Jacobian
      // (rus6_ik's `levers`) instead: the same numbers, to the bit, or a
      // controller and the host's identification would read different ones.
      Mat6<double> J;
      double levers[6] = {};
      Vec6<double> q_with = Vec6<double>::Zero();
      if (rus6_ik(g, pose, q_with, &J, levers) == Status::Ok) {
        EXPECT_EQ(q_with, q);
        for (int i = 0; i < 6; ++i) EXPECT_EQ(levers[i], values[6 + i]) << "joint " << i;
      }
    }
    EXPECT_LT(worst, 1e-6) << "machine " << machine;
    EXPECT_GE(used, 90) << "machine " << machine;  // of 104 poses
  }
  // Out of reach: the IK's status, nothing written.
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  Pose<double> far = g.home;
  far.p.z() += 500;
  double values[12] = {};
  EXPECT_EQ(rus6_formula_joint_values(g, far, values), Status::Unreachable);
  EXPECT_EQ(values[0], 0.0);
}

TEST(CoreRus6, ForwardJacobianInvertsInverseJacobian) {
  for (int machine = 0; machine < 2; ++machine) {
    const Rus6Geometry<double> g = machine == 0 ? make_rus6_ref<double>() : make_custom_machine(nullptr);
    double worst = 0;
    int checked = 0;
    for (const auto& off : box_offsets(200, machine == 0 ? kBoxMm : 30.0, machine == 0 ? kBoxRad : 6 * kDeg, 22)) {
      const Pose<double> pose = offset_pose<double>(g.home, off.data());
      Vec6<double> q = Vec6<double>::Zero();
      Mat6<double> J, F;
      Rus6Legs<double> legs;
      if (rus6_ik(g, pose, q, &J, &legs) != Status::Ok) continue;
      ASSERT_EQ(rus6_forward_jacobian(g, legs, F), Status::Ok);
      worst = std::max(worst, (F * J - Mat6<double>::Identity()).cwiseAbs().maxCoeff());
      worst = std::max(worst, (J * F - Mat6<double>::Identity()).cwiseAbs().maxCoeff());
      ++checked;
    }
    EXPECT_GT(checked, 200) << "machine " << machine;
    EXPECT_LT(worst, 1e-10) << "machine " << machine;
  }
  // And in float on the reference machine.
  const Rus6Geometry<float> gf = make_rus6_ref<float>();
  Vec6<float> q = Vec6<float>::Zero();
  Mat6<float> J, F;
  Rus6Legs<float> legs;
  const double off[6] = {20, -10, 15, 5 * kDeg, -3 * kDeg, 8 * kDeg};
  ASSERT_EQ(rus6_ik(gf, offset_pose<float>(gf.home.cast<double>(), off), q, &J, &legs), Status::Ok);
  ASSERT_EQ(rus6_forward_jacobian(gf, legs, F), Status::Ok);
  EXPECT_LT((F * J - Mat6<float>::Identity()).cwiseAbs().maxCoeff(), 1e-4f);
}

TEST(CoreRus6, ForwardJacobianMatchesFkDifferences) {
  // ∂twist/∂q by central differences of the FK (started at the pose itself).
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  const double off[6] = {-25, 15, -30, -6 * kDeg, 4 * kDeg, 9 * kDeg};
  const Pose<double> pose = offset_pose<double>(g.home, off);
  Vec6<double> q = Vec6<double>::Zero();
  Rus6Legs<double> legs;
  ASSERT_EQ(rus6_ik(g, pose, q, nullptr, &legs), Status::Ok);
  Mat6<double> F;
  ASSERT_EQ(rus6_forward_jacobian(g, legs, F), Status::Ok);
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Pose<double> plus, minus;
    ASSERT_EQ(rus6_fk(g, Vec6<double>(q + h * Vec6<double>::Unit(k)), pose, plus).status, Status::Ok);
    ASSERT_EQ(rus6_fk(g, Vec6<double>(q - h * Vec6<double>::Unit(k)), pose, minus).status, Status::Ok);
    const Twist<double> numeric = (pose_error(plus, pose) - pose_error(minus, pose)) / (2 * h);
    EXPECT_LT((numeric - F.col(k)).norm(), 1e-6 * F.col(k).norm()) << "column " << k;
  }
}

// ---- the custom machine ------------------------------------------------------

TEST(CoreRus6, CustomMachineHomeAndRoundTrip) {
  Vec6<double> q_home = Vec6<double>::Zero();
  const Rus6Geometry<double> g = make_custom_machine(&q_home);
  ASSERT_TRUE(rus6_valid_geometry(g));
  Vec6<double> q = Vec6<double>::Zero();
  ASSERT_EQ(rus6_ik(g, g.home, q), Status::Ok);
  EXPECT_LT((q - q_home).cwiseAbs().maxCoeff(), 1e-12);
  Pose<double> found;
  const double off[6] = {20, 10, -15, 3 * kDeg, 2 * kDeg, -4 * kDeg};
  ASSERT_EQ(rus6_fk(g, q_home, offset_pose<double>(g.home, off), found).status, Status::Ok);
  EXPECT_LT(position_error(found, g.home), 1e-9);

  const RoundTripStats sd = round_trip<double>(g, 30.0, 6 * kDeg, 2000, 31);
  const RoundTripStats sf = round_trip<float>(g, 30.0, 6 * kDeg, 2000, 32);
  std::printf("custom: double %d/%d worst %.3g mm; float %d/%d worst %.3g mm\n", sd.ok, sd.total, sd.worst_mm, sf.ok,
              sf.total, sf.worst_mm);
  EXPECT_GT(sd.ok, sd.total * 9 / 10);  // irregular: a few corners may leave the limits
  EXPECT_LE(sd.worst_mm, 1e-9);
  EXPECT_LE(sd.worst_rad, 1e-11);
  EXPECT_GT(sf.ok, sf.total * 9 / 10);
  EXPECT_LE(sf.worst_mm, 1e-3);
}

// ---- statuses, held outputs --------------------------------------------------

template <class Scalar> void check_statuses() {
  const Rus6Geometry<Scalar> g = make_rus6_ref<Scalar>();
  const Scalar sentinel = Scalar(123.5);
  Vec6<Scalar> q = Vec6<Scalar>::Constant(sentinel);
  Mat6<Scalar> J = Mat6<Scalar>::Constant(sentinel);
  const Vec6<Scalar> q_untouched = q;
  const Mat6<Scalar> J_untouched = J;

  // Non-finite pose.
  Pose<Scalar> bad = g.home;
  bad.p.x() = std::numeric_limits<Scalar>::quiet_NaN();
  EXPECT_EQ(rus6_ik(g, bad, q, &J), Status::InvalidInput);
  bad = g.home;
  bad.R(1, 2) = std::numeric_limits<Scalar>::infinity();
  EXPECT_EQ(rus6_ik(g, bad, q, &J), Status::InvalidInput);

  // Platform 500 mm above home: no rod reaches its crank circle.
  Pose<Scalar> far = g.home;
  far.p.z() += Scalar(500);
  EXPECT_EQ(rus6_ik(g, far, q, &J), Status::Unreachable);
  // Platform down on the base: too close for the rods.
  Pose<Scalar> low = g.home;
  low.p.z() = Scalar(0);
  EXPECT_EQ(rus6_ik(g, low, q, &J), Status::Unreachable);

  // Reachable but outside the limits: 113 mm up needs θ ≈ 73° > 70°
  // (the rods reach up to about 117 mm).
  Pose<Scalar> up = g.home;
  up.p.z() += Scalar(113);
  EXPECT_EQ(rus6_ik(g, up, q, &J), Status::OutOfLimits);
  Rus6Geometry<Scalar> wide = g;
  wide.min_joint.setConstant(-pi<Scalar>() + Scalar(0.01));
  wide.max_joint.setConstant(pi<Scalar>() - Scalar(0.01));
  Vec6<Scalar> q_wide = Vec6<Scalar>::Zero();
  EXPECT_EQ(rus6_ik(wide, up, q_wide), Status::Ok);  // reachable indeed
  EXPECT_GT(q_wide.maxCoeff(), g.max_joint(0));
  EXPECT_EQ(q, q_untouched);
  EXPECT_EQ(J, J_untouched);

  // FK: non-finite commands and guess, commands outside the limits.
  Pose<Scalar> pose = g.home;
  pose.p.x() = sentinel;
  const Pose<Scalar> pose_untouched = pose;
  Vec6<Scalar> qn = Vec6<Scalar>::Zero();
  qn(3) = std::numeric_limits<Scalar>::quiet_NaN();
  EXPECT_EQ(rus6_fk(g, qn, g.home, pose).status, Status::InvalidInput);
  Pose<Scalar> nan_guess = g.home;
  nan_guess.R(0, 0) = std::numeric_limits<Scalar>::quiet_NaN();
  EXPECT_EQ(rus6_fk(g, Vec6<Scalar>(Vec6<Scalar>::Zero()), nan_guess, pose).status, Status::InvalidInput);
  Vec6<Scalar> q_out = Vec6<Scalar>::Zero();
  q_out(2) = g.max_joint(2) + Scalar(0.01);
  EXPECT_EQ(rus6_fk(g, q_out, g.home, pose).status, Status::OutOfLimits);
  // No iterations allowed from a distant guess: NotConverged, iterations reported.
  FkOptions<Scalar> no_steps;
  no_steps.max_iterations = 0;
  Vec6<Scalar> q_moved = Vec6<Scalar>::Zero();
  const double off[6] = {20, 0, 10, 0, 0, 5 * kDeg};
  ASSERT_EQ(rus6_ik(g, offset_pose<Scalar>(g.home.template cast<double>(), off), q_moved), Status::Ok);
  const FkReport<Scalar> r = rus6_fk(g, q_moved, g.home, pose, no_steps);
  EXPECT_EQ(r.status, Status::NotConverged);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_GT(r.residual, Scalar(0.1));
  // Commands no assembly can reach: rods far too short for the cranks'
  // positions. Never Ok, pose held.
  Rus6Geometry<Scalar> short_rods = g;
  short_rods.rod_length.setConstant(Scalar(20));
  const FkReport<Scalar> rs = rus6_fk(short_rods, Vec6<Scalar>(Vec6<Scalar>::Zero()), g.home, pose);
  EXPECT_NE(rs.status, Status::Ok);
  EXPECT_TRUE(pose.p == pose_untouched.p && pose.R == pose_untouched.R);
}

TEST(CoreRus6, StatusesDouble) { check_statuses<double>(); }
TEST(CoreRus6, StatusesFloat) { check_statuses<float>(); }

TEST(CoreRus6, ParallelSingularityIsReported) {
  // Spheres straight above the horizontal crank tips: six vertical rods, so
  // K = [uᵀ, (R·p × u)ᵀ] has rank 3 (no horizontal stiffness). The IK itself
  // exists; asking for the Jacobian is Singular, and FK cannot take a step
  // from a guess 10 mm above home with the cranks at home (rods vertical).
  Rus6Geometry<double> g = make_rus6_ref<double>();
  for (int i = 0; i < 6; ++i) {
    const Vec3<double> tip = g.shaft_points.col(i) + g.crank_length(i) * g.crank_zero.col(i);
    g.platform_joints.col(i) = Vec3<double>(tip.x(), tip.y(), 0.0);
  }
  g.home = Pose<double>::from_xyz_rpy(0, 0, 300, 0, 0, 0);
  Vec6<double> q = Vec6<double>::Zero();
  ASSERT_EQ(rus6_ik(g, g.home, q), Status::Ok);
  EXPECT_LT(q.cwiseAbs().maxCoeff(), 1e-12);
  Mat6<double> J = Mat6<double>::Zero();
  EXPECT_EQ(rus6_ik(g, g.home, q, &J), Status::Singular);
  EXPECT_EQ(J, Mat6<double>::Zero());
  Pose<double> pose;
  Pose<double> above = g.home;
  above.p.z() += 10;
  const FkReport<double> r = rus6_fk(g, Vec6<double>(Vec6<double>::Zero()), above, pose);
  EXPECT_EQ(r.status, Status::Singular);
}

TEST(CoreRus6, SerialSingularityAndSphereOnShaftLine) {
  // At the top of the reach (about 117 mm above home) each rod is normal to
  // its crank tip's path: |C| = ρ, the two branches meet and every lever
  // λ_i → 0. Bisect for that height with the limits opened.
  Rus6Geometry<double> g = make_rus6_ref<double>();
  g.min_joint.setConstant(-3.1);
  g.max_joint.setConstant(3.1);
  double reachable = 100, unreachable = 130;
  Vec6<double> q = Vec6<double>::Zero();
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (reachable + unreachable);
    Pose<double> p = g.home;
    p.p.z() += mid;
    (rus6_ik(g, p, q) == Status::Ok ? reachable : unreachable) = mid;
  }
  Pose<double> top = g.home;
  top.p.z() += reachable;
  Rus6Legs<double> legs;
  ASSERT_EQ(rus6_ik(g, top, q, nullptr, &legs), Status::Ok);
  EXPECT_LT(legs.levers.cwiseAbs().maxCoeff() / 100.0, 1e-6);
  // Asking for the Jacobian there: Singular, or (if the lever is still above
  // the threshold) a finite Jacobian — never NaN/Inf with Ok.
  Mat6<double> J;
  const Status st = rus6_ik(g, top, q, &J);
  EXPECT_TRUE(st == Status::Singular || (st == Status::Ok && all_finite(J))) << to_string(st);
  // The forward Jacobian's serial test itself: one lever exactly zero.
  Pose<double> near = g.home;
  near.p.z() += 30;
  ASSERT_EQ(rus6_ik(g, near, q, nullptr, &legs), Status::Ok);
  legs.levers(2) = 0.0;
  Mat6<double> F = Mat6<double>::Zero();
  EXPECT_EQ(rus6_forward_jacobian(g, legs, F), Status::Singular);
  EXPECT_EQ(F, Mat6<double>::Zero());

  // Sphere 0 at its shaft point with ℓ_0 = c_0: A = B = C = 0, every θ
  // closes leg 0's loop (leg 0 is solved first, so its status is returned).
  Rus6Geometry<double> degenerate = g;
  degenerate.rod_length(0) = degenerate.crank_length(0);
  Pose<double> on_axis = g.home;
  on_axis.p = degenerate.shaft_points.col(0) - degenerate.platform_joints.col(0);
  EXPECT_EQ(rus6_ik(degenerate, on_axis, q), Status::Singular);
}

// ---- the branch rule ---------------------------------------------------------

TEST(CoreRus6, BranchRuleWhenBothBranchesFitTheLimits) {
  Rus6Geometry<double> g = make_rus6_ref<double>();
  g.min_joint.setConstant(-3.0);
  g.max_joint.setConstant(3.0);
  const double off[6] = {10, -5, 20, 2 * kDeg, 0, -3 * kDeg};
  const Pose<double> pose = offset_pose<double>(g.home, off);
  Vec6<double> home_branch_q = Vec6<double>::Zero(), other_q = Vec6<double>::Zero(), nearest_q = Vec6<double>::Zero();
  Rus6Legs<double> legs;
  ASSERT_EQ(rus6_ik(g, pose, home_branch_q, nullptr, &legs), Status::Ok);  // home_branch = −1
  EXPECT_EQ(rus6_branches(legs), g.home_branch);
  g.home_branch = -g.home_branch;
  ASSERT_EQ(rus6_ik(g, pose, other_q, nullptr, &legs), Status::Ok);
  EXPECT_EQ(rus6_branches(legs), g.home_branch);
  for (int i = 0; i < 6; ++i) {
    EXPECT_GT(std::abs(other_q(i) - home_branch_q(i)), 1.0);  // really the other solution
    EXPECT_NEAR(legs.rod_lengths(i), g.rod_length(i), 1e-9);   // and it closes the loop
    const std::vector<double> roots = closure_roots(g, pose, i);
    ASSERT_EQ(roots.size(), 2u);
  }
  // Unknown home branch: the one nearer mid-range (0 here), i.e. the home one.
  g.home_branch.setZero();
  ASSERT_EQ(rus6_ik(g, pose, nearest_q), Status::Ok);
  EXPECT_LT((nearest_q - home_branch_q).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(CoreRus6, LimitsWindowNotCentredOnZero) {
  // Commands wrap into the window of the limits: a machine whose range is
  // [200°, 330°] (zero direction pointing the other way round) gets commands
  // there, not their −2π equivalents.
  Rus6Geometry<double> g = make_rus6_ref<double>();
  Rus6Geometry<double> turned = g;
  turned.joint_offset.setConstant(-3.14159265358979323846);  // θ = q − π
  turned.min_joint = g.min_joint + Vec6<double>::Constant(3.14159265358979323846);
  turned.max_joint = g.max_joint + Vec6<double>::Constant(3.14159265358979323846);
  const double off[6] = {-12, 30, -20, 4 * kDeg, 7 * kDeg, 1 * kDeg};
  const Pose<double> pose = offset_pose<double>(g.home, off);
  Vec6<double> q = Vec6<double>::Zero(), q_turned = Vec6<double>::Zero();
  ASSERT_EQ(rus6_ik(g, pose, q), Status::Ok);
  ASSERT_EQ(rus6_ik(turned, pose, q_turned), Status::Ok);
  EXPECT_LT((q_turned - q - Vec6<double>::Constant(3.14159265358979323846)).cwiseAbs().maxCoeff(), 1e-12);
  Pose<double> found;
  ASSERT_EQ(rus6_fk(turned, q_turned, found).status, Status::Ok);
  EXPECT_LT(position_error(found, pose), 1e-9);
}

TEST(CoreRus6, GeometryValidation) {
  const Rus6Geometry<double> g = make_rus6_ref<double>();
  Rus6Geometry<double> b = g;
  b.shaft_axes(0, 2) = 2.0;  // not unit
  EXPECT_FALSE(rus6_valid_geometry(b));
  b = g;
  b.crank_zero.col(1) = b.shaft_axes.col(1);  // not ⟂
  EXPECT_FALSE(rus6_valid_geometry(b));
  b = g;
  b.rod_length(4) = -1;
  EXPECT_FALSE(rus6_valid_geometry(b));
  b = g;
  b.min_joint(3) = b.max_joint(3);
  EXPECT_FALSE(rus6_valid_geometry(b));
  b = g;
  b.max_joint(3) = b.min_joint(3) + 7.0;  // more than a turn
  EXPECT_FALSE(rus6_valid_geometry(b));
  b = g;
  b.home_branch(2) = 0.5;
  EXPECT_FALSE(rus6_valid_geometry(b));
  b = g;
  b.platform_joints(1, 5) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(rus6_valid_geometry(b));
}

// ---- no heap on the controller path ----------------------------------------

TEST(CoreRus6, NoHeap) {
  const Rus6Geometry<double> gd = make_rus6_ref<double>();
  const Rus6Geometry<float> gf = make_rus6_ref<float>();
  HeapForbidden guard;
  Vec6<double> qd = Vec6<double>::Zero();
  Mat6<double> Jd, Fd;
  Rus6Legs<double> legsd;
  ASSERT_EQ(rus6_ik(gd, gd.home, qd, &Jd, &legsd), Status::Ok);
  ASSERT_EQ(rus6_forward_jacobian(gd, legsd, Fd), Status::Ok);
  Pose<double> pd;
  ASSERT_EQ(rus6_fk(gd, Vec6<double>(Vec6<double>::Constant(0.1)), gd.home, pd).status, Status::Ok);
  Vec6<float> qf = Vec6<float>::Zero();
  Mat6<float> Jf;
  ASSERT_EQ(rus6_ik(gf, gf.home, qf, &Jf), Status::Ok);
  Pose<float> pf;
  ASSERT_EQ(rus6_fk(gf, Vec6<float>(Vec6<float>::Constant(0.1f)), gf.home, pf).status, Status::Ok);
}
