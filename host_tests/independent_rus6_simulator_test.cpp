// Self-test of the independent 6-RUS simulator (independent/rus6_simulator.hpp):
// its IK and FK invert each other, its loops close by a closure evaluated
// here by hand, its nominal machines are the ones documented (home angles
// from a closed form written here; kincal's rus6-ref agrees with core's IK,
// used only as a reference), its frame errors move the crank tip as rigid
// motions, the hidden effects change exactly what they say (backlash b·dir,
// compliance torques against the statics of the rods, rod thermal, encoder
// drift), with the effects off nothing changes bit for bit, and the
// measurement has the noise, targets, blunders and columns asked for.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "independent/rus6_simulator.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/core/rus6.hpp"

namespace ind = kincal::independent;
using ind::M3;
using ind::Rigid;
using ind::V3;
using ind::V6;
using kincal::Pose;

namespace {

std::vector<ind::Rus6Nominal> both_nominals() { return {ind::rus6_ref_nominal(), ind::rus6_tangential_nominal()}; }

double rotation_distance(const M3& a, const M3& b) { return ind::rotation_log(M3(a * b.transpose())).norm(); }

double position_distance(const Pose<double>& a, const Pose<double>& b) { return (a.p - b.p).norm(); }

// Crank tip written out by hand from the description + the errors (not the
// simulator's frame composition): motor axes x = zero, y = axis × zero,
// z = axis, turned by exp(w) in motor coordinates, origin s + R_M·d; the pin
// (c + δx, δy, δz) turned by θ about the local z.
V3 tip_by_hand(const ind::Rus6Nominal& n, const ind::Rus6Errors& e, int i, double theta) {
  const std::size_t k = std::size_t(i);
  M3 RM;
  RM.col(0) = n.crank_zero[k];
  RM.col(1) = n.shaft_axis[k].cross(n.crank_zero[k]);
  RM.col(2) = n.shaft_axis[k];
  const double w = e.motor_rotation[k].norm();
  const M3 Rw = w == 0 ? M3::Identity() : M3(Eigen::AngleAxisd(w, e.motor_rotation[k] / w));
  const V3 pin = V3(n.crank_length[k], 0, 0) + e.crank_pin[k];
  const V3 turned(std::cos(theta) * pin.x() - std::sin(theta) * pin.y(),
                  std::sin(theta) * pin.x() + std::cos(theta) * pin.y(), pin.z());
  return n.shaft_point[k] + RM * e.motor_translation[k] + RM * Rw * turned;
}

// Max over legs of | |S − C| − ℓ | at an FK result, by hand.
double closure_by_hand(const ind::Rus6Nominal& n, const ind::Rus6Errors& e, const ind::Rus6FkResult& r,
                       double rod_scale = 1.0) {
  double worst = 0;
  for (int i = 0; i < 6; ++i) {
    const std::size_t k = std::size_t(i);
    const V3 S = r.platform.transform(n.platform_joint[k] + e.platform_sphere[k]);
    const double rod = (n.rod_length[k] + e.rod[k]) * rod_scale;
    worst = std::max(worst, std::abs((S - tip_by_hand(n, e, i, r.theta(i))).norm() - rod));
  }
  return worst;
}

bool same_bits(const Pose<double>& a, const Pose<double>& b) { return a.R == b.R && a.p == b.p; }

}  // namespace

// ------------------------------------------------------------------ nominal machines

