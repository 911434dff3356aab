// The hybrid robot's joint/link-level error model (identify/hybrid_error_model.hpp,
// identify/gauge.hpp) against the nonlinear machine that carries every source
// error: zero errors reproduce core's FK, every column of B matches central
// differences, B·Δχ matches the nonlinear pose error for 10 µm / 10 µrad
// errors, the gauge map of seed 000 Eq. (9) matches target differences, and
// the identifiable set for two pure-translation layers (seed 000 Section 4.1).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/gauge.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/simulate.hpp"

#include "../identify/src/families/chain_kinematics.hpp"  // the closed-form limb closure, tested on its own

namespace {

using kincal::HybridPassive;
using kincal::Pose;
using kincal::Status;
using kincal::Twist;
using kincal::Vec3;
using kincal::Vec6;
using kincal::identify::HybridErrorModel;
using kincal::identify::MeasurementKind;

constexpr double kGaugeRadius = 200.0;  // seed 000 Table 1, |P0 Pj|
constexpr double kLength = 1000.0;      // mm per rad when mixing v and ω in one norm

double scaled_norm(const Twist<double>& t) {
  return std::sqrt(t.head<3>().squaredNorm() + kLength * kLength * t.tail<3>().squaredNorm());
}

const kincal::HybridGeometry<double>& geometry() {
  static const kincal::HybridGeometry<double> g = kincal::make_hybrid_seed000<double>();
  return g;
}
const HybridErrorModel& model() {
  static const HybridErrorModel m(geometry());
  return m;
}
// The alternative convention: E_j after the joint's motion (DH-like link errors).
const HybridErrorModel& model_moving() {
  static const HybridErrorModel m(geometry(), [] {
    kincal::identify::HybridErrorModelOptions o;
    o.errors_move_with_joint = true;
    return o;
  }());
  return m;
}

// Poses over the 500 × 500 × 120 mm task cuboid of {R}: a 3 × 3 × 3 grid at
// constant orientation, plus tilted poses (the model is not tied to pure translation).
std::vector<Pose<double>> cuboid_poses() {
  std::vector<Pose<double>> out;
  for (double z : {-60.0, 0.0, 60.0})
    for (double y : {-250.0, 0.0, 250.0})
      for (double x : {-250.0, 0.0, 250.0}) out.push_back(Pose<double>::from_xyz_rpy(x, y, z, 0, 0, 0));
  out.push_back(Pose<double>::from_xyz_rpy(120, -80, 30, 0.05, -0.04, 0.1));
  out.push_back(Pose<double>::from_xyz_rpy(-200, 180, -45, -0.06, 0.03, -0.08));
  out.push_back(Pose<double>::from_xyz_rpy(240, 230, 55, 0.02, 0.07, 0.0));
  return out;
}

struct Nominal {
  Vec6<double> q;
  HybridPassive<double> passive;
};
Nominal nominal_joints(const Pose<double>& pose) {
  Nominal n;
  const Status st = kincal::hybrid_ik(geometry(), pose, n.q, nullptr, &n.passive);
  EXPECT_EQ(st, Status::Ok);
  return n;
}

// pose_error(actual FK of the erroneous machine, nominal pose), in {R}.
Twist<double> nonlinear_error(const Eigen::VectorXd& chi, const Pose<double>& pose, const Nominal& n,
                              const HybridErrorModel& m = model()) {
  Pose<double> actual;
  const auto rep = m.actual_fk(chi, n.q, n.passive, actual);
  EXPECT_EQ(rep.status, Status::Ok) << "residual " << rep.residual;
  return kincal::pose_error(actual, pose);
}

// Uniform in ±size_mm (lengths) or ±size_rad (angles), every parameter.
Eigen::VectorXd random_errors(std::mt19937_64& rng, double size_mm = 0.010, double size_rad = 10e-6) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd chi(model().size());
  for (Eigen::Index k = 0; k < chi.size(); ++k)
    chi(k) = u(rng) * (model().parameters()[static_cast<std::size_t>(k)].angular() ? size_rad : size_mm);
  return chi;
}

