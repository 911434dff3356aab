// The 6-UPS stewart-seed001's joint-level error model (identify/stewart_error_model.hpp)
// against the nonlinear machine carrying every source error: zero errors
// reproduce core's stewart_fk, every column of B matches central differences,
// B·Δχ matches the nonlinear pose error for 10 µm / 10 µrad errors, and the
// rank for full-pose measurements on examples/seed001/grid_poses.csv.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/stewart_error_model.hpp"

namespace {

using kincal::Pose;
using kincal::Status;
using kincal::Twist;
using kincal::Vec6;
using kincal::identify::StewartErrorModel;

constexpr double kLength = 1000.0;  // mm per rad when mixing v and ω in one norm

double scaled_norm(const Twist<double>& t) {
  return std::sqrt(t.head<3>().squaredNorm() + kLength * kLength * t.tail<3>().squaredNorm());
}

const kincal::StewartGeometry<double>& geometry() {
  static const kincal::StewartGeometry<double> g = kincal::make_stewart_seed001<double>();
  return g;
}
const StewartErrorModel& model() {
  static const StewartErrorModel m(geometry());
  return m;
}

std::vector<Pose<double>> cal_poses() {
  const auto t = kincal::identify::read_pose_table(std::string(KINCAL_SOURCE_DIR) + "/examples/seed001/grid_poses.csv");
  std::vector<Pose<double>> out;
  for (const auto& r : t.rows)
    if (r.role == kincal::identify::Role::Cal) out.push_back(Pose<double>::from_xyz_rpy(r.commanded));
  return out;
}

// Columns that vanish identically (structural zeros, here at rounding level
// ~1e-16 of the others) are set to exact zeros: unit-norm column scaling would
// otherwise blow rounding noise up into spurious rank.
Eigen::MatrixXd drop_rounding_columns(Eigen::MatrixXd H, std::vector<int>* zero = nullptr) {
  double big = 0;
  for (Eigen::Index c = 0; c < H.cols(); ++c) big = std::max(big, H.col(c).norm());
  for (Eigen::Index c = 0; c < H.cols(); ++c)
    if (H.col(c).norm() < 1e-10 * big) {
      H.col(c).setZero();
      if (zero != nullptr) zero->push_back(static_cast<int>(c));
    }
  return H;
}

Pose<double> actual_pose(const Eigen::VectorXd& errors, const Pose<double>& nominal) {
  Vec6<double> q;
  EXPECT_EQ(kincal::stewart_ik(geometry(), nominal, q), Status::Ok);
  Pose<double> out;
  const auto rep = model().actual_fk(errors, q, nominal, out);
  EXPECT_EQ(rep.status, Status::Ok);
  return out;
}

TEST(identifyStewartErrorModel, CountsAndNames) {
  const StewartErrorModel& m = model();
  EXPECT_EQ(m.size(), 222);
  ASSERT_EQ(m.parameters().size(), 222u);
  EXPECT_EQ(m.index_of("dxi_3_1"), 0);
  EXPECT_EQ(m.index_of("dxi_3_6"), 5);
  EXPECT_EQ(m.index_of("dx_0_1"), 6);
  EXPECT_EQ(m.index_of("dgamma_0_1"), 11);
  EXPECT_EQ(m.index_of("dx_1_1"), 12);
  EXPECT_EQ(m.index_of("dz_3_1"), -1);      // the P joint's Δz is its encoder offset
  EXPECT_EQ(m.index_of("dgamma_4_2"), -1);  // an R joint's Δγ is its own variable
  EXPECT_EQ(m.index_of("dbeta_6_6"), 221);
  EXPECT_EQ(m.index_of("dx_0_2"), 42);
}

TEST(identifyStewartErrorModel, ZeroErrorsReproduceCoreFk) {
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model().size());
  double worst = 0;
  int worst_iter = 0;
  for (const Pose<double>& target : cal_poses()) {
    Vec6<double> q;
    ASSERT_EQ(kincal::stewart_ik(geometry(), target, q), Status::Ok);
    Pose<double> core, ours;
    ASSERT_EQ(kincal::stewart_fk(geometry(), q, geometry().home, core).status, Status::Ok);
    const auto rep = model().actual_fk(zero, q, geometry().home, ours);
    ASSERT_EQ(rep.status, Status::Ok);
    worst = std::max(worst, scaled_norm(kincal::pose_error(ours, core)));
    worst_iter = std::max(worst_iter, rep.iterations);
  }
  std::printf("zero errors vs stewart_fk: worst %.3g mm (rad x 1000), outer iterations <= %d\n", worst, worst_iter);
  EXPECT_LT(worst, 1e-9);
}