// The tangential machine's home: each leg's θ from the closed form of its
// loop in motor coordinates, (ρ_r − c cos θ)² + (h − c sin θ)² + ρ_a² = ℓ²,
// numbers entered here (ψ, φ, 200, 80, 300, 100, 240), lower root.
TEST(IndependentRus6, TangentialHomeMatchesClosedForm) {
  const double deg = ind::kPi / 180.0;
  const double psi[6] = {-15, 15, 105, 135, 225, 255}, phi[6] = {-45, 45, 75, 165, 195, 285};
  const ind::Rus6Simulator sim(ind::rus6_tangential_nominal());
  const ind::Rus6IkResult r = sim.ik_detail(Pose<double>::from_xyz_rpy(0, 0, 240, 0, 0, 0));
  ASSERT_TRUE(r.ok) << r.why;
  for (int i = 0; i < 6; ++i) {
    const V3 s(200 * std::cos(psi[i] * deg), 200 * std::sin(psi[i] * deg), 0);
    const V3 zero(std::cos(psi[i] * deg), std::sin(psi[i] * deg), 0), axis(std::sin(psi[i] * deg), -std::cos(psi[i] * deg), 0);
    const V3 d = V3(100 * std::cos(phi[i] * deg), 100 * std::sin(phi[i] * deg), 240) - s;
    const double A = d.dot(zero), B = d.z(), c = 80, l = 300;
    const double C = (d.squaredNorm() + c * c - l * l) / (2 * c);  // A cos θ + B sin θ = C
    const double theta = std::atan2(B, A) - std::acos(C / std::hypot(A, B));
    EXPECT_NEAR(r.theta(i), theta, 1e-12) << "leg " << i + 1;
    EXPECT_NEAR(r.theta(i), 0.188, 5e-4) << "leg " << i + 1;  // the value the machine's spec quotes
    EXPECT_NEAR(d.dot(axis), (i % 2 == 0 ? 50.0 : -50.0), 1e-9);  // the rod leans 50 mm along the shaft
  }
  // Off home too: at the corner (30, −30, 260, 0.08, −0.08, −0.08) of a ±30 mm
  // box the closed form needs q3 = 0.91188 rad, past the 0.9 limit (why the
  // machine's box is ±25 mm); the IK finds the same angle and refuses it.
  const Pose<double> corner = Pose<double>::from_xyz_rpy(30, -30, 260, 0.08, -0.08, -0.08);
  const ind::Rus6IkResult c = sim.ik_detail(corner);
  ASSERT_TRUE(c.solved);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.limit_joint, 2);
  for (int i = 0; i < 6; ++i) {
    const V3 s(200 * std::cos(psi[i] * deg), 200 * std::sin(psi[i] * deg), 0);
    const V3 zero(std::cos(psi[i] * deg), std::sin(psi[i] * deg), 0);
    const V3 d = corner.transform(V3(100 * std::cos(phi[i] * deg), 100 * std::sin(phi[i] * deg), 0)) - s;
    const double A = d.dot(zero), B = d.z();
    const double C = (d.squaredNorm() + 80.0 * 80.0 - 300.0 * 300.0) / 160.0;
    EXPECT_NEAR(c.q(i), std::atan2(B, A) - std::acos(C / std::hypot(A, B)), 1e-12) << "leg " << i + 1;
  }
  EXPECT_NEAR(c.q(2), 0.91188, 1e-5);
}

// kincal's rus6-ref: home z = 274.0438 mm (docs/reference-machines.md) with
// every crank horizontal; FK of zero commands is that pose.
TEST(IndependentRus6, RefHomeIsCranksHorizontalAsDocumented) {
  const ind::Rus6Nominal n = ind::rus6_ref_nominal();
  EXPECT_NEAR(n.home(2), 274.0438, 5e-5);
  const ind::Rus6Simulator sim(n);
  const ind::Rus6IkResult r = sim.ik_detail(Pose<double>::from_xyz_rpy(n.home));
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_LT(r.q.cwiseAbs().maxCoeff(), 1e-12);
  const ind::Rus6FkResult f = sim.fk(V6::Zero());
  ASSERT_TRUE(f.ok) << f.why;
  EXPECT_LT(position_distance(f.pose, Pose<double>::from_xyz_rpy(n.home)), 1e-9);
  EXPECT_LT(rotation_distance(f.pose.R, M3::Identity()), 1e-12);
}

// The re-entered rus6-ref is core's: same commands as core's closed-form IK
// (core used only as the reference here) over the workspace.
TEST(IndependentRus6, RefAgreesWithCoreAtZeroErrors) {
  const ind::Rus6Nominal n = ind::rus6_ref_nominal();
  const ind::Rus6Simulator sim(n);
  const kincal::Rus6Geometry<double> g = kincal::make_rus6_ref<double>();
  EXPECT_NEAR(g.home.p.z(), n.home(2), 1e-12);
  for (const V6& v : ind::rus6_random_poses(n, 200, 11)) {
    V6 ours = V6::Zero(), core = V6::Zero();
    ASSERT_TRUE(sim.ik(Pose<double>::from_xyz_rpy(v), ours));
    ASSERT_EQ(kincal::rus6_ik(g, Pose<double>::from_xyz_rpy(v), core), kincal::Status::Ok);
    EXPECT_LT((ours - core).cwiseAbs().maxCoeff(), 1e-11) << v.transpose();
  }
}

// Nominal FK of the nominal IK's commands returns the commanded pose, on the
// branch with every lever positive.
TEST(IndependentRus6, NominalFkInvertsIk) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const ind::Rus6Simulator sim(n);
    std::vector<V6> poses = ind::rus6_grid_poses(n, {2, 2, 2, 2, 2, 2});
    for (const V6& v : ind::rus6_random_poses(n, 100, 3)) poses.push_back(v);
    for (const V6& v : poses) {
      const Pose<double> X = Pose<double>::from_xyz_rpy(v);
      V6 q;
      ASSERT_TRUE(sim.ik(X, q)) << n.name << " " << v.transpose();
      const ind::Rus6FkResult f = sim.fk(q);
      ASSERT_TRUE(f.ok) << f.why;
      EXPECT_LT(position_distance(f.pose, X), 1e-9) << n.name;
      EXPECT_LT(rotation_distance(f.pose.R, X.R), 1e-11) << n.name;
      EXPECT_GT(f.levers.minCoeff(), 0.0) << n.name;
    }
  }
}