TEST(identifyHybridErrorModel, ParameterCountAndStableNames) {
  const HybridErrorModel& m = model();
  ASSERT_EQ(m.size(), 156);  // seed 000's 150 + the tool frame's 6 (issue #31)
  ASSERT_EQ(static_cast<int>(m.parameters().size()), 156);
  std::set<std::string> names;
  for (const auto& p : m.parameters()) names.insert(p.name);
  EXPECT_EQ(names.size(), 156u);
  const char* const encoders[6] = {"dxi_3_1", "dxi_3_2", "dxi_3_3", "dxi_4_4", "dxi_5_4", "dxi_6_4"};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(m.index_of(encoders[k]), k);
    EXPECT_TRUE(m.parameters()[static_cast<std::size_t>(k)].encoder());
  }
  EXPECT_STREQ(m.parameters()[0].unit(), "mm");
  EXPECT_STREQ(m.parameters()[3].unit(), "rad");
  // Appendix A: Δη_0 has all six; R joints omit Δγ, P joints omit Δz.
  EXPECT_GE(m.index_of("dgamma_0_1"), 0);
  EXPECT_GE(m.index_of("dz_2_1"), 0);
  EXPECT_EQ(m.index_of("dgamma_2_1"), -1);
  EXPECT_EQ(m.index_of("dz_3_1"), -1);
  EXPECT_GE(m.index_of("dgamma_3_1"), 0);
  EXPECT_EQ(m.index_of("dz_3_4"), -1);
  EXPECT_GE(m.index_of("dz_4_4"), 0);
  // The tool frame comes after seed 000's 150; the UPS limbs have no frame 7.
  EXPECT_EQ(m.index_of("dx_7_1"), -1);
  EXPECT_EQ(m.index_of("dx_7_4"), 150);
  EXPECT_EQ(m.parameters()[150].symbol, "Δx_{7,4}");
  EXPECT_STREQ(m.parameters()[152].unit(), "mm");
  EXPECT_STREQ(m.parameters()[153].unit(), "rad");
  EXPECT_EQ(m.index_of("dx_8_4"), -1);
  EXPECT_EQ(m.index_of("dx_0_5"), -1);  // the wrist has no base frame of its own
  EXPECT_EQ(m.parameters()[static_cast<std::size_t>(m.index_of("dx_2_1"))].symbol, "Δx_{2,1}");
  int per_limb[5] = {0, 0, 0, 0, 0};
  for (const auto& p : m.parameters()) ++per_limb[p.limb];
  EXPECT_EQ(per_limb[1], 37);  // 6 + 6·5 + Δξ_{a,3,1}
  EXPECT_EQ(per_limb[2], 37);
  EXPECT_EQ(per_limb[3], 37);
  EXPECT_EQ(per_limb[4], 45);  // UP limb 6 + 3·5, wrist 3·5 + 3 encoders + the tool frame's 6
}

TEST(identifyHybridErrorModel, ZeroErrorsReproduceCoreFkOverTheCuboid) {
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model().size());
  double worst_p = 0, worst_r = 0;
  int count = 0;
  // The cuboid at 20 mm pitch, constant orientation, plus the tilted poses.
  std::vector<Pose<double>> poses = cuboid_poses();
  for (double z = -60; z <= 60; z += 30)
    for (double y = -250; y <= 250; y += 50)
      for (double x = -250; x <= 250; x += 50) poses.push_back(Pose<double>::from_xyz_rpy(x, y, z, 0, 0, 0));
  for (const Pose<double>& pose : poses) {
    const Nominal n = nominal_joints(pose);
    Pose<double> core_pose, ours;
    // Both from the home configuration, as a controller without history would.
    ASSERT_EQ(kincal::hybrid_fk(geometry(), n.q, geometry().home, core_pose).status, Status::Ok);
    const auto rep = model().actual_fk(zero, n.q, geometry().home, ours);
    ASSERT_EQ(rep.status, Status::Ok);
    worst_p = std::max(worst_p, (ours.p - core_pose.p).norm());
    worst_r = std::max(worst_r, kincal::pose_error(ours, core_pose).tail<3>().norm());
    ++count;
  }
  std::printf("zero errors vs core hybrid_fk over %d poses: worst %.3g mm, %.3g rad\n", count, worst_p, worst_r);
  EXPECT_LT(worst_p, 1e-9);
  EXPECT_LT(worst_r, 1e-12);
}

