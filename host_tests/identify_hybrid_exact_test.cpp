// core's exact erroneous hybrid (core/hybrid_exact.hpp: chains with Δχ folded
// into their links, Newton IK and FK) against identify's nonlinear machine
// (HybridErrorModel::actual_fk, whose chains are rebuilt from the source
// errors at every call and closed by its own Newton code), and against
// itself: IK then FK returns the pose. Errors at two sizes (10 µm / 20 µrad
// and 1 mm / 2 mrad, issue #31's nonlinear case), random poses over the task
// workspace with tilts, double and float.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "kincal/core/hybrid_exact.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/hybrid_error_model.hpp"

namespace {

using kincal::HybridChains;
using kincal::HybridErrorLayout;
using kincal::HybridGeometry;
using kincal::HybridPassive;
using kincal::Pose;
using kincal::Status;
using kincal::Vec6;

constexpr double kUpSplit = 345.0;

const HybridGeometry<double>& geometry() {
  static const HybridGeometry<double> g = kincal::make_hybrid_seed000<double>();
  return g;
}

Eigen::VectorXd random_errors(std::mt19937& rng, double length_mm, double angle_rad) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd e(HybridErrorLayout::size());
  for (int k = 0; k < e.size(); ++k) e(k) = u(rng) * (HybridErrorLayout::angular(k) ? angle_rad : length_mm);
  return e;
}

// The same with every S joint a ball, as identify writes its models (the
// S axes' offsets dx_5_i, dy_5_i, dz_5_i and the last axis's tilts
// dalpha_6_i, dbeta_6_i held at zero): the stored chains then close each
// UPS limb on its ball's centre (close_ups_on_centre, three unknowns)
// instead of its end frame (six). random_errors's machines take the
// six-joint closure.
Eigen::VectorXd ball_errors(std::mt19937& rng, double length_mm, double angle_rad) {
  Eigen::VectorXd e = random_errors(rng, length_mm, angle_rad);
  for (int i = 0; i < 3; ++i) {
    const int limb = HybridErrorLayout::ups(i);
    for (int k = 0; k < 3; ++k) e(limb + 6 + 5 * 4 + k) = 0;  // joint 4's translations
    for (int k = 3; k < 5; ++k) e(limb + 6 + 5 * 5 + k) = 0;  // joint 5's tilts
  }
  return e;
}

enum class Balls { No, Yes };
Eigen::VectorXd machine_errors(Balls balls, std::mt19937& rng, double length_mm, double angle_rad) {
  return balls == Balls::Yes ? ball_errors(rng, length_mm, angle_rad) : random_errors(rng, length_mm, angle_rad);
}
bool every_limb_a_ball(const HybridChains<double>& c) { return c.ups_ball[0] && c.ups_ball[1] && c.ups_ball[2]; }
bool no_limb_a_ball(const HybridChains<double>& c) { return !c.ups_ball[0] && !c.ups_ball[1] && !c.ups_ball[2]; }

// A pose of the task workspace (500 × 500 × 120 mm about {R}'s origin), tilted
// up to 0.15 rad about each axis.
Pose<double> random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Pose<double>::from_xyz_rpy(250 * u(rng), 250 * u(rng), 60 * u(rng), 0.15 * u(rng), 0.15 * u(rng),
                                    0.15 * u(rng));
}

double position_gap(const Pose<double>& a, const Pose<double>& b) { return (a.p - b.p).norm(); }
double rotation_gap(const Pose<double>& a, const Pose<double>& b) { return (a.R - b.R).cwiseAbs().maxCoeff(); }

TEST(HybridExact, ZeroErrorsAreTheNominalMachine) {
  const HybridGeometry<double>& g = geometry();
  HybridChains<double> c;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(HybridErrorLayout::size());
  ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, zero.data(), c), Status::Ok);
  std::mt19937 rng(11);
  for (int n = 0; n < 100; ++n) {
    const Pose<double> pose = random_pose(rng);
    Vec6<double> q_nominal, q_exact;
    ASSERT_EQ(kincal::hybrid_ik(g, pose, q_nominal), Status::Ok);
    ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, q_exact), Status::Ok);
    EXPECT_LT((q_exact - q_nominal).cwiseAbs().maxCoeff(), 1e-9) << "pose " << n;
    Pose<double> fk_nominal, fk_exact;
    ASSERT_EQ(kincal::hybrid_fk(g, q_nominal, g.home, fk_nominal).status, Status::Ok);
    ASSERT_EQ(kincal::hybrid_exact_fk(g, c, q_nominal, g.home, fk_exact).status, Status::Ok);
    EXPECT_LT(position_gap(fk_exact, fk_nominal), 1e-9);
    EXPECT_LT(rotation_gap(fk_exact, fk_nominal), 1e-12);
  }
}