// Over the 64 corners and 2000 random poses of each machine's box every
// command is inside the limits (the spec's claim), with some margin.
TEST(IndependentRus6, WorkspaceStaysInsideTheLimits) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const ind::Rus6Simulator sim(n);
    std::vector<V6> poses = ind::rus6_grid_poses(n, {2, 2, 2, 2, 2, 2});
    for (const V6& v : ind::rus6_random_poses(n, 2000, 5)) poses.push_back(v);
    double lo = 1e9, hi = -1e9;
    for (const V6& v : poses) {
      const ind::Rus6IkResult r = sim.ik_detail(Pose<double>::from_xyz_rpy(v));
      ASSERT_TRUE(r.ok) << n.name << " " << v.transpose() << ": " << r.why;
      lo = std::min(lo, r.q.minCoeff());
      hi = std::max(hi, r.q.maxCoeff());
    }
    std::printf("%s: q over the workspace %.4f .. %.4f rad (limits %.4f .. %.4f)\n", n.name.c_str(), lo, hi,
                n.min_command(0), n.max_command(0));
    if (n.name == "rus6-ref") {  // docs/reference-machines.md: θ spans −73.9° … +61.3° over this box
      EXPECT_NEAR(lo / (ind::kPi / 180), -73.9, 0.2);
      EXPECT_NEAR(hi / (ind::kPi / 180), 61.3, 0.2);
    }
    EXPECT_GT(lo, n.min_command(0) + 0.02) << n.name;
    EXPECT_LT(hi, n.max_command(0) - 0.02) << n.name;
  }
}

// ------------------------------------------------------------------ with errors

TEST(IndependentRus6, WithErrorsLoopsCloseAndIkInvertsFk) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const ind::Rus6Errors e = ind::random_rus6_errors(1.0, 5e-3, 21);
    const ind::Rus6Simulator nominal(n), actual(n, e);
    double moved = 0;
    for (const V6& v : ind::rus6_random_poses(n, 40, 8)) {
      const Pose<double> X = Pose<double>::from_xyz_rpy(v);
      V6 q;
      ASSERT_TRUE(nominal.ik(X, q));
      const ind::Rus6FkResult f = actual.fk(q, &X);
      ASSERT_TRUE(f.ok) << f.why;
      EXPECT_LT(closure_by_hand(n, e, f), 1e-10) << n.name;
      EXPECT_GT(f.levers.minCoeff(), 0.0);
      // The measured frame sits on the platform by the tool offset.
      const Rigid tool{ind::rotation_vector(e.tool_rotation), e.tool_point};
      const Rigid expected = ind::to_rigid(f.platform) * tool;
      EXPECT_LT((expected.p - f.pose.p).norm(), 1e-12);
      EXPECT_LT(rotation_distance(expected.R, f.pose.R), 1e-14);
      // The erroneous machine's own IK (per-leg bisection) inverts its FK (Newton).
      const ind::Rus6IkResult back = actual.ik_detail(f.pose);
      ASSERT_TRUE(back.solved) << back.why;
      EXPECT_LT((back.q - q).cwiseAbs().maxCoeff(), 1e-10) << n.name;
      moved = std::max(moved, position_distance(f.pose, X));
    }
    EXPECT_GT(moved, 0.5) << n.name << ": millimetre errors must move the platform by about that much";
  }
}

// Frame errors act as rigid motions of the motor frame / crank.
TEST(IndependentRus6, FrameErrorsMoveTheCrankTipRigidly) {
  const ind::Rus6Nominal n = ind::rus6_tangential_nominal();
  const ind::Rus6Simulator nom(n);
  const int leg = 2;
  const std::size_t k = std::size_t(leg);
  M3 RM;
  RM.col(0) = n.crank_zero[k];
  RM.col(1) = n.shaft_axis[k].cross(n.crank_zero[k]);
  RM.col(2) = n.shaft_axis[k];
  for (double theta : {-0.7, 0.0, 0.188, 0.9}) {
    // A translation d in motor coordinates moves every tip by R_M·d.
    ind::Rus6Errors t;
    t.motor_translation[k] = V3(0.3, -0.2, 0.5);
    EXPECT_LT((ind::Rus6Simulator(n, t).crank_tip(leg, theta) - nom.crank_tip(leg, theta) - RM * t.motor_translation[k]).norm(),
              1e-12);
    // A turn of the motor about its own shaft is an encoder offset.
    ind::Rus6Errors r;
    r.motor_rotation[k] = V3(0, 0, 2e-3);
    EXPECT_LT((ind::Rus6Simulator(n, r).crank_tip(leg, theta) - nom.crank_tip(leg, theta + 2e-3)).norm(), 1e-12);
    // A tilt about the crank-zero axis swings the tip out of the nominal crank plane.
    ind::Rus6Errors tilt;
    tilt.motor_rotation[k] = V3(1e-3, 0, 0);
    const V3 off = ind::Rus6Simulator(n, tilt).crank_tip(leg, theta) - n.shaft_point[k];
    EXPECT_NEAR(off.dot(n.shaft_axis[k]), 80.0 * std::sin(theta) * std::sin(1e-3), 1e-12);
    // Crank pin: δx lengthens the crank, δz moves the tip along the shaft.
    ind::Rus6Errors pin;
    pin.crank_pin[k] = V3(0.25, 0, 0.4);
    const V3 tip = ind::Rus6Simulator(n, pin).crank_tip(leg, theta);
    EXPECT_NEAR((tip - n.shaft_point[k] - 0.4 * n.shaft_axis[k]).norm(), 80.25, 1e-12);
    EXPECT_NEAR((tip - nom.crank_tip(leg, theta)).dot(n.shaft_axis[k]), 0.4, 1e-12);
  }
}