// The UPS limbs' nominal closure (the closed form of chain_kinematics.hpp,
// which B uses at every pose; its Newton fallback would hide a wrong closed
// form from ups_frames, so the joint values are compared too) against a
// closure this test makes itself: Newton with a finite-difference Jacobian of
// the limb's own frames, from the reference configuration. Poses: the cuboid,
// then tilts of 0.3 rad and an 80 mm excursion below it (past the task, where
// the S angles are large).
TEST(identifyHybridErrorModel, UpsClosureInClosedFormMatchesAnIndependentNewton) {
  const HybridErrorModel& m = model();
  std::vector<Pose<double>> poses = cuboid_poses();
  poses.push_back(Pose<double>::from_xyz_rpy(-150, 60, -140, 0.3, -0.25, 0.3));
  poses.push_back(Pose<double>::from_xyz_rpy(200, -220, 40, -0.3, 0.3, -0.2));
  const double e = kincal::identify::HybridErrorModelOptions().up_split;
  double worst = 0;
  for (const Pose<double>& pose : poses) {
    const Nominal n = nominal_joints(pose);
    const double xu[3] = {n.passive.theta1, n.passive.theta2, n.passive.extension - e};
    const Pose<double> platform = m.chain_frames(3, Pose<double>(), xu, nullptr).end;
    for (int i = 0; i < 3; ++i) {
      kincal::identify::HybridChainFrames ours;
      ASSERT_TRUE(m.ups_frames(i, platform, ours));
      const Pose<double> target = platform * m.attachment(i);
      auto residual = [&](const Vec6<double>& x) {
        const Pose<double> end = m.chain_frames(i, Pose<double>(), x.data(), nullptr).end;
        Vec6<double> r;
        r.head<3>() = end.p - target.p;
        r.tail<3>() = kLength * kincal::log_so3(kincal::Mat3<double>(end.R * target.R.transpose()));
        return r;
      };
      const kincal::Vec3<double> A1 = m.chain(i).base.p, A6 = target.p;
      Vec6<double> x;
      x << 0, 0, (A6 - A1).norm(), 0, 0, 0;
      for (int it = 0; it < 30 && residual(x).norm() > 1e-12; ++it) {
        Eigen::Matrix<double, 6, 6> J;
        for (int k = 0; k < 6; ++k) {
          Vec6<double> d = Vec6<double>::Zero();
          d(k) = 1e-7;
          J.col(k) = (residual(x + d) - residual(x - d)) / 2e-7;
        }
        x -= J.partialPivLu().solve(residual(x));
      }
      ASSERT_LT(residual(x).norm(), 1e-9);
      Vec6<double> closed;  // the hybrid's reference end frame has the platform's axes: E = attachment's R
      ASSERT_TRUE(kincal::identify::chain::nominal_ups_joints(A1, m.attachment(i).R, target, closed));
      worst = std::max(worst, (closed - x).cwiseAbs().maxCoeff() * kLength);
      const kincal::identify::HybridChainFrames theirs = m.chain_frames(i, Pose<double>(), x.data(), nullptr);
      ASSERT_EQ(ours.count, theirs.count);
      for (int f = 0; f < ours.count; ++f) {
        worst = std::max(worst, (ours.axis[std::size_t(f)].p - theirs.axis[std::size_t(f)].p).norm());
        worst = std::max(worst, kLength * (ours.axis[std::size_t(f)].R - theirs.axis[std::size_t(f)].R).norm());
      }
    }
  }
  std::printf("UPS closure, closed form vs FD Newton over %zu poses: worst joint or frame difference %.3g mm (rad × 1 m)\n", poses.size(),
              worst);
  EXPECT_LT(worst, 1e-8);
}