TEST(identifyStewartErrorModel, EveryColumnMatchesCentralDifferences) {
  const StewartErrorModel& m = model();
  const std::vector<Pose<double>> poses = cal_poses();
  const double h = 1e-6;
  double worst = 0;
  for (std::size_t k : {std::size_t(0), std::size_t(13), std::size_t(26)}) {
    const Pose<double>& nominal = poses[k];
    Eigen::MatrixXd B;
    ASSERT_EQ(m.error_jacobian(nominal, B), Status::Ok);
    double bmax = 0;
    for (int c = 0; c < m.size(); ++c) bmax = std::max(bmax, scaled_norm(B.col(c)));
    for (int c = 0; c < m.size(); ++c) {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(m.size());
      e(c) = h;
      const Pose<double> plus = actual_pose(e, nominal);
      e(c) = -h;
      const Pose<double> minus = actual_pose(e, nominal);
      const Twist<double> fd = (kincal::pose_error(plus, nominal) - kincal::pose_error(minus, nominal)) / (2 * h);
      const double err = scaled_norm(fd - B.col(c)) / bmax;
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-6) << m.parameters()[static_cast<std::size_t>(c)].name << " at pose " << k;
    }
  }
  std::printf("B columns vs central differences: worst %.3g (relative to the largest column)\n", worst);
}

TEST(identifyStewartErrorModel, LinearModelMatchesNonlinearMachine) {
  const StewartErrorModel& m = model();
  const std::vector<Pose<double>> poses = cal_poses();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  double worst = 0;
  int tested = 0;
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd e(m.size());
    for (int c = 0; c < m.size(); ++c) e(c) = uni(rng) * (m.parameters()[static_cast<std::size_t>(c)].angular() ? 10e-6 : 10e-3);
    for (std::size_t k = 0; k < poses.size(); k += 2) {
      Eigen::MatrixXd B;
      ASSERT_EQ(m.error_jacobian(poses[k], B), Status::Ok);
      const Twist<double> lin = B * e;
      const Twist<double> nl = kincal::pose_error(actual_pose(e, poses[k]), poses[k]);
      const double rel = scaled_norm(lin - nl) / scaled_norm(nl);
      worst = std::max(worst, rel);
      ++tested;
    }
  }
  std::printf("linear vs nonlinear, 10 um / 10 urad errors, %d pose-error pairs: worst relative %.3g\n", tested, worst);
  EXPECT_GE(tested, 10);
  EXPECT_LT(worst, 0.01);
}