// Negative control: a 1 nm rod error is seen in the FK pose far above its
// convergence floor.
TEST(IndependentRus6, NegativeControlOneNanometreIsSeen) {
  const ind::Rus6Nominal n = ind::rus6_ref_nominal();
  ind::Rus6Errors e;
  e.rod[3] = 1e-6;
  V6 q;
  q << 0.1, -0.2, 0.3, 0.05, -0.1, 0.2;
  const ind::Rus6FkResult a = ind::Rus6Simulator(n).fk(q), b = ind::Rus6Simulator(n, e).fk(q);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_GT(position_distance(a.pose, b.pose), 2e-7);
  EXPECT_LT(position_distance(a.pose, b.pose), 1e-5);
}

// ------------------------------------------------------------------ effects

// With every effect zero the effect code runs and changes nothing, bit for
// bit, whatever the temperature and directions; a dataset with a payload set
// (but no compliance), temperatures and dir columns measures the same numbers.
TEST(IndependentRus6Effects, OffIsBitForBit) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const ind::Rus6Errors e = ind::random_rus6_errors(0.2, 1e-3, 4);
    ind::Rus6Effects zero;
    zero.payload_weight = 80;
    zero.payload_com = V3(10, 20, 30);
    const ind::Rus6Simulator plain(n, e), with_code(n, e, zero);
    std::mt19937_64 rng(9);
    const ind::Rus6Simulator ctl(n);
    for (const V6& v : ind::rus6_random_poses(n, 20, 2)) {
      V6 q;
      ASSERT_TRUE(ctl.ik(Pose<double>::from_xyz_rpy(v), q));
      ind::Rus6Inputs in;
      in.temp = std::uniform_real_distribution<double>(15, 35)(rng);
      for (int j = 0; j < 6; ++j) in.dir(j) = rng() % 2 ? 1.0 : -1.0;
      const ind::Rus6FkResult a = plain.fk(q), b = with_code.fk(q, in);
      ASSERT_TRUE(a.ok && b.ok);
      EXPECT_TRUE(same_bits(a.pose, b.pose)) << n.name;
      EXPECT_TRUE(a.theta == b.theta);
    }
    const std::vector<V6> poses = ind::rus6_random_poses(n, 15, 6);
    const ind::MeasurementSpec spec = ind::rus6_measurement(2, 5, 77);
    ind::Rus6DatasetOptions opt;
    opt.temps = ind::rus6_random_temperatures(poses.size(), 15, 35, 1);
    opt.write_dir = true;
    const ind::Dataset a = ind::make_rus6_dataset(n, e, ind::Rus6Effects{}, poses, spec);
    const ind::Dataset b = ind::make_rus6_dataset(n, e, zero, poses, spec, opt);
    ASSERT_EQ(a.rows.size(), poses.size());
    ASSERT_EQ(b.rows.size(), poses.size());
    for (std::size_t r = 0; r < a.rows.size(); ++r) {
      EXPECT_TRUE(*a.rows[r].measured == *b.rows[r].measured) << n.name << " row " << r;
      EXPECT_TRUE(a.rows[r].q == b.rows[r].q);
    }
    EXPECT_TRUE(b.has_temp && b.has_dir && !a.has_temp && !a.has_dir);
  }
}