TEST(identifyHybridErrorModel, EveryColumnMatchesCentralDifferences) {
  for (const HybridErrorModel* mp : {&model(), &model_moving()}) {
  const HybridErrorModel& m = *mp;
  const double h = 1e-4;  // mm or rad (error ∝ 1/h below: the FK's 1e-11 mm resolution)
  double worst = 0;
  std::string worst_name;
  const std::vector<Pose<double>> all = cuboid_poses();
  const std::vector<Pose<double>> poses = {all[13], all[0], all[26], all[27], all[28]};
  Eigen::MatrixXd B;
  for (const Pose<double>& pose : poses) {
    const Nominal n = nominal_joints(pose);
    ASSERT_EQ(m.error_jacobian(pose, B), Status::Ok);
    for (int k = 0; k < m.size(); ++k) {
      Eigen::VectorXd chi = Eigen::VectorXd::Zero(m.size());
      chi(k) = h;
      const Twist<double> plus = nonlinear_error(chi, pose, n, m);
      chi(k) = -h;
      const Twist<double> minus = nonlinear_error(chi, pose, n, m);
      const Twist<double> fd = (plus - minus) / (2 * h);
      const Twist<double> col = B.col(k);
      // Relative to the column's size; columns that vanish (e.g. rotations of
      // a UPS base frame, whose actuation wrench passes through A1) absolutely.
      const double err = scaled_norm(col - fd) / std::max(scaled_norm(fd), 1e-2);
      if (err > worst) {
        worst = err;
        worst_name = m.parameters()[static_cast<std::size_t>(k)].name;
      }
      EXPECT_LT(err, 1e-5) << m.parameters()[static_cast<std::size_t>(k)].name << " at " << pose.p.transpose()
                           << "\n B  " << col.transpose() << "\n FD " << fd.transpose();
    }
  }
  std::printf("B vs central differences (5 poses × 150 columns, %s): worst column %s, relative error %.3g\n",
              mp == &model() ? "errors before joint motion" : "errors after joint motion", worst_name.c_str(), worst);
  }
}

TEST(identifyHybridErrorModel, LinearModelMatchesNonlinearMachineFor10umErrors) {
  for (const HybridErrorModel* mp : {&model(), &model_moving()}) {
  const HybridErrorModel& m = *mp;
  std::mt19937_64 rng(20240601);
  const std::vector<Pose<double>> poses = cuboid_poses();  // 30 poses
  ASSERT_GE(poses.size(), 20u);
  Eigen::MatrixXd B;
  double worst = 0, typical = 0;
  int count = 0;
  for (int draw = 0; draw < 5; ++draw) {
    const Eigen::VectorXd chi = random_errors(rng);  // 10 µm / 10 µrad, every parameter
    for (const Pose<double>& pose : poses) {
      const Nominal n = nominal_joints(pose);
      ASSERT_EQ(m.error_jacobian(pose, B), Status::Ok);
      const Twist<double> lin = B * chi;
      const Twist<double> nl = nonlinear_error(chi, pose, n, m);
      const double rel = scaled_norm(lin - nl) / scaled_norm(nl);
      worst = std::max(worst, rel);
      typical += scaled_norm(nl);
      ++count;
      EXPECT_LT(rel, 0.01) << "at " << pose.p.transpose() << "\n lin " << lin.transpose() << "\n nl  "
                           << nl.transpose();
    }
  }
  std::printf("B·Δχ vs nonlinear pose error (%s), %d cases (5 draws × %zu poses), mean |$_t| %.3g "
              "(mm, 1000 mm·rad): worst discrepancy %.4g %%\n",
              mp == &model() ? "errors before joint motion" : "errors after joint motion", count, poses.size(),
              typical / count, 100 * worst);
  }
}