TEST(identifyStewartErrorModel, IdentifiabilityOnGridPoses) {
  const StewartErrorModel& m = model();
  const std::vector<Pose<double>> poses = cal_poses();
  ASSERT_EQ(poses.size(), 27u);
  const int n = static_cast<int>(poses.size());
  Eigen::MatrixXd H(6 * n, m.size());
  // Seed 001's 42-parameter model (ΔB_i, ΔP_i, Δl_i): the same pose twists
  // $ = J⁻¹·Δl with Δl_i = u_iᵀ(R·ΔP_i − ΔB_i) + Δl_i.
  Eigen::MatrixXd H42(6 * n, 42);
  for (int k = 0; k < n; ++k) {
    const Pose<double>& X = poses[static_cast<std::size_t>(k)];
    Eigen::MatrixXd B;
    ASSERT_EQ(m.error_jacobian(X, B), Status::Ok);
    H.middleRows(6 * k, 6) = B;
    const kincal::Mat6<double> J = kincal::stewart_jacobian(geometry(), X);
    const kincal::Mat6<double> Jinv = J.inverse();
    const Eigen::Matrix<double, 3, 6> legs = kincal::stewart_leg_vectors(geometry(), X);
    for (int i = 0; i < 6; ++i) {
      const kincal::Vec3<double> u = legs.col(i).normalized();
      for (int a = 0; a < 3; ++a) {
        H42.block(6 * k, 7 * i + a, 6, 1) = -Jinv.col(i) * u(a);
        H42.block(6 * k, 7 * i + 3 + a, 6, 1) = Jinv.col(i) * (u.transpose() * X.R.col(a));
      }
      H42.block(6 * k, 7 * i + 6, 6, 1) = Jinv.col(i);
    }
  }
  std::vector<int> zeros;
  H = drop_rounding_columns(H, &zeros);
  std::printf("grid H: %zu identically zero columns\n", zeros.size());
  const auto full = kincal::identify::rank_by_svd(H);
  const auto r42 = kincal::identify::rank_by_svd(H42);
  Eigen::MatrixXd both(6 * n, m.size() + 42);
  both << H, H42;
  const auto rboth = kincal::identify::rank_by_svd(both);
  std::printf("joint-level H %ldx%ld: rank %ld (rcond %.3g); seed 001 H: rank %ld; [H | H42]: rank %ld\n",
              static_cast<long>(H.rows()), static_cast<long>(H.cols()), static_cast<long>(full.rank), full.rcond,
              static_cast<long>(r42.rank), static_cast<long>(rboth.rank));
  // Per leg (its encoder and its 36 Δη columns).
  for (int i = 0; i < 6; ++i) {
    Eigen::MatrixXd Hi(6 * n, 37);
    Hi.col(0) = H.col(i);
    Hi.rightCols(36) = H.middleCols(m.chain(i).first_parameter, 36);
    const auto ri = kincal::identify::rank_by_svd(drop_rounding_columns(Hi));
    std::printf("  leg %d: rank %ld of 37; singular values near the cut:", i + 1, static_cast<long>(ri.rank));
    for (Eigen::Index s = std::max<Eigen::Index>(0, ri.rank - 2); s < std::min<Eigen::Index>(ri.singular_values.size(), ri.rank + 2); ++s)
      std::printf(" %.3g", ri.singular_values(s) / ri.singular_values(0));
    std::printf("\n");
  }
  std::printf("  singular values (relative) around 42:");
  for (Eigen::Index s = 38; s < std::min<Eigen::Index>(full.singular_values.size(), 56); ++s)
    std::printf(" %.2g", full.singular_values(s) / full.singular_values(0));
  std::printf("\n");
  EXPECT_EQ(r42.rank, 42);
  EXPECT_EQ(zeros.size(), 132u);
  EXPECT_EQ(full.rank, 54);
  EXPECT_EQ(rboth.rank, 66);  // 12 = the two P_i components ⊥ z_6,i per leg, outside the joint-level span
}