// core's FK of the folded chains equals identify's actual_fk, which applies
// each E_j while walking the chain: the same machine, two code paths.
TEST(HybridExact, ForwardKinematicsEqualsIdentifysNonlinearMachine) {
  const HybridGeometry<double>& g = geometry();
  const kincal::identify::HybridErrorModel model(g);
  std::mt19937 rng(5);
  for (const auto& [length, angle] : {std::pair{0.01, 2e-5}, std::pair{1.0, 2e-3}}) {
    for (int m = 0; m < 4; ++m) {
      const Eigen::VectorXd errors = random_errors(rng, length, angle);
      HybridChains<double> c;
      ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::Ok);
      double worst = 0;
      for (int n = 0; n < 20; ++n) {
        Vec6<double> q;
        ASSERT_EQ(kincal::hybrid_ik(g, random_pose(rng), q), Status::Ok);
        Pose<double> truth, core;
        ASSERT_EQ(model.actual_fk(errors, q, g.home, truth).status, Status::Ok);
        const auto report = kincal::hybrid_exact_fk(g, c, q, g.home, core);
        ASSERT_EQ(report.status, Status::Ok);
        worst = std::max(worst, position_gap(core, truth));
        EXPECT_LT(rotation_gap(core, truth), 1e-12);
      }
      EXPECT_LT(worst, 1e-9) << "errors " << length << " mm / " << angle << " rad, machine " << m;
      // The errors are really there: the machine is far from the nominal one.
      Vec6<double> q;
      ASSERT_EQ(kincal::hybrid_ik(g, Pose<double>(), q), Status::Ok);
      Pose<double> nominal, actual;
      ASSERT_EQ(kincal::hybrid_fk(g, q, g.home, nominal).status, Status::Ok);
      ASSERT_EQ(kincal::hybrid_exact_fk(g, c, q, g.home, actual).status, Status::Ok);
      EXPECT_GT(position_gap(actual, nominal), 100 * length * 0.01);
    }
  }
}

// The exact IK inverts the exact machine: the commands it gives put the
// erroneous tool on the pose asked for, to rounding — at 1 mm / 2 mrad,
// where the first-order model leaves micrometres (issue #31).
TEST(HybridExact, InverseKinematicsInvertsTheErroneousMachine) {
  const HybridGeometry<double>& g = geometry();
  const kincal::identify::HybridErrorModel model(g);
  std::mt19937 rng(23);
  for (const Balls balls : {Balls::No, Balls::Yes})
  for (const auto& [length, angle] : {std::pair{0.1, 3e-4}, std::pair{1.0, 2e-3}}) {
    const Eigen::VectorXd errors = machine_errors(balls, rng, length, angle);
    HybridChains<double> c;
    ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::Ok);
    ASSERT_TRUE(balls == Balls::Yes ? every_limb_a_ball(c) : no_limb_a_ball(c));
    double worst_p = 0, worst_r = 0;
    for (int n = 0; n < 100; ++n) {
      const Pose<double> pose = random_pose(rng);
      Vec6<double> q;
      HybridPassive<double> passive;
      ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, q, &passive), Status::Ok) << "pose " << n;
      Pose<double> reached;
      ASSERT_EQ(model.actual_fk(errors, q, g.home, reached).status, Status::Ok);
      worst_p = std::max(worst_p, position_gap(reached, pose));
      worst_r = std::max(worst_r, rotation_gap(reached, pose));
    }
    EXPECT_LT(worst_p, 1e-9) << length << " mm, balls " << int(balls);
    EXPECT_LT(worst_r, 1e-12) << length << " mm, balls " << int(balls);
  }
}