TEST(identifyHybridErrorModel, GaugeMapSignAndMeasurementModels) {
  const kincal::HybridGeometry<double>& g = geometry();
  // P_k of Eq. (9) against finite differences of the target positions under a
  // small rigid twist of the tool pose (checks the sign of [p̂_j×]).
  const Pose<double> pose = cuboid_poses()[27];
  const Eigen::Matrix<double, 9, 6> Pk = kincal::identify::gauge_map(g, kGaugeRadius, pose);
  const double h = 1e-6;
  for (int c = 0; c < 6; ++c) {
    Twist<double> t = Twist<double>::Zero();
    t(c) = h;
    const Pose<double> plus = kincal::apply_twist(pose, t);
    t(c) = -h;
    const Pose<double> minus = kincal::apply_twist(pose, t);
    const Eigen::VectorXd fd =
        (kincal::identify::measurement_deviation(MeasurementKind::GaugeTargets, g, kGaugeRadius, plus, pose) -
         kincal::identify::measurement_deviation(MeasurementKind::GaugeTargets, g, kGaugeRadius, minus, pose)) /
        (2 * h);
    EXPECT_LT((Pk.col(c) - fd).norm(), 1e-6 * std::max(1.0, fd.norm())) << "column " << c;
  }
  // Targets measured on the erroneous machine vs H rows for all three kinds.
  std::mt19937_64 rng(7);
  const Eigen::VectorXd chi = random_errors(rng);
  const std::vector<Pose<double>> nodes = {cuboid_poses()[0], cuboid_poses()[17], cuboid_poses()[28]};
  double worst = 0;
  for (MeasurementKind kind : {MeasurementKind::GaugeTargets, MeasurementKind::FullPose, MeasurementKind::Position}) {
    const Eigen::MatrixXd H = kincal::identify::identification_jacobian(model(), kind, kGaugeRadius, nodes);
    const int r = kincal::identify::measurement_rows(kind);
    ASSERT_EQ(H.rows(), r * 3);
    ASSERT_EQ(H.cols(), model().size());
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const Nominal n = nominal_joints(nodes[k]);
      Pose<double> actual;
      ASSERT_EQ(model().actual_fk(chi, n.q, n.passive, actual).status, Status::Ok);
      const Eigen::VectorXd dy =
          kincal::identify::measurement_deviation(kind, g, kGaugeRadius, actual, nodes[k]);
      const Eigen::VectorXd pred = H.middleRows(static_cast<Eigen::Index>(k) * r, r) * chi;
      Eigen::VectorXd diff = pred - dy, ref = dy;
      if (kind == MeasurementKind::FullPose) {  // mix v and ω in one unit
        diff.tail<3>() *= kLength;
        ref.tail<3>() *= kLength;
      }
      const double rel = diff.norm() / ref.norm();
      worst = std::max(worst, rel);
      EXPECT_LT(rel, 0.01) << "kind " << static_cast<int>(kind) << " node " << k;
    }
  }
  std::printf("H·Δχ vs nonlinear measurements (gauge 9, pose 6, position 3 rows): worst %.4g %%\n", 100 * worst);
  // Target differences through identify::gauge_targets (the simulator's convention).
  const auto t = kincal::identify::gauge_targets(g, kGaugeRadius, pose);
  for (int j = 0; j < 3; ++j) EXPECT_NEAR((pose.p - t.col(j)).norm(), std::hypot(250.0, 200.0), 1e-9);
}

// Seed 000 Section 4.1, second way: start from the encoder-offset columns and
// add each structural column only if it raises the rank. A minimal local
// version (identify/identifiability.hpp will hold the shared one).
int numerical_rank(const Eigen::MatrixXd& A, double tol) {
  if (A.cols() == 0) return 0;
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(A);
  const auto& s = svd.singularValues();
  int r = 0;
  for (Eigen::Index k = 0; k < s.size(); ++k)
    if (s(k) > tol * s(0)) ++r;
  return r;
}

struct Identifiable {
  int rank = 0;
  std::vector<int> kept;
};