// With full-pose measurements J·$ = Δξ + G·Δη gives each leg's length error
// Δl_i separately, so the identifiable set is leg by leg: the rank of the
// n × 37 matrix of rows (e_i, G_i) over many poses. 300 random poses in the
// grid's box (±20 mm, z 190–225 mm, tilts ±5°) give the structural ranks.
TEST(identifyStewartErrorModel, StructuralRankPerLeg) {
  const StewartErrorModel& m = model();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const int n = 300;
  const double deg = 3.14159265358979323846 / 180.0;
  std::vector<Eigen::MatrixXd> L(6, Eigen::MatrixXd(n, 37)), L7(6, Eigen::MatrixXd(n, 7)), Lp(6, Eigen::MatrixXd(n, 3));
  for (int k = 0; k < n; ++k) {
    const Pose<double> X = Pose<double>::from_xyz_rpy(20 * uni(rng), 20 * uni(rng), 207.5 + 17.5 * uni(rng),
                                                      5 * deg * uni(rng), 5 * deg * uni(rng), 5 * deg * uni(rng));
    Eigen::MatrixXd B;
    ASSERT_EQ(m.error_jacobian(X, B), Status::Ok);
    const kincal::Mat6<double> J = kincal::stewart_jacobian(geometry(), X);
    const Eigen::MatrixXd dl = J * B;  // rows: Δl_i per unit parameter
    const Eigen::Matrix<double, 3, 6> legs = kincal::stewart_leg_vectors(geometry(), X);
    for (int i = 0; i < 6; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      L[si](k, 0) = dl(i, i);
      L[si].block(k, 1, 1, 36) = dl.block(i, m.chain(i).first_parameter, 1, 36);
      const kincal::Vec3<double> u = legs.col(i).normalized();
      L7[si].block(k, 0, 1, 3) = -u.transpose();
      L7[si].block(k, 3, 1, 3) = u.transpose() * X.R;
      L7[si](k, 6) = 1.0;
      // ΔP_i along the attachment frame's axes (z = the S joint's last axis z_6,i).
      Lp[si].row(k) = u.transpose() * X.R * m.attachment(i).R;
    }
  }
  long total = 0;
  for (int i = 0; i < 6; ++i) {
    const std::size_t si = static_cast<std::size_t>(i);
    std::vector<int> zc;
    L[si] = drop_rounding_columns(L[si], &zc);
    const auto r = kincal::identify::rank_by_svd(L[si]);
    const auto r7 = kincal::identify::rank_by_svd(L7[si]);
    Eigen::MatrixXd both(n, 44);
    both << L[si], L7[si];
    const auto rb = kincal::identify::rank_by_svd(both);
    std::printf("leg %d: joint-level rank %ld of 37, seed-001 rank %ld of 7, union %ld; s/s0 at cut:", i + 1,
                static_cast<long>(r.rank), static_cast<long>(r7.rank), static_cast<long>(rb.rank));
    for (Eigen::Index s = std::max<Eigen::Index>(0, r.rank - 2); s < std::min<Eigen::Index>(37, r.rank + 2); ++s)
      std::printf(" %.3g", r.singular_values(s) / r.singular_values(0));
    std::printf("\n");
    // Columns that contribute nothing at any pose.
    std::string zero;
    for (int c : zc)
      zero += " " + (c == 0 ? std::string("dxi") : m.parameters()[static_cast<std::size_t>(m.chain(i).first_parameter + c - 1)].name);
    std::printf("  %zu zero columns:%s\n", zc.size(), zero.c_str());
    // B_i and Δl_i lie in the joint-level span; of P_i only the component along z_6,i.
    Eigen::MatrixXd with(n, 41);
    with << L[si], L7[si].leftCols<3>(), L7[si].col(6);
    EXPECT_EQ(kincal::identify::rank_by_svd(with).rank, r.rank);
    for (int a = 0; a < 3; ++a) {
      Eigen::MatrixXd withp(n, 38);
      withp << L[si], Lp[si].col(a);
      EXPECT_EQ(kincal::identify::rank_by_svd(withp).rank, r.rank + (a == 2 ? 0 : 1)) << "leg " << i + 1 << " axis " << a;
    }
    // The table of docs/stewart-error-model.md: base-fixed translations ≡ ΔB_i, Δx_4 ≡ Δξ.
    auto col = [&](const std::string& name) {
      return L[si].col(m.index_of(name + "_" + std::to_string(i + 1)) - m.chain(i).first_parameter + 1);
    };
    Eigen::MatrixXd base(n, 10);
    base << L7[si].leftCols<3>(), col("dx_0"), col("dy_0"), col("dz_0"), col("dx_1"), col("dy_1"), col("dz_1"), col("dx_2");
    EXPECT_EQ(kincal::identify::rank_by_svd(base).rank, 3);
    Eigen::MatrixXd along(n, 2);
    along << L[si].col(0), col("dx_4");
    EXPECT_EQ(kincal::identify::rank_by_svd(along).rank, 1);
    EXPECT_EQ(r.rank, 9);
    EXPECT_EQ(zc.size(), 22u);
    total += static_cast<long>(r.rank);
    EXPECT_EQ(r7.rank, 7);
  }
  std::printf("structural rank (sum over legs): %ld of 222\n", total);
  EXPECT_EQ(total, 54);
}

}  // namespace