// Which limbs are balls (hybrid_ups_ball): a tilt of the S's last axis
// with a displacement along it moves that axis off the centre; either alone
// does not. Each classification is checked by its result: the IK's
// commands put identify's nonlinear machine on the pose.
TEST(HybridExact, ABallIsAnSWhoseAxesMeetInOnePoint) {
  const HybridGeometry<double>& g = geometry();
  const kincal::identify::HybridErrorModel model(g);
  std::mt19937 rng(29);
  const int last_axis = HybridErrorLayout::ups(0) + 6 + 5 * 5;  // limb 1's joint 5: dx, dy, dz, dalpha, dbeta
  struct Case {
    double dz, dalpha;
    bool ball;
  };
  for (const Case k : {Case{0.4, 0.0, true}, Case{0.4, 1e-3, false}, Case{0.0, 1e-3, true}}) {
    Eigen::VectorXd errors = ball_errors(rng, 0.5, 1e-3);
    errors(last_axis + 2) = k.dz;
    errors(last_axis + 3) = k.dalpha;
    HybridChains<double> c;
    ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::Ok);
    EXPECT_EQ(c.ups_ball[0], k.ball) << k.dz << " mm, " << k.dalpha << " rad";
    EXPECT_TRUE(c.ups_ball[1] && c.ups_ball[2]);
    for (int n = 0; n < 30; ++n) {
      const Pose<double> pose = random_pose(rng);
      Vec6<double> q;
      ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, q), Status::Ok) << "pose " << n;
      Pose<double> reached;
      ASSERT_EQ(model.actual_fk(errors, q, g.home, reached).status, Status::Ok);
      EXPECT_LT(position_gap(reached, pose), 1e-9) << k.dz << " mm, " << k.dalpha << " rad, pose " << n;
    }
  }
}

// The controller's form, which builds each chain from the table's numbers
// where it needs it (no stored chains) and closes every UPS limb on its end
// frame (six joints), gives the stored form's commands — also where the
// stored form closes a ball's limb on its centre (three joints).
TEST(HybridExact, TheTableFormEqualsTheStoredChains) {
  const HybridGeometry<double>& g = geometry();
  std::mt19937 rng(41);
  for (const Balls balls : {Balls::No, Balls::Yes}) {
  Eigen::VectorXd errors = machine_errors(balls, rng, 0.5, 1e-3);
  const Eigen::VectorXd encoder = random_errors(rng, 0.2, 5e-4).head<6>();
  HybridChains<double> c;
  ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c, encoder.data()), Status::Ok);
  ASSERT_TRUE(balls == Balls::Yes ? every_limb_a_ball(c) : no_limb_a_ball(c));
  for (int n = 0; n < 50; ++n) {
    const Pose<double> pose = random_pose(rng);
    Vec6<double> stored, from_table;
    ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, stored), Status::Ok);
    ASSERT_EQ(kincal::hybrid_exact_ik(g, kUpSplit, errors.data(), encoder.data(), pose, from_table), Status::Ok);
    // The same Newton on the same chains agrees to rounding; the two
    // closures of a ball's limb each stop within HybridExactTolerance's
    // 1e-10 mm of the solution.
    const double agree = balls == Balls::Yes ? 1e-9 : 1e-12;
    EXPECT_LT((stored - from_table).cwiseAbs().maxCoeff(), agree) << "pose " << n << ", balls " << int(balls);
  }
  }
}

// An NC stream's points start from the last one's solution
// (HybridExactWarmStart): on a random walk of 0–0.8 mm and up to 1 mrad a
// step (not the benchmark's circle), with a jump of 5–60 mm every 25 points
// (beyond kHybridWarmReach: those start cold), at 0.1 mm / 0.3 mrad and
// 1 mm / 2 mrad, the commands equal the cold start's to 1e-9 and identify's
// nonlinear machine (its own chains and Newton) puts the tool on the pose.
TEST(HybridExact, AStreamStartsFromItsLastPoint) {
  const HybridGeometry<double>& g = geometry();
  const kincal::identify::HybridErrorModel model(g);
  std::mt19937 rng(67);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Balls balls : {Balls::No, Balls::Yes})
  for (const auto& [length, angle] : {std::pair{0.1, 3e-4}, std::pair{1.0, 2e-3}}) {
    const Eigen::VectorXd errors = machine_errors(balls, rng, length, angle);
    HybridChains<double> c;
    ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::Ok);
    kincal::HybridExactWarmStart<double> warm;
    Pose<double> pose = Pose<double>::from_xyz_rpy(-40, 60, 10, 0.05, -0.03, 0.02);
    double worst_q = 0, worst_p = 0;
    int near = 0;
    for (int n = 0; n < 200; ++n) {
      if (n % 25 == 24) {  // a jump
        const Eigen::Vector3d d(u(rng), u(rng), u(rng));
        pose.p += (5.0 + 55.0 * std::abs(u(rng))) * d.normalized();
      } else {
        const Eigen::Vector3d d(u(rng), u(rng), u(rng)), axis(u(rng), u(rng), u(rng));
        pose.p += 0.8 * std::abs(u(rng)) * d.normalized();
        pose.R = pose.R * Eigen::AngleAxisd(1e-3 * u(rng), axis.normalized()).toRotationMatrix();
        if (n > 0) ++near;  // the first point has no last one
      }
      pose.p = pose.p.cwiseMax(Eigen::Vector3d(-240, -240, -55)).cwiseMin(Eigen::Vector3d(240, 240, 55));
      Vec6<double> streamed, cold;
      HybridPassive<double> passive_streamed, passive_cold;
      ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, streamed, &passive_streamed, &warm), Status::Ok) << n;
      ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, cold, &passive_cold), Status::Ok) << n;
      worst_q = std::max(worst_q, (streamed - cold).cwiseAbs().maxCoeff());
      EXPECT_LT(std::abs(passive_streamed.extension - passive_cold.extension), 1e-9);
      Pose<double> reached;
      ASSERT_EQ(model.actual_fk(errors, streamed, g.home, reached).status, Status::Ok);
      worst_p = std::max(worst_p, position_gap(reached, pose));
      EXPECT_LT(rotation_gap(reached, pose), 1e-12) << n;
    }
    EXPECT_LT(worst_q, 1e-9) << length << " mm, balls " << int(balls);
    EXPECT_LT(worst_p, 1e-9) << length << " mm, balls " << int(balls);
    // The near points did start from the last one (a jump and the first
    // point did not): every closure of each.
    EXPECT_EQ(warm.serial.reused, std::uint32_t(near));
    for (const auto& limb : warm.ups) EXPECT_EQ(limb.reused, std::uint32_t(near));
  }
}