// Backlash: θ − (q + encoder) is b·dir; the dataset's directions follow the
// command sequence and the pose reached is the FK at those angles.
TEST(IndependentRus6Effects, BacklashShiftsThetaByBTimesDir) {
  const ind::Rus6Nominal n = ind::rus6_tangential_nominal();
  const ind::Rus6Errors e = ind::random_rus6_errors(0.1, 1e-3, 12);
  ind::Rus6Effects fx;
  fx.backlash = {2e-4, -1e-4, 3e-4, 0, 1.5e-4, 5e-5};
  const ind::Rus6Simulator sim(n, e, fx);
  V6 q;
  q << 0.1, 0.2, -0.3, 0.15, 0.0, 0.05;
  ind::Rus6Inputs in;
  in.dir << 1, -1, -1, 1, 1, -1;
  const V6 theta = sim.physical_angles(q, in);
  for (int i = 0; i < 6; ++i)
    EXPECT_NEAR(theta(i) - (q(i) + e.encoder[std::size_t(i)]), fx.backlash[std::size_t(i)] * in.dir(i), 1e-16);

  // A back-and-forth sequence: z up, up, down, hold, x across.
  std::vector<V6> poses;
  for (double z : {235.0, 245.0, 255.0, 230.0, 230.0}) poses.push_back((V6() << 0, 0, z, 0, 0, 0).finished());
  poses.push_back((V6() << 20, 0, 230, 0, 0, 0).finished());
  poses.push_back((V6() << -20, 0, 230, 0, 0, 0.05).finished());
  const ind::Dataset d = ind::make_rus6_dataset(n, e, fx, poses, ind::rus6_measurement(0, 0, 1));
  ASSERT_EQ(d.rows.size(), poses.size());
  ASSERT_TRUE(d.has_dir);
  V6 expected_dir = V6::Ones();
  for (std::size_t r = 0; r < d.rows.size(); ++r) {
    if (r > 0)
      for (int j = 0; j < 6; ++j) {
        const double dq = d.rows[r].q(j) - d.rows[r - 1].q(j);
        if (dq != 0) expected_dir(j) = dq > 0 ? 1 : -1;
      }
    EXPECT_TRUE(d.rows[r].dir == expected_dir) << "row " << r << ": " << d.rows[r].dir.transpose();
    V6 th = d.rows[r].q + sim.encoder();
    for (int j = 0; j < 6; ++j) th(j) += fx.backlash[std::size_t(j)] * expected_dir(j);
    const ind::Rus6FkResult f = sim.fk_angles(th);
    ASSERT_TRUE(f.ok);
    EXPECT_LT(position_distance(f.pose, d.rows[r].actual), 1e-11);
  }
  // Going up then down reverses every leg's direction at row 3 (z falls).
  EXPECT_TRUE(d.rows[2].dir == V6::Ones());
  EXPECT_TRUE(d.rows[3].dir == -V6::Ones());
  EXPECT_TRUE(d.rows[4].dir == -V6::Ones());  // held: kept
}

// Compliance: the virtual-work torques equal the statics of the rods (each a
// two-force member: platform equilibrium gives the rod forces, each pushes its
// crank pin), and the potential energy's slope along a mixed direction; the
// deflection is k·τ and linear in the weight.
TEST(IndependentRus6Effects, ComplianceTorqueMatchesRodStatics) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const ind::Rus6Errors e = ind::random_rus6_errors(0.5, 2e-3, 31);
    ind::Rus6Effects fx;
    fx.payload_weight = 120;             // N
    fx.payload_com = V3(15, -25, 40);    // mm, platform frame
    fx.compliance = {1e-7, 2e-7, 1.5e-7, 1e-7, 3e-7, 2e-7};
    const ind::Rus6Simulator sim(n, e, fx), ctl(n);
    for (const V6& v : ind::rus6_random_poses(n, 6, 14)) {
      V6 q;
      ASSERT_TRUE(ctl.ik(Pose<double>::from_xyz_rpy(v), q));
      const V6 theta = q + sim.encoder();
      const V6 tau = sim.motor_torques(theta);
      ASSERT_TRUE(tau.allFinite());
      const ind::Rus6FkResult f = sim.fk_angles(theta);
      ASSERT_TRUE(f.ok);
      const V3 com = f.platform.transform(fx.payload_com), F(0, 0, -fx.payload_weight);
      ind::M6 A;
      std::array<V3, 6> u, C;
      for (int i = 0; i < 6; ++i) {
        C[std::size_t(i)] = tip_by_hand(n, e, i, theta(i));
        const V3 S = f.platform.transform(n.platform_joint[std::size_t(i)] + e.platform_sphere[std::size_t(i)]);
        u[std::size_t(i)] = (S - C[std::size_t(i)]).normalized();
        A.block<3, 1>(0, i) = u[std::size_t(i)];
        A.block<3, 1>(3, i) = (S - com).cross(u[std::size_t(i)]);
      }
      ind::V6 wrench;
      wrench << -F, V3::Zero();
      const V6 force = A.fullPivLu().solve(wrench);  // f_i u_i on the platform
      for (int i = 0; i < 6; ++i) {
        const Rigid& M = sim.motor_frame(i);
        const double statics = M.R.col(2).dot((C[std::size_t(i)] - M.p).cross(-force(i) * u[std::size_t(i)]));
        EXPECT_NEAR(tau(i), statics, 1e-6 * tau.cwiseAbs().maxCoeff()) << n.name << " motor " << i + 1;
      }
      // Energy: U = W·z_com; −dU/ds along d equals τ·d.
      const V6 dirn = (V6() << 0.3, -0.5, 0.2, 0.7, -0.1, 0.4).finished();
      const double h = 1e-6;
      const auto fa = sim.fk_angles(theta + h * dirn, 20, &f.pose), fb = sim.fk_angles(theta - h * dirn, 20, &f.pose);
      ASSERT_TRUE(fa.ok && fb.ok);
      const double dU = fx.payload_weight * (fa.platform.transform(fx.payload_com).z() - fb.platform.transform(fx.payload_com).z()) / (2 * h);
      EXPECT_NEAR(-dU, tau.dot(dirn), 1e-6 * tau.cwiseAbs().maxCoeff()) << n.name;
      // Deflection θ − θ₀ = k·τ, and twice the weight twice the deflection.
      V6 used;
      const V6 deflected = sim.physical_angles(q, ind::Rus6Inputs{}, &used);
      for (int i = 0; i < 6; ++i)
        EXPECT_NEAR(deflected(i) - theta(i), fx.compliance[std::size_t(i)] * tau(i), 1e-15);
      EXPECT_TRUE(used == tau);
      ind::Rus6Effects heavy = fx;
      heavy.payload_weight *= 2;
      const V6 twice = ind::Rus6Simulator(n, e, heavy).physical_angles(q, ind::Rus6Inputs{});
      for (int i = 0; i < 6; ++i)
        EXPECT_NEAR(twice(i) - theta(i), 2 * (deflected(i) - theta(i)), 1e-9 * std::abs(deflected(i) - theta(i)) + 1e-16);
      EXPECT_GT((deflected - theta).cwiseAbs().maxCoeff(), 1e-5) << "the test load must deflect measurably";
    }
  }
}