Identifiable identifiable_set(const HybridErrorModel& m, const char* label) {
  Identifiable out;
  // Two layers of 7 × 7 nodes, z = ±60 mm, pure translation over ±250 mm (seed 000 Section 5).
  const std::vector<Pose<double>> nodes = kincal::identify::translation_grid({-60.0, 60.0}, 7, 250.0);
  EXPECT_EQ(nodes.size(), 98u);
  const auto t0 = std::chrono::steady_clock::now();
  Eigen::MatrixXd H;
  kincal::identify::identification_jacobian(m, MeasurementKind::GaugeTargets, kGaugeRadius, nodes, H);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(H.rows(), 9 * 98);
  // Column scaling: every column to unit norm (rank is then unit-free);
  // columns that vanish identically (|h| < 1e-9) are left out.
  Eigen::MatrixXd Hn = H;
  std::vector<bool> zero_col(static_cast<std::size_t>(H.cols()), false);
  for (Eigen::Index k = 0; k < H.cols(); ++k) {
    const double nrm = H.col(k).norm();
    if (nrm < 1e-9) {
      zero_col[static_cast<std::size_t>(k)] = true;
      Hn.col(k).setZero();
    } else {
      Hn.col(k) /= nrm;
    }
  }
  const double tol = 1e-9;  // σ_i > 1e-9·σ_max of the column-normalised H
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(Hn);
  const auto& s = svd.singularValues();
  out.rank = numerical_rank(Hn, tol);
  std::printf("[%s] H: %lld × %lld built in %.2f ms; rank %d (tol %.0e·σ_max); σ/σ_max around the cut:", label,
              static_cast<long long>(H.rows()), static_cast<long long>(H.cols()), ms, out.rank, tol);
  for (int k = std::max(0, out.rank - 3); k < std::min<int>(static_cast<int>(s.size()), out.rank + 3); ++k)
    std::printf(" %.3g", s(k) / s(0));
  std::printf("\n");

  // Reconstruction: H_ξ first, then each Δη column in Δχ order.
  for (int k = 0; k < HybridErrorModel::kEncoderCount; ++k) out.kept.push_back(k);
  Eigen::MatrixXd Hk = Hn.leftCols(HybridErrorModel::kEncoderCount);
  EXPECT_EQ(numerical_rank(Hk, tol), HybridErrorModel::kEncoderCount);  // rank(H_ξ) = f
  int current = HybridErrorModel::kEncoderCount;
  for (int k = HybridErrorModel::kEncoderCount; k < m.size(); ++k) {
    if (zero_col[static_cast<std::size_t>(k)]) continue;
    Eigen::MatrixXd trial(Hk.rows(), Hk.cols() + 1);
    trial << Hk, Hn.col(k);
    const int r = numerical_rank(trial, tol);
    if (r == current + 1) {
      Hk = std::move(trial);
      out.kept.push_back(k);
      current = r;
    }
  }
  EXPECT_EQ(current, out.rank);
  std::string list;
  int last_limb = 0;
  bool encoders = true;
  for (int k : out.kept) {
    const auto& p = m.parameters()[static_cast<std::size_t>(k)];
    if (p.limb != last_limb || (encoders && !p.encoder())) {
      list += "\n  limb " + std::to_string(p.limb) + ":";
      last_limb = p.limb;
      encoders = p.encoder();
    }
    list += " " + p.name;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd_k(Hk);
  std::printf("[%s] identifiable (reconstructed H): %zu of %d (seed 000: 54 of 145); condition number of the "
              "column-normalised reconstructed H %.3g%s\n",
              label, out.kept.size(), m.size(),
              svd_k.singularValues()(0) / svd_k.singularValues()(svd_k.singularValues().size() - 1), list.c_str());
  return out;
}

TEST(identifyHybridErrorModel, IdentifiableSetForTwoPureTranslationLayers) {
  const Identifiable before = identifiable_set(model(), "errors before joint motion");
  // docs/hybrid-error-model.md §8: 50 of seed 000's 150 (seed 000: 54 of
  // 145), and two of the tool frame's rotations (dbeta_7_4, dgamma_7_4: the
  // gauge's targets are fixed in the tool frame; its translations are the
  // wrist's). 51 before the S centres on the platform (§3).
  EXPECT_EQ(before.rank, 52);
  const auto kept_name = [&](const char* n) {
    return std::find(before.kept.begin(), before.kept.end(), model().index_of(n)) != before.kept.end();
  };
  EXPECT_TRUE(kept_name("dbeta_7_4") && kept_name("dgamma_7_4"));
  EXPECT_EQ(static_cast<int>(before.kept.size()), before.rank);
  const Identifiable after = identifiable_set(model_moving(), "errors after joint motion");
  EXPECT_EQ(static_cast<int>(after.kept.size()), after.rank);
}

}  // namespace