// A start that belongs to another machine (a compensator rebuilt at the same
// address, or a state handed to the wrong one) cannot make the IK wrong: the
// residual it assumes is not the chain's, and the Newton's own evaluations
// decide. Machine B's commands from machine A's starts equal B's cold ones.
TEST(HybridExact, AnotherMachinesStartCannotMisleadTheIk) {
  const HybridGeometry<double>& g = geometry();
  std::mt19937 rng(71);
  const Eigen::VectorXd errors_a = random_errors(rng, 1.0, 2e-3), errors_b = random_errors(rng, 1.0, 2e-3);
  HybridChains<double> a, b;
  ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors_a.data(), a), Status::Ok);
  ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors_b.data(), b), Status::Ok);
  for (int n = 0; n < 30; ++n) {
    const Pose<double> pose = random_pose(rng);
    Pose<double> next = pose;
    next.p += Eigen::Vector3d(0.3, -0.2, 0.1);
    kincal::HybridExactWarmStart<double> warm;
    Vec6<double> q, from_a, cold;
    ASSERT_EQ(kincal::hybrid_exact_ik(g, a, pose, q, nullptr, &warm), Status::Ok);
    warm.chains = &b;  // as if b lived where a did
    ASSERT_EQ(kincal::hybrid_exact_ik(g, b, next, from_a, nullptr, &warm), Status::Ok) << n;
    ASSERT_EQ(kincal::hybrid_exact_ik(g, b, next, cold), Status::Ok);
    EXPECT_LT((from_a - cold).cwiseAbs().maxCoeff(), 1e-9) << "pose " << n;
  }
  // The address check itself: a start made on a is not used for b.
  kincal::HybridExactWarmStart<double> warm;
  Vec6<double> q;
  ASSERT_EQ(kincal::hybrid_exact_ik(g, a, Pose<double>(), q, nullptr, &warm), Status::Ok);
  ASSERT_EQ(kincal::hybrid_exact_ik(g, b, Pose<double>(), q, nullptr, &warm), Status::Ok);
  EXPECT_EQ(warm.chains, &b);
  EXPECT_EQ(warm.serial.reused, 0u);
}

TEST(HybridExact, FloatFollowsDouble) {
  const HybridGeometry<double>& g = geometry();
  const HybridGeometry<float> gf = g.cast<float>();
  std::mt19937 rng(3);
  for (const Balls balls : {Balls::No, Balls::Yes}) {
  const Eigen::VectorXd errors = machine_errors(balls, rng, 1.0, 2e-3);
  const Eigen::VectorXf errors_f = errors.cast<float>();
  HybridChains<double> c;
  HybridChains<float> cf;
  ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::Ok);
  ASSERT_EQ(kincal::hybrid_exact_chains(gf, float(kUpSplit), errors_f.data(), cf), Status::Ok);
  ASSERT_EQ(cf.ups_ball[0], balls == Balls::Yes);
  for (int n = 0; n < 50; ++n) {
    const Pose<double> pose = random_pose(rng);
    Vec6<double> q;
    Vec6<float> qf;
    ASSERT_EQ(kincal::hybrid_exact_ik(g, c, pose, q), Status::Ok);
    ASSERT_EQ(kincal::hybrid_exact_ik(gf, cf, pose.cast<float>(), qf), Status::Ok) << "pose " << n;
    // float rounding of 1 m chains: ~1e-4 mm per chain, the wrist in rad.
    EXPECT_LT((qf.cast<double>() - q).head<3>().cwiseAbs().maxCoeff(), 2e-3) << "pose " << n;
    EXPECT_LT((qf.cast<double>() - q).tail<3>().cwiseAbs().maxCoeff(), 2e-5) << "pose " << n;
  }
  }
}