// Rod thermal: the loops close with every rod × (1 + α·(T − 20)); at 20 °C
// nothing changes. Encoder drift moves only the motors given, by d·(T − 20).
TEST(IndependentRus6Effects, RodThermalAndEncoderDrift) {
  const ind::Rus6Nominal n = ind::rus6_tangential_nominal();
  const ind::Rus6Errors e = ind::random_rus6_errors(0.3, 1e-3, 41);
  ind::Rus6Effects fx;
  fx.rod_thermal = 1.2e-5;
  fx.encoder_drift = {3e-5, 0, -2e-5, 0, 4e-5, 0};
  const ind::Rus6Simulator sim(n, e, fx), plain(n, e);
  V6 q;
  q << 0.2, 0.1, 0.3, 0.25, 0.15, 0.18;
  for (double T : {15.0, 20.0, 35.0}) {
    ind::Rus6Inputs in;
    in.temp = T;
    const V6 theta = sim.physical_angles(q, in);
    for (int i = 0; i < 6; ++i) {
      const double d = fx.encoder_drift[std::size_t(i)];
      if (d == 0)
        EXPECT_EQ(theta(i), q(i) + e.encoder[std::size_t(i)]);
      else
        EXPECT_NEAR(theta(i) - (q(i) + e.encoder[std::size_t(i)]), d * (T - 20), 1e-16);
    }
    const ind::Rus6FkResult f = sim.fk(q, in);
    ASSERT_TRUE(f.ok) << f.why;
    EXPECT_LT(closure_by_hand(n, e, f, 1.0 + fx.rod_thermal * (T - 20)), 1e-10) << T;
    if (T == 20.0) EXPECT_TRUE(same_bits(f.pose, plain.fk(q).pose));
    else EXPECT_GT(position_distance(f.pose, plain.fk(q).pose), 1e-3) << T;
  }
  // A temperature effect without temperatures is refused, not silently off.
  EXPECT_THROW(ind::make_rus6_dataset(n, e, fx, {n.home}, ind::rus6_measurement(0, 0, 1)), std::invalid_argument);
}

// ------------------------------------------------------------------ measurement

TEST(IndependentRus6Measurement, NoiseHasTheRequestedSigma) {
  const ind::Rus6Nominal n = ind::rus6_ref_nominal();
  const std::vector<V6> poses = ind::rus6_random_poses(n, 600, 19);
  const ind::Dataset d = ind::make_rus6_dataset(n, ind::Rus6Errors{}, ind::Rus6Effects{}, poses, ind::rus6_measurement(2, 5, 123));
  ASSERT_EQ(d.rows.size(), poses.size());
  for (int group = 0; group < 2; ++group) {
    const double sigma = group == 0 ? 2e-3 : 5e-6;
    double sum = 0, sum2 = 0;
    int count = 0;
    for (const auto& r : d.rows) {
      const V6 err = *r.measured - r.actual.to_xyz_rpy();
      for (int k = 3 * group; k < 3 * group + 3; ++k) {
        sum += err(k);
        sum2 += err(k) * err(k);
        ++count;
      }
    }
    const double mean = sum / count, sd = std::sqrt(sum2 / count - mean * mean);
    EXPECT_LT(std::abs(mean), 4 * sigma / std::sqrt(double(count))) << group;
    EXPECT_NEAR(sd / sigma, 1.0, 0.07) << group;
  }
  // Zero noise: the measurement is the pose reached.
  const ind::Dataset clean = ind::make_rus6_dataset(n, ind::Rus6Errors{}, ind::Rus6Effects{}, poses, ind::rus6_measurement(0, 0, 1));
  for (const auto& r : clean.rows) EXPECT_TRUE(*r.measured == r.actual.to_xyz_rpy());
}

// Targets in the tracker's frame: y_k = T_IB·X·t_k, their distances those on the platform.
TEST(IndependentRus6Measurement, TargetsAreSeenFromTheTracker) {
  const ind::Rus6Nominal n = ind::rus6_tangential_nominal();
  const ind::Rus6Errors e = ind::random_rus6_errors(0.5, 2e-3, 7);
  const Pose<double> tracker = Pose<double>::from_xyz_rpy(1500, -300, 400, 0.1, -0.2, 2.5);
  const ind::MeasurementSpec spec = ind::rus6_measurement(0, 0, 1, n.targets, tracker);
  const ind::Dataset d = ind::make_rus6_dataset(n, e, ind::Rus6Effects{}, ind::rus6_random_poses(n, 10, 2), spec);
  ASSERT_EQ(d.rows.size(), 10u);
  EXPECT_FALSE(d.has_measured);
  EXPECT_EQ(d.target_count, 3);
  for (const auto& r : d.rows) {
    const Rigid seen = ind::to_rigid(tracker) * ind::to_rigid(r.actual);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_LT((r.targets[k] - seen * n.targets[k]).norm(), 1e-11);
    EXPECT_NEAR((r.targets[0] - r.targets[1]).norm(), (n.targets[0] - n.targets[1]).norm(), 1e-9);
    // The tracker is far away: the targets are not in base coordinates.
    EXPECT_GT((r.targets[0] - r.actual.transform(n.targets[0])).norm(), 100.0);
  }
}

TEST(IndependentRus6Measurement, BlundersDisplaceOnlyTheirRow) {
  const ind::Rus6Nominal n = ind::rus6_ref_nominal();
  const std::vector<V6> poses = ind::rus6_random_poses(n, 8, 4);
  ind::Rus6DatasetOptions opt;
  opt.blunders.push_back({3, V3(0, 0, 2.0)});
  ind::MeasurementSpec spec = ind::rus6_measurement(2, 5, 5, n.targets);
  spec.pose_and_targets = true;
  const ind::Dataset d = ind::make_rus6_dataset(n, ind::Rus6Errors{}, ind::Rus6Effects{}, poses, spec, opt);
  ASSERT_EQ(d.rows.size(), poses.size());
  for (std::size_t r = 0; r < d.rows.size(); ++r) {
    const V3 shift = d.rows[r].measured->head<3>() - d.rows[r].actual.p;
    const V3 want = r == 3 ? V3(0, 0, 2.0) : V3::Zero();
    EXPECT_LT((shift - want).norm(), 0.02) << "row " << r;
    for (std::size_t k = 0; k < 3; ++k)
      EXPECT_LT((d.rows[r].targets[k] - d.rows[r].actual.transform(n.targets[k]) - want).norm(), 0.02);
  }
}

// A command past the limits is reported by the IK, the FK refuses it and the
// dataset leaves the row out, saying why.
TEST(IndependentRus6Measurement, CommandsPastTheLimitsAreReported) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const ind::Rus6Simulator sim(n);
    // Lower the platform from home until some command leaves the limits.
    V6 low = n.home;
    ind::Rus6IkResult r;
    for (double dz = 0; dz < 200; dz += 1) {
      low(2) = n.home(2) - dz;
      r = sim.ik_detail(Pose<double>::from_xyz_rpy(low));
      if (!r.ok) break;
    }
    ASSERT_TRUE(r.solved) << n.name << ": " << r.why;
    ASSERT_FALSE(r.ok) << n.name;
    ASSERT_GE(r.limit_joint, 0);
    EXPECT_LT(r.q(r.limit_joint), n.min_command(r.limit_joint));
    EXPECT_NE(r.why.find("past its limits"), std::string::npos) << r.why;
    V6 q;
    EXPECT_FALSE(sim.ik(Pose<double>::from_xyz_rpy(low), q));
    // The FK refuses the command rather than using it.
    const ind::Rus6FkResult f = sim.fk(r.q);
    EXPECT_FALSE(f.ok);
    EXPECT_NE(f.why.find("joint " + std::to_string(r.limit_joint + 1)), std::string::npos) << f.why;
    EXPECT_FALSE(sim.fk(r.q, ind::Rus6Inputs{}).ok);
    // In a dataset the row is skipped with the reason.
    const std::vector<V6> poses{n.home, low, n.workspace_max};
    const ind::Dataset d = ind::make_rus6_dataset(n, ind::Rus6Errors{}, ind::Rus6Effects{}, poses, ind::rus6_measurement(0, 0, 1));
    ASSERT_EQ(d.rows.size(), 2u);
    ASSERT_EQ(d.skipped.size(), 1u);
    EXPECT_EQ(d.skipped[0].rfind("1: ", 0), 0u) << d.skipped[0];
    EXPECT_NE(d.skipped[0].find("past its limits"), std::string::npos) << d.skipped[0];
    EXPECT_EQ(d.rows[1].id, "n3");
  }
}