// core's libm-free sin / cos (core/sin_cos.hpp: reduction, halving, series,
// doubling) against libm, on joint angles and on angles many turns out.
TEST(HybridExact, SinCosWithoutLibmMatchesLibm) {
  double worst = 0, worst_far = 0, worst_f = 0;
  for (int k = -20000; k <= 20000; ++k) {
    const double a = 1e-3 * k + 1e-7 * (k % 7);  // -20 … 20 rad, off the grid
    double s = 0, c = 0;
    ASSERT_TRUE(kincal::sin_cos(a, s, c));
    const double gap = std::max(std::abs(s - std::sin(a)), std::abs(c - std::cos(a)));
    (std::abs(a) <= 4.0 ? worst : worst_far) = std::max(std::abs(a) <= 4.0 ? worst : worst_far, gap);
    float sf = 0, cf = 0;
    ASSERT_TRUE(kincal::sin_cos(float(a), sf, cf));
    worst_f = std::max({worst_f, std::abs(double(sf) - std::sin(double(float(a)))),
                        std::abs(double(cf) - std::cos(double(float(a))))});
  }
  double worst_turns = 0;  // many turns out: the reduction to [−π, π]
  for (int k = 1; k <= 2000; ++k) {
    const double a = (k % 2 ? 1.0 : -1.0) * (0.5 * k + 1e-3 * (k % 13));
    double s = 0, c = 0;
    ASSERT_TRUE(kincal::sin_cos(a, s, c));
    worst_turns = std::max({worst_turns, std::abs(s - std::sin(a)), std::abs(c - std::cos(a))});
  }
  EXPECT_LT(worst, 1e-14);        // joint angles (|a| ≤ 4 rad): at most five doublings
  EXPECT_LT(worst_far, 2e-14);    // to 20 rad: reduced to [−π, π] first
  EXPECT_LT(worst_turns, 2e-13);  // to 1000 rad: k·2π's rounding, ~|a|·1e-16
  EXPECT_LT(worst_f, 2e-5);
  double s = 7, c = 7;
  EXPECT_FALSE(kincal::sin_cos(2e9, s, c));
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
  s = c = 7;
  EXPECT_FALSE(kincal::sin_cos(std::nan(""), s, c));
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
  EXPECT_FALSE(kincal::sin_cos(std::numeric_limits<double>::infinity(), s, c));
}

TEST(HybridExact, BadInputIsAStatus) {
  const HybridGeometry<double>& g = geometry();
  Eigen::VectorXd errors = Eigen::VectorXd::Zero(HybridErrorLayout::size());
  HybridChains<double> c;
  errors(40) = std::nan("");
  EXPECT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::InvalidInput);
  errors(40) = 0.0;
  ASSERT_EQ(kincal::hybrid_exact_chains(g, kUpSplit, errors.data(), c), Status::Ok);
  Pose<double> pose;
  pose.p.x() = std::nan("");
  Vec6<double> q = Vec6<double>::Constant(7.0);
  EXPECT_EQ(kincal::hybrid_exact_ik(g, c, pose, q), Status::InvalidInput);
  EXPECT_EQ(q, Vec6<double>::Constant(7.0));  // untouched
  // Out of reach: the tool point on the UP limb's U centre A0 ({R0}'s origin).
  Pose<double> at_base;
  at_base.p = -(g.workpiece_rotation * g.workpiece_origin);
  EXPECT_EQ(kincal::hybrid_exact_ik(g, c, at_base, q), Status::Unreachable);
  EXPECT_EQ(q, Vec6<double>::Constant(7.0));
  Pose<double> out;
  Vec6<double> bad = Vec6<double>::Zero();
  bad(2) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(kincal::hybrid_exact_fk(g, c, bad, g.home, out).status, Status::InvalidInput);
}

}  // namespace