TEST(IndependentRus6Measurement, CsvColumns) {
  const ind::Rus6Nominal n = ind::rus6_tangential_nominal();
  ind::Rus6Effects fx;
  fx.backlash[0] = 1e-4;
  fx.rod_thermal = 1e-5;
  const std::vector<V6> poses = ind::rus6_random_poses(n, 3, 1);
  ind::Rus6DatasetOptions opt;
  opt.temps = {15, 25, 35};
  opt.roles = {"cal", "test", "cal"};
  ind::MeasurementSpec spec = ind::rus6_measurement(2, 5, 1, {n.targets[0]});
  const ind::Dataset d = ind::make_rus6_dataset(n, ind::Rus6Errors{}, fx, poses, spec, opt);
  std::ostringstream out;
  ind::write_measurement_csv(out, d);
  const std::string text = out.str();
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "id,x,y,z,rx,ry,rz,t1x,t1y,t1z,q1,q2,q3,q4,q5,q6,role,temp,dir1,dir2,dir3,dir4,dir5,dir6");
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 4);
  EXPECT_NE(text.find(",test,25,"), std::string::npos);
}

// ------------------------------------------------------------------ generators

TEST(IndependentRus6Generators, RandomErrorsAreSeededBoundedAndGrouped) {
  const ind::Rus6Errors a = ind::random_rus6_errors(0.01, 1e-4, 5), b = ind::random_rus6_errors(0.01, 1e-4, 5),
                        c = ind::random_rus6_errors(0.01, 1e-4, 6);
  EXPECT_TRUE(a.motor_translation[2] == b.motor_translation[2] && a.encoder == b.encoder && a.rod == b.rod);
  EXPECT_FALSE(a.encoder == c.encoder);
  double maxlen = 0, maxang = 0;
  for (std::size_t i = 0; i < 6; ++i) {
    maxlen = std::max({maxlen, a.motor_translation[i].cwiseAbs().maxCoeff(), a.crank_pin[i].cwiseAbs().maxCoeff(),
                       std::abs(a.rod[i]), a.platform_sphere[i].cwiseAbs().maxCoeff()});
    maxang = std::max({maxang, a.motor_rotation[i].cwiseAbs().maxCoeff(), std::abs(a.encoder[i])});
  }
  EXPECT_LE(maxlen, 0.01);
  EXPECT_GT(maxlen, 0.005);
  EXPECT_LE(maxang, 1e-4);
  EXPECT_GT(maxang, 5e-5);
  // One group fills only its own fields.
  const ind::Rus6Errors rods = ind::random_rus6_errors(1.0, 1.0, 3, {"rods"});
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NE(rods.rod[i], 0.0);
    EXPECT_TRUE(rods.motor_translation[i].isZero() && rods.motor_rotation[i].isZero() && rods.crank_pin[i].isZero() &&
                rods.platform_sphere[i].isZero() && rods.encoder[i] == 0.0);
  }
  EXPECT_TRUE(rods.tool_point.isZero() && rods.tool_rotation.isZero());
  EXPECT_THROW(ind::random_rus6_errors(1, 1, 1, {"spring"}), std::invalid_argument);
}

TEST(IndependentRus6Generators, GridAndRandomPosesFillTheBox) {
  for (const ind::Rus6Nominal& n : both_nominals()) {
    const std::vector<V6> grid = ind::rus6_grid_poses(n, {3, 2, 4, 1, 1, 2});
    ASSERT_EQ(grid.size(), 3u * 2 * 4 * 2);
    EXPECT_TRUE(grid.front().head<3>() == n.workspace_min.head<3>());
    EXPECT_EQ(grid.front()(3), n.home(3));
    EXPECT_EQ(grid.back()(5), n.workspace_max(5));
    EXPECT_EQ(grid[1](0), 0.5 * (n.workspace_min(0) + n.workspace_max(0)));
    for (const V6& v : ind::rus6_random_poses(n, 500, 2)) {
      EXPECT_TRUE((v.array() >= n.workspace_min.array()).all() && (v.array() <= n.workspace_max.array()).all());
    }
    const std::vector<double> t = ind::rus6_random_temperatures(200, 15, 35, 3);
    EXPECT_GE(*std::min_element(t.begin(), t.end()), 15.0);
    EXPECT_LE(*std::max_element(t.begin(), t.end()), 35.0);
    EXPECT_GT(*std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end()), 15.0);
  }
}
