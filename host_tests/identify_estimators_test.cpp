// Linear estimators (identify/estimators.hpp): OLS, ridge, PCR, Liu (seed 000
// Eqs. (11)–(14)), weighting, outliers, and the factor-once Monte Carlo path.
// References are independent where possible (normal equations on
// well-conditioned designs, augmented least squares, brute-force grids);
// Monte Carlo checks are seeded.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "../identify/src/estimate/least_squares_step.hpp"
#include "../identify/src/estimate/scaled_design.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/input_error.hpp"
#include "random_design.hpp"

using namespace kincal::identify;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

using kincal::test::gaussian;  // random_design.hpp

VectorXd gaussian(Index rows, std::mt19937_64& rng) { return gaussian(rows, 1, rng).col(0); }

MatrixXd orthonormal(Index rows, Index cols, std::mt19937_64& rng) {
  Eigen::HouseholderQR<MatrixXd> qr(gaussian(rows, cols, rng));
  return qr.householderQ() * MatrixXd::Identity(rows, cols);
}

// n × m design with singular values log-spaced from s_max down to s_max / cond.
MatrixXd design_with_spectrum(Index n, Index m, double s_max, double cond, std::mt19937_64& rng) {
  VectorXd s(m);
  for (Index j = 0; j < m; ++j) {
    s(j) = s_max * std::pow(cond, -static_cast<double>(j) / static_cast<double>(m - 1));
  }
  return orthonormal(n, m, rng) * s.asDiagonal() * orthonormal(m, m, rng).transpose();
}

// Reference on well-conditioned designs only: the normal equations.
VectorXd normal_equations(const MatrixXd& H, const VectorXd& y) {
  return (H.transpose() * H).ldlt().solve(H.transpose() * y);
}

double total_variance(const std::vector<VectorXd>& xs) {
  const Index m = xs.front().size();
  VectorXd mean = VectorXd::Zero(m);
  for (const auto& x : xs) mean += x;
  mean /= static_cast<double>(xs.size());
  double v = 0;
  for (const auto& x : xs) v += (x - mean).squaredNorm();
  return v / static_cast<double>(xs.size() - 1);
}

}  // namespace

TEST(identifyEstimators, OlsRecoversTruthOnNoiselessData) {
  std::mt19937_64 rng(1);
  LinearProblem p;
  p.H = design_with_spectrum(120, 8, 50.0, 1e3, rng);
  const VectorXd x = gaussian(8, rng);
  p.y = p.H * x;
  const Estimate e = ols(p);
  EXPECT_EQ(e.method, "ols");
  EXPECT_EQ(e.rank, 8);
  EXPECT_LT((e.x - x).norm(), 1e-11 * x.norm() * 1e3);
  EXPECT_LT(e.rss, 1e-20);
  EXPECT_LT(e.residual.norm(), 1e-10);
}

TEST(identifyEstimators, OlsMatchesNormalEquationsOnWellConditionedDesign) {
  std::mt19937_64 rng(2);
  LinearProblem p;
  p.H = gaussian(200, 7, rng);
  p.y = p.H * gaussian(7, rng) + 0.1 * gaussian(200, rng);
  const Estimate e = ols(p);
  const VectorXd ref = normal_equations(p.H, p.y);
  EXPECT_LT((e.x - ref).norm(), 1e-12 * ref.norm());
  const VectorXd r = p.y - p.H * ref;
  EXPECT_NEAR(e.rss, r.squaredNorm(), 1e-10 * r.squaredNorm());
  EXPECT_NEAR(e.sigma2, r.squaredNorm() / 200.0, 1e-12);            // Eq. (13) σ̂² = RSS/n
  EXPECT_NEAR(e.sigma2_unbiased, r.squaredNorm() / 193.0, 1e-12);   // RSS/(n − m)
  const VectorXd se_ref = (e.sigma2_unbiased * (p.H.transpose() * p.H).inverse().diagonal()).cwiseSqrt();
  EXPECT_LT((e.standard_error - se_ref).cwiseAbs().maxCoeff(), 1e-10 * se_ref.maxCoeff());
  EXPECT_LT((e.residual - r).norm(), 1e-10);
}

TEST(identifyEstimators, RankDeficientDesignNamesTheColumns) {
  std::mt19937_64 rng(3);
  LinearProblem p;
  p.H = gaussian(60, 6, rng);
  p.H.col(4) = p.H.col(1) - 2.0 * p.H.col(3);  // dZB1 = dXB1 − 2·dl1
  p.names = {"dAlpha", "dXB1", "dYP2", "dl1", "dZB1", "dGamma"};
  p.y = gaussian(60, rng);
  try {
    ols(p);
    FAIL() << "rank-deficient design accepted";
  } catch (const InputError& err) {
    const std::string what = err.what();
    EXPECT_NE(what.find("rank 5 of 6"), std::string::npos) << what;
    for (const char* bad : {"dXB1", "dl1", "dZB1"}) EXPECT_NE(what.find(bad), std::string::npos) << what;
    for (const char* good : {"dAlpha", "dYP2", "dGamma"}) EXPECT_EQ(what.find(good), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);  // one line
  }
  // Liu needs the OLS estimate, so it refuses too; PCR and ridge with k > 0 do not.
  EXPECT_THROW(liu(p), InputError);
  EXPECT_THROW(ridge(p), InputError);  // default k needs OLS
  EXPECT_NO_THROW(ridge(p, 0.1));
  const Estimate pcr = principal_components(p, PcrOptions{5, 0, 0});
  EXPECT_EQ(pcr.rank, 5);
  EXPECT_THROW(principal_components(p, PcrOptions{6, 0, 0}), InputError);
}

TEST(identifyEstimators, BadInputIsAnInputError) {
  std::mt19937_64 rng(4);
  LinearProblem p;
  p.H = gaussian(20, 3, rng);
  p.y = gaussian(20, rng);
  p.names = {"a", "b", "c"};
  LinearProblem q = p;
  q.H(7, 2) = std::nan("");
  try {
    ols(q);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("row 7, column 'c'"), std::string::npos) << e.what();
  }
  q = p;
  q.y(3) = INFINITY;
  EXPECT_THROW(ols(q), InputError);
  q = p;
  q.weights = VectorXd::Ones(20);
  (*q.weights)(5) = 0.0;
  EXPECT_THROW(ols(q), InputError);
  q = p;
  q.H.conservativeResize(3, 3);
  q.y.conservativeResize(3);
  EXPECT_THROW(ols(q), InputError);  // n ≤ m
  q = p;
  q.y.conservativeResize(19);
  EXPECT_THROW(ols(q), InputError);
  EXPECT_THROW(ridge(p, -1.0), InputError);
}

TEST(identifyEstimators, RidgeZeroIsOlsAndMatchesAugmentedLeastSquares) {
  std::mt19937_64 rng(5);
  LinearProblem p;
  p.H = design_with_spectrum(80, 6, 10.0, 1e4, rng);
  p.y = p.H * gaussian(6, rng) + 0.01 * gaussian(80, rng);
  const Estimate o = ols(p);
  const Estimate r0 = ridge(p, 0.0);
  EXPECT_LT((r0.x - o.x).norm(), 1e-10 * o.x.norm());
  // (HᵀH + kI)⁻¹Hᵀy = argmin ‖[H; √k I] x − [y; 0]‖ (a QR reference, no normal equations)
  const double k = 0.37;
  MatrixXd A(86, 6);
  A << p.H, std::sqrt(k) * MatrixXd::Identity(6, 6);
  VectorXd b = VectorXd::Zero(86);
  b.head(80) = p.y;
  const VectorXd ref = A.colPivHouseholderQr().solve(b);
  const Estimate rk = ridge(p, k);
  EXPECT_LT((rk.x - ref).norm(), 1e-10 * ref.norm());
  EXPECT_DOUBLE_EQ(rk.ridge_k, k);
  // Hoerl–Kennard–Baldwin default
  const Estimate rd = ridge(p);
  EXPECT_TRUE(rd.ridge_k_default);
  EXPECT_NEAR(rd.ridge_k, 6.0 * o.sigma2_unbiased / o.x.squaredNorm(), 1e-12 * rd.ridge_k);
}

TEST(identifyEstimators, PcrWithAllComponentsIsOlsAndTruncationProjects) {
  std::mt19937_64 rng(6);
  LinearProblem p;
  p.H = design_with_spectrum(70, 5, 3.0, 1e5, rng);
  p.y = p.H * gaussian(5, rng) + 1e-3 * gaussian(70, rng);
  const Estimate o = ols(p);
  const Estimate all = principal_components(p, PcrOptions{5, 0, 0});
  EXPECT_LT((all.x - o.x).norm(), 1e-10 * o.x.norm());
  // 3 components: x = V₃ S₃⁻¹ U₃ᵀ y, reference by JacobiSVD
  Eigen::JacobiSVD<MatrixXd> svd(p.H, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const VectorXd ref = svd.matrixV().leftCols(3) *
                       (svd.matrixU().leftCols(3).transpose() * p.y).cwiseQuotient(svd.singularValues().head(3));
  const Estimate three = principal_components(p, PcrOptions{3, 0, 0});
  EXPECT_EQ(three.pcr_components, 3);
  EXPECT_LT((three.x - ref).norm(), 1e-10 * ref.norm());
  // default: condition-index cut at 1e3 keeps s_j ≥ s_max/1e3 (cond 1e5 over 5 values: 1, 0.056, 3.2e-3, 1.8e-4, 1e-5)
  EXPECT_EQ(principal_components(p).pcr_components, 3);
  EXPECT_EQ(principal_components(p, PcrOptions{0, 0.5, 0}).pcr_components, 1);
}

TEST(identifyEstimators, LiuWithDOneIsOlsAndFixedDMatchesEq11) {
  std::mt19937_64 rng(7);
  LinearProblem p;
  p.H = gaussian(90, 6, rng) * 0.3;  // well-conditioned, λ_j of order 1 so the Liu shrinkage is visible
  p.y = p.H * gaussian(6, rng) + 0.05 * gaussian(90, rng);
  const Estimate o = ols(p);
  const Estimate l1 = liu(p, LiuOptions{LiuRule::Fixed, 1.0});
  EXPECT_LT((l1.x - o.x).norm(), 1e-12 * o.x.norm());
  for (double d : {0.0, 0.3, 0.8}) {
    // Eq. (11) literally: (HᵀH + I)⁻¹(HᵀΔp + d·Δχ̂)
    const MatrixXd N = p.H.transpose() * p.H + MatrixXd::Identity(6, 6);
    const VectorXd ref = N.ldlt().solve(p.H.transpose() * p.y + d * o.x);
    const Estimate ld = liu(p, LiuOptions{LiuRule::Fixed, d});
    EXPECT_LT((ld.x - ref).norm(), 1e-11 * ref.norm()) << "d = " << d;
    EXPECT_DOUBLE_EQ(ld.liu_d, d);
    // standard error of the linear map x_L = (N⁻¹(Hᵀ + d·(HᵀH)⁻¹Hᵀ)) y at fixed d
    const MatrixXd M = N.inverse() * (p.H.transpose() + d * (p.H.transpose() * p.H).inverse() * p.H.transpose());
    const VectorXd se = (o.sigma2_unbiased * (M * M.transpose()).diagonal()).cwiseSqrt();
    EXPECT_LT((ld.standard_error - se).cwiseAbs().maxCoeff(), 1e-9 * se.maxCoeff());
  }
}

TEST(identifyEstimators, LiuEq14IsTheMinimiserOfTheEq13Mse) {
  std::mt19937_64 rng(8);
  LinearProblem p;
  p.H = design_with_spectrum(150, 8, 5.0, 1e3, rng);  // λ from 25 down to 2.5e-5
  const VectorXd truth = gaussian(8, rng);
  p.y = p.H * truth + 0.02 * gaussian(150, rng);
  const Estimate o = ols(p);
  // Eq. (12) independently: eigenpairs of HᵀH (fine at this conditioning for a reference)
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(p.H.transpose() * p.H);
  const VectorXd lambda = es.eigenvalues();
  const VectorXd alpha = es.eigenvectors().transpose() * o.x;
  const double sigma2 = o.sigma2;  // Eq. (13): RSS/n
  const double d14 = liu_d_eq14(lambda, alpha, sigma2);
  ASSERT_GT(d14, 0.0);
  ASSERT_LT(d14, 1.0);  // the interesting case: no clamping
  // numeric minimum over a wide bracket, and a brute-force grid
  EXPECT_NEAR(liu_d_minimise_mse(lambda, alpha, sigma2, -5.0, 5.0), d14, 1e-7);
  double best = 0, best_mse = INFINITY;
  for (int i = 0; i <= 40000; ++i) {
    const double d = -2.0 + 4.0 * i / 40000.0;
    const double v = liu_mse_eq13(lambda, alpha, sigma2, d);
    if (v < best_mse) best_mse = v, best = d;
  }
  EXPECT_NEAR(best, d14, 1.5e-4);
  // The estimator reports the same d by both rules.
  const Estimate l = liu(p);
  EXPECT_NEAR(l.liu_d, d14, 1e-9 * (1 + d14));
  EXPECT_FALSE(l.liu_d_clamped);
  const Estimate ln = liu(p, LiuOptions{LiuRule::MinimiseMse, 0});
  EXPECT_NEAR(ln.liu_d, d14, 1e-7);
  const LiuParameter lp = liu_optimal_d(p);
  EXPECT_NEAR(lp.d, d14, 1e-9 * (1 + d14));
}

TEST(identifyEstimators, LiuDIsClampedAndReported) {
  // Eq. (14) is < 1 whenever σ̂² > 0 (each numerator term is below its
  // denominator term); it drops below 0 when the estimate is all noise:
  // x = 0, large λ_j, so α̂_j² ≈ σ²/λ_j < σ².
  std::mt19937_64 rng(9);
  LinearProblem p;
  p.H = 10.0 * gaussian(50, 4, rng);
  p.y = gaussian(50, rng);
  const Estimate l = liu(p);
  EXPECT_LT(l.liu_d_unclamped, 0.0);
  EXPECT_TRUE(l.liu_d_clamped);
  EXPECT_DOUBLE_EQ(l.liu_d, 0.0);
  const Estimate ln = liu(p, LiuOptions{LiuRule::MinimiseMse, 0});
  EXPECT_NEAR(ln.liu_d, 0.0, 1e-8);
  EXPECT_TRUE(ln.liu_d_clamped);
  // noiseless data: d → 1 (OLS) from below
  p.y = p.H * VectorXd::Constant(4, 3.0);
  const Estimate l1 = liu(p);
  EXPECT_NEAR(l1.liu_d, 1.0, 1e-9);
  EXPECT_FALSE(l1.liu_d_clamped);
}

TEST(identifyEstimators, MonteCarloLiuReducesVarianceAndOlsIsUnbiased) {
  std::mt19937_64 rng(10);
  LinearProblem p;
  const Index n = 120, m = 8;
  p.H = design_with_spectrum(n, m, 10.0, 3e3, rng);
  const VectorXd truth = gaussian(m, rng);
  const double sigma = 0.02;
  const PreparedDesign design(p);
  FitWorkspace ws;
  VectorXd x, xl;
  const int runs = 2000;
  std::vector<VectorXd> xo, xliu;
  VectorXd se_sum = VectorXd::Zero(m);
  const VectorXd ones = VectorXd::Ones(m);
  std::normal_distribution<double> noise(0.0, sigma);
  VectorXd y(n);
  for (int run = 0; run < runs; ++run) {
    for (Index i = 0; i < n; ++i) y(i) = noise(rng);
    y += p.H * truth;
    const FitInfo fo = design.ols(y, x, ws);
    xo.push_back(x);
    se_sum += design.standard_errors(ones, fo.sigma2_unbiased);
    design.liu(y, xl, ws);
    xliu.push_back(xl);
  }
  // seed 000 Eqs. (17)–(18)
  const double eta = 1.0 - std::sqrt(total_variance(xliu) / total_variance(xo));
  std::printf("Monte Carlo (%d runs, cond 3e3): eta = %.1f %%\n", runs, 100 * eta);
  EXPECT_GT(eta, 0.0);
  VectorXd mean = VectorXd::Zero(m), var = VectorXd::Zero(m);
  for (const auto& v : xo) mean += v;
  mean /= runs;
  for (const auto& v : xo) var += (v - mean).cwiseAbs2();
  var /= runs - 1;
  const VectorXd se_true = design.standard_errors(ones, sigma * sigma);
  const VectorXd se_reported = se_sum / runs;
  for (Index j = 0; j < m; ++j) {
    // unbiased: mean within 4 standard errors of the mean
    EXPECT_LT(std::abs(mean(j) - truth(j)), 4.0 * se_true(j) / std::sqrt(runs)) << j;
    // standard errors (formula with the true σ, and the reported ones) vs the MC spread
    EXPECT_NEAR(std::sqrt(var(j)) / se_true(j), 1.0, 0.10) << j;
    EXPECT_NEAR(std::sqrt(var(j)) / se_reported(j), 1.0, 0.10) << j;
  }
}

TEST(identifyEstimators, WeightingReducesVarianceUnderHeteroscedasticNoise) {
  std::mt19937_64 rng(11);
  const Index n = 90, m = 5;
  LinearProblem plain;
  plain.H = gaussian(n, m, rng);
  VectorXd sigma(n);
  for (Index i = 0; i < n; ++i) sigma(i) = (i % 3 == 0) ? 0.01 : 0.2;  // a precise and an imprecise sensor
  LinearProblem weighted = plain;
  weighted.weights = sigma.cwiseAbs2().cwiseInverse();
  const PreparedDesign dp(plain), dw(weighted);
  FitWorkspace ws;
  VectorXd x;
  const VectorXd truth = gaussian(m, rng);
  std::vector<VectorXd> xp, xw;
  std::normal_distribution<double> g(0.0, 1.0);
  VectorXd y(n);
  for (int run = 0; run < 1000; ++run) {
    for (Index i = 0; i < n; ++i) y(i) = sigma(i) * g(rng);
    y += plain.H * truth;
    dp.ols(y, x, ws);
    xp.push_back(x);
    dw.ols(y, x, ws);
    xw.push_back(x);
  }
  const double vp = total_variance(xp), vw = total_variance(xw);
  std::printf("heteroscedastic: total variance unweighted %.3g, weighted %.3g\n", vp, vw);
  EXPECT_LT(vw, 0.5 * vp);
  // GLS reference on one draw: (HᵀWH)⁻¹HᵀWy
  weighted.y = y;
  const MatrixXd W = weighted.weights->asDiagonal();
  const VectorXd ref = (plain.H.transpose() * W * plain.H).ldlt().solve(plain.H.transpose() * W * y);
  EXPECT_LT((ols(weighted).x - ref).norm(), 1e-10 * ref.norm());
}

TEST(identifyEstimators, BlockCovarianceWhiteningIsGeneralisedLeastSquares) {
  std::mt19937_64 rng(12);
  const Index nodes = 30, m = 4;
  LinearProblem p;
  p.H = gaussian(3 * nodes, m, rng);
  p.y = gaussian(3 * nodes, rng);
  MatrixXd sigma_full = MatrixXd::Zero(3 * nodes, 3 * nodes);
  std::vector<MatrixXd> covs;
  for (Index k = 0; k < nodes; ++k) {
    const MatrixXd A = gaussian(3, 3, rng);
    const MatrixXd C = A * A.transpose() + 0.1 * MatrixXd::Identity(3, 3);
    covs.push_back(C);
    sigma_full.block(3 * k, 3 * k, 3, 3) = C;
    for (int r = 0; r < 3; ++r) p.row_node.push_back(k);
  }
  const LinearProblem w = whitened_by_node(p, covs);
  const MatrixXd Si = sigma_full.inverse();
  const VectorXd ref = (p.H.transpose() * Si * p.H).ldlt().solve(p.H.transpose() * Si * p.y);
  EXPECT_LT((ols(w).x - ref).norm(), 1e-9 * ref.norm());
  // a non-SPD covariance is an input error naming the block
  covs[4](0, 0) = -1.0;
  EXPECT_THROW(whitened_by_node(p, covs), InputError);
}

TEST(identifyEstimators, FDistributionTail) {
  EXPECT_NEAR(f_distribution_upper_tail(4.9646, 1, 10), 0.05, 2e-5);  // t_{10,0.975}² = 2.2281²
  EXPECT_NEAR(f_distribution_upper_tail(3.0984, 3, 20), 0.05, 2e-5);
  EXPECT_NEAR(f_distribution_upper_tail(1.0, 9, 9), 0.5, 1e-12);
  EXPECT_NEAR(f_distribution_upper_tail(2.0, 2, 1e6), std::exp(-2.0), 1e-5);  // → χ²₂/2
}

namespace {

// 40 nodes × 3 rows (one gauge target), m = 6.
LinearProblem node_problem(std::mt19937_64& rng, const VectorXd& truth, double sigma, const MatrixXd& H) {
  LinearProblem p;
  p.H = H;
  std::normal_distribution<double> g(0.0, sigma);
  p.y = H * truth;
  for (Index i = 0; i < H.rows(); ++i) {
    p.y(i) += g(rng);
    p.row_node.push_back(100 + i / 3);  // node ids need not start at 0
  }
  return p;
}

}  // namespace

TEST(identifyEstimators, OutlierNodeWith50SigmaIsFlagged) {
  std::mt19937_64 rng(13);
  const MatrixXd H = gaussian(120, 6, rng);
  const VectorXd truth = gaussian(6, rng);
  LinearProblem p = node_problem(rng, truth, 0.01, H);
  p.y(3 * 17 + 1) += 50 * 0.01;  // node 117, its y row
  const OutlierReport rep = detect_outliers(p);
  ASSERT_EQ(rep.outlying_nodes.size(), 1u);
  EXPECT_EQ(rep.outlying_nodes[0], 117);
  EXPECT_EQ(rep.nodes.size(), 40u);
  EXPECT_EQ(rep.testable_nodes, 40);
  EXPECT_GT(std::abs(rep.deleted_t(3 * 17 + 1)), 20.0);
  EXPECT_EQ(rep.nodes[17].node, 117);
  EXPECT_EQ(rep.nodes[17].rows, 3);
  // exclusion is explicit: the returned problem lacks the node, and is clean
  const LinearProblem cleaned = without_nodes(p, rep.outlying_nodes);
  EXPECT_EQ(cleaned.H.rows(), 117);
  EXPECT_TRUE(detect_outliers(cleaned).outlying_nodes.empty());
  EXPECT_LT((ols(cleaned).x - truth).norm(), (ols(p).x - truth).norm());
  EXPECT_THROW(without_nodes(p, {5}), InputError);
}

TEST(identifyEstimators, OutlierFalseAlarmRateOnCleanData) {
  std::mt19937_64 rng(14);
  const MatrixXd H = gaussian(120, 6, rng);
  const VectorXd truth = gaussian(6, rng);
  int runs_with_flags = 0;
  const int runs = 400;
  for (int run = 0; run < runs; ++run) {
    const LinearProblem p = node_problem(rng, truth, 0.01, H);
    if (!detect_outliers(p).outlying_nodes.empty()) ++runs_with_flags;
  }
  std::printf("clean data: %d of %d runs had a flagged node (alpha 0.01 family-wise)\n", runs_with_flags, runs);
  EXPECT_LE(runs_with_flags, runs / 20);  // ≥ 95 % of runs clean
}

TEST(identifyEstimators, RidgeKByGcvIsTheMinimumOfAnIndependentGcv) {
  // GCV(k) = n·‖y − H x_k‖² / (n − tr A_k)², A_k = H (HᵀH + kI)⁻¹ Hᵀ, evaluated
  // here by the augmented least squares of the ridge test above and an
  // explicit trace (well-conditioned enough for the normal matrix).
  std::mt19937_64 rng(41);
  LinearProblem p;
  const Index n = 60, m = 8;
  p.H = design_with_spectrum(n, m, 10.0, 300.0, rng);
  p.y = p.H * (0.05 * gaussian(m, rng)) + 0.02 * gaussian(n, rng);
  auto gcv_reference = [&](double k) {
    MatrixXd A(n + m, m);
    A << p.H, std::sqrt(k) * MatrixXd::Identity(m, m);
    VectorXd b = VectorXd::Zero(n + m);
    b.head(n) = p.y;
    const VectorXd x = A.colPivHouseholderQr().solve(b);
    const MatrixXd G = p.H.transpose() * p.H + k * MatrixXd::Identity(m, m);
    const double trace = (p.H * G.ldlt().solve(p.H.transpose())).trace();
    return static_cast<double>(n) * (p.y - p.H * x).squaredNorm() / ((n - trace) * (n - trace));
  };
  double best_k = 0, best = gcv_reference(0);
  for (int i = 0; i <= 400; ++i) {
    const double k = std::pow(10.0, -8.0 + 12.0 * i / 400.0);
    EXPECT_NEAR(ridge_gcv(p, k), gcv_reference(k), 1e-9 * gcv_reference(k));
    if (gcv_reference(k) < best) best = gcv_reference(k), best_k = k;
  }
  const double k = ridge_parameter(p, RidgeOptions{RidgeRule::Gcv, 0});
  std::printf("GCV: k = %.4g (grid %.4g), GCV %.6g (grid %.6g)\n", k, best_k, ridge_gcv(p, k), best);
  EXPECT_GT(k, 0.0);
  EXPECT_LE(ridge_gcv(p, k), best * (1 + 1e-9));
  EXPECT_NEAR(std::log10(k), std::log10(best_k), 0.05);
  // The estimate at that k is the ridge estimate at that k.
  EstimatorOptions o;
  o.kind = EstimatorKind::Ridge;
  const Estimate e = estimate(p, o);
  EXPECT_EQ(e.ridge_k, k);
  EXPECT_EQ(e.ridge_rule, RidgeRule::Gcv);
  EXPECT_LT((e.x - ridge(p, k).x).norm(), 1e-12 * e.x.norm());
  // Without noise OLS cross-validates best: k = 0.
  LinearProblem exact = p;
  exact.y = p.H * gaussian(m, rng);
  EXPECT_EQ(ridge_parameter(exact, RidgeOptions{}), 0.0);
  // The other rules.
  EXPECT_EQ(ridge_parameter(p, RidgeOptions{RidgeRule::Fixed, 0.25}), 0.25);
  EXPECT_NEAR(ridge_parameter(p, RidgeOptions{RidgeRule::HoerlKennardBaldwin, 0}), ridge(p).ridge_k, 1e-15);
  EXPECT_THROW(ridge_parameter(p, RidgeOptions{RidgeRule::Fixed, -1}), InputError);
}

TEST(identifyEstimators, PcrComponentsByGcvFollowTheNoise) {
  // Truncated SVD with GCV(k) = n·RSS_k / (n − k)²: components whose signal
  // is below the noise are dropped; noise-free, all are kept.
  std::mt19937_64 rng(42);
  LinearProblem p;
  const Index n = 80, m = 10;
  p.H = design_with_spectrum(n, m, 10.0, 1e4, rng);
  const VectorXd x = gaussian(m, rng);
  p.y = p.H * x;
  EstimatorOptions o;
  o.kind = EstimatorKind::Pcr;  // EstimatorOptions' default PCR rule is GCV
  EXPECT_TRUE(o.pcr.by_gcv);
  EXPECT_EQ(estimate(p, o).pcr_components, m);
  p.y += 0.01 * gaussian(n, rng);
  const Estimate e = estimate(p, o);
  // Brute force over k of the same criterion with RSS from explicit truncated fits.
  Index best_k = 0;
  double best = INFINITY;
  for (Index k = 1; k <= m; ++k) {
    const Estimate t = principal_components(p, PcrOptions{k, 0, 0});
    const double dof = static_cast<double>(n - k);
    const double g = static_cast<double>(n) * t.residual.squaredNorm() / (dof * dof);
    if (g < best) best = g, best_k = k;
  }
  std::printf("PCR by GCV: %lld of %lld components\n", static_cast<long long>(e.pcr_components),
              static_cast<long long>(m));
  EXPECT_EQ(e.pcr_components, best_k);
  EXPECT_LT(e.pcr_components, m);
  EXPECT_LT((e.x - principal_components(p, PcrOptions{best_k, 0, 0}).x).norm(), 1e-12 * e.x.norm());
  // An explicit count and the one-shot default (condition index) are unchanged.
  o.pcr = PcrOptions{4, 0, 0};
  EXPECT_EQ(estimate(p, o).pcr_components, 4);
  EXPECT_FALSE(PcrOptions{}.by_gcv);
}

TEST(identifyEstimators, OneEntryPointAndSettings) {
  std::mt19937_64 rng(43);
  LinearProblem p;
  p.H = design_with_spectrum(50, 5, 2.0, 100.0, rng);
  p.y = p.H * gaussian(5, rng) + 0.05 * gaussian(50, rng);
  EstimatorOptions o;
  EXPECT_EQ(estimate(p, o).x, ols(p).x);
  o.kind = EstimatorKind::Liu;
  EXPECT_EQ(estimate(p, o).x, liu(p).x);
  o.kind = EstimatorKind::Ridge;
  o.ridge = {RidgeRule::Fixed, 0.3};
  EXPECT_EQ(estimate(p, o).x, ridge(p, 0.3).x);
  // One factorisation, several estimators.
  const PreparedDesign design(p);
  EXPECT_EQ(estimate(design, p, o).x, ridge(p, 0.3).x);
  for (EstimatorKind k : {EstimatorKind::Ols, EstimatorKind::Ridge, EstimatorKind::Pcr, EstimatorKind::Liu})
    EXPECT_EQ(parse_estimator(to_string(k)), k);
  EXPECT_THROW(parse_estimator("lasso"), InputError);
  // MODEL.json settings
  o.ridge = {RidgeRule::Gcv, 0};
  auto s = estimator_settings(estimate(p, o), o);
  EXPECT_EQ(s.count("ridge_k"), 1u);
  EXPECT_EQ(s.at("ridge_k_gcv"), 1.0);
  o.kind = EstimatorKind::Pcr;
  s = estimator_settings(estimate(p, o), o);
  EXPECT_EQ(s.at("pcr_components_gcv"), 1.0);
  EXPECT_GE(s.at("pcr_components"), 1.0);
  o.pcr = PcrOptions{};
  s = estimator_settings(estimate(p, o), o);
  EXPECT_EQ(s.at("pcr_max_condition_index"), 1e3);
  o.kind = EstimatorKind::Liu;
  s = estimator_settings(estimate(p, o), o);
  EXPECT_EQ(s.count("liu_d"), 1u);
  EXPECT_EQ(s.count("liu_d_unclamped"), 1u);
  o.kind = EstimatorKind::Ols;
  EXPECT_TRUE(estimator_settings(estimate(p, o), o).empty());
}

// GCV of the ridge that shrinks only some columns (the hybrid's joint fit:
// base parameters shrunk, effect parameters free), in closed form, against
// the ridge solved afresh at each k by an augmented QR [X; √k·(I 0)] with
// the trace of its hat matrix from the explicit inverse — another route to
// the same numbers. Designs drawn here, not from the tool: ill-conditioned
// penalised block (condition 1e6), free columns on scales 1e-3…1e3, and a
// penalised column inside the free columns' span; also no free column.
TEST(identifyEstimators, PartialRidgeGcvMatchesTheAugmentedSolve) {
  std::mt19937_64 rng(23);
  auto reference = [](const MatrixXd& X, const VectorXd& z, Index p, double k) {
    const Index n = X.rows(), m = X.cols();
    MatrixXd A = MatrixXd::Zero(n + p, m);
    A.topRows(n) = X;
    A.bottomLeftCorner(p, p) = std::sqrt(k) * MatrixXd::Identity(p, p);
    VectorXd w = VectorXd::Zero(n + p);
    w.head(n) = z;
    const VectorXd b = A.colPivHouseholderQr().solve(w);
    const double rss = (z - X * b).squaredNorm();
    MatrixXd K = X.transpose() * X;
    K.topLeftCorner(p, p) += k * MatrixXd::Identity(p, p);
    const double df = (X * K.inverse() * X.transpose()).trace();
    return double(n) * rss / ((double(n) - df) * (double(n) - df));
  };
  for (int trial = 0; trial < 3; ++trial) {
    const Index n = 120, p = 10, q = trial == 2 ? 0 : 4;
    MatrixXd X(n, p + q);
    X.leftCols(p) = design_with_spectrum(n, p, 50.0, trial == 0 ? 1e3 : 1e6, rng);
    for (Index j = 0; j < q; ++j) X.col(p + j) = std::pow(10.0, 3.0 - 2.0 * double(j)) * gaussian(n, rng);
    if (trial == 1) X.col(3) = 0.5 * X.col(p) / X.col(p).norm() + 0.01 * X.col(3);  // nearly inside E's span
    const VectorXd z = X * gaussian(p + q, rng) + 0.05 * gaussian(n, rng);
    const PartialRidgeGcv gcv(X, z, p);
    for (const double k : {1e-6, 1e-3, 0.05, 1.0, 30.0, 1e3}) {
      const double want = reference(X, z, p, k);
      EXPECT_NEAR(gcv(k), want, 1e-7 * want) << "trial " << trial << ", k = " << k;
    }
  }
}

// Columns in units 1e-2 … 1e1 apart (mm against rad-like parameters): what
// the column scaling of the host's least squares is for.
namespace {
MatrixXd columns_in_units_apart(MatrixXd X) {
  for (Index j = 0; j < X.cols(); ++j) X.col(j) *= std::pow(10.0, double(j % 4) - 2.0);
  return X;
}
}  // namespace

// The diagnosis's "confounded" share of a candidate column, read off the QR
// its fit appends columns to (AppendedColumnsLeastSquares::share_in_span),
// against the projection on the left singular vectors of an independent SVD
// of the whole design (BDCSVD of X itself, not of a triangular factor): full
// rank with columns in units 1e-2 … 1e1 apart, and
// rank-deficient with one column an exact combination of two others, where
// Q spans a direction X does not.
TEST(identifyEstimators, ShareInSpanMatchesTheProjectionOnAnIndependentSvd) {
  std::mt19937_64 rng(41);
  for (int trial = 0; trial < 2; ++trial) {
    const Index n = 90, p = 12;
    MatrixXd X = columns_in_units_apart(design_with_spectrum(n, p, 1.0, 1e4, rng));
    if (trial == 1) X.col(5) = 2.0 * X.col(1) - 0.3 * X.col(8);
    const Eigen::BDCSVD<MatrixXd> svd(X, Eigen::ComputeThinU);
    Index rank = 0;
    for (Index i = 0; i < p; ++i) rank += svd.singularValues()(i) > 1e-9 * svd.singularValues()(0);
    ASSERT_EQ(rank, trial == 0 ? p : p - 1);
    const MatrixXd U = svd.matrixU().leftCols(rank);
    const kincal::identify::detail::AppendedColumnsLeastSquares ls(X);
    const std::vector<double> inside = {0.0, 0.3, 0.9, 0.999, 1.0};
    MatrixXd G(n, Index(inside.size()) + 1);
    for (std::size_t c = 0; c < inside.size(); ++c) {
      const VectorXd a = X * gaussian(p, rng), b = gaussian(n, rng);
      G.col(Index(c)) = inside[c] * a / a.norm() + (1.0 - inside[c]) * b / b.norm();
    }
    G.col(G.cols() - 1).setZero();
    // As the diagnosis reads them (from its candidate's solve) and alone.
    Index rank_with_g = 0;
    VectorXd from_solve;
    ls.solve(G.leftCols(G.cols() - 1), gaussian(n, rng), rank_with_g, &from_solve);
    const VectorXd alone = ls.shares_in_span(G);
    for (Index c = 0; c + 1 < G.cols(); ++c) {
      const double want = (U.transpose() * G.col(c)).squaredNorm() / G.col(c).squaredNorm();
      EXPECT_NEAR(alone(c), want, 1e-10) << "trial " << trial << ", inside " << inside[std::size_t(c)];
      EXPECT_NEAR(from_solve(c), want, 1e-10) << "trial " << trial << ", inside " << inside[std::size_t(c)];
    }
    EXPECT_EQ(alone(G.cols() - 1), 0.0);
  }
}

// The held-out rows' leverage the diagnosis's verdict allows for
// (ScaledLeastSquares::mean_leverage) against the variance of x_tᵀ·δ̂ taken
// by Monte Carlo: 4 000 noise draws through an independent solve (BDCSVD of
// the column-scaled design); and on the fitted rows themselves rank / n
// exactly.
// Full rank with columns in units apart, and rank-deficient (the
// minimum-norm solve: the unestimated direction adds no variance).
TEST(identifyEstimators, MeanLeverageIsThePredictionVarianceOfHeldOutRows) {
  std::mt19937_64 rng(47);
  for (int trial = 0; trial < 2; ++trial) {
    const Index n = 60, p = 8, nt = 25;
    MatrixXd X = columns_in_units_apart(design_with_spectrum(n, p, 1.0, 1e3, rng));
    if (trial == 1) X.col(3) = X.col(0) - 0.5 * X.col(6);
    // Held-out rows partly outside the cal rows' cloud (extrapolation).
    const MatrixXd Xt = 1.8 * columns_in_units_apart(design_with_spectrum(nt, p, 1.0, 1e3, rng));
    const kincal::identify::detail::ScaledLeastSquares ls(X);
    EXPECT_NEAR(ls.mean_leverage(X), double(ls.rank()) / double(n), 1e-10);
    // The minimum norm is the column-scaled one (the estimate's definition;
    // with the dependency, the held-out rows see the choice).
    VectorXd d(p);
    for (Index j = 0; j < p; ++j) d(j) = X.col(j).norm();
    Eigen::BDCSVD<MatrixXd> svd(X * d.cwiseInverse().asDiagonal(), Eigen::ComputeThinU | Eigen::ComputeThinV);
    svd.setThreshold(1e-9);
    const MatrixXd St = Xt * d.cwiseInverse().asDiagonal();
    double sum = 0;
    const int draws = 4000;
    for (int k = 0; k < draws; ++k) sum += (St * svd.solve(gaussian(n, rng))).squaredNorm();
    const double monte_carlo = sum / draws / double(nt);
    EXPECT_NEAR(ls.mean_leverage(Xt), monte_carlo, 0.05 * monte_carlo) << "trial " << trial;
    // And exactly: the rows through the SVD's pseudo-inverse (mean_leverage
    // reads it off the decomposition's triangular factor instead).
    const MatrixXd pinv = svd.matrixV().leftCols(svd.rank()) *
                          svd.singularValues().head(svd.rank()).cwiseInverse().asDiagonal() *
                          svd.matrixU().leftCols(svd.rank()).transpose();
    const double exact = (St * pinv).squaredNorm() / double(nt);
    EXPECT_NEAR(ls.mean_leverage(Xt), exact, 1e-9 * exact) << "trial " << trial;
    // The held-out residual's χ² in the metric of its covariance (Chow's
    // predictive test), against the dense (I + S_t·S⁺·S⁺ᵀ·S_tᵀ)⁻¹ by LU.
    const VectorXd rt = gaussian(nt, rng);
    const MatrixXd cov = MatrixXd::Identity(nt, nt) + (St * pinv) * (St * pinv).transpose();
    const double chi2 = rt.dot(cov.partialPivLu().solve(rt));
    EXPECT_NEAR(ls.prediction_chi2(Xt, rt), chi2, 1e-9 * chi2) << "trial " << trial;
    EXPECT_LT(ls.prediction_chi2(Xt, rt), rt.squaredNorm());  // the prediction's spread discounts it
    EXPECT_GT(ls.mean_leverage(Xt), double(ls.rank()) / double(n));  // extrapolated rows weigh more
  }
}

// ScaledDesign (the one rank rule and the statistics of the joint effect fit
// and the target fit) against an independent computation: columns divided
// by their norms by hand, the normal matrix's inverse for the variances at
// full rank, JacobiSVD for the condition number, and a null vector built
// by construction for the rank-deficient design; a zero column scaled by 1.
TEST(identifyEstimators, ScaledDesignAgreesWithAnIndependentFactorisation) {
  std::mt19937_64 rng(53);
  const Index n = 45, p = 7;
  const MatrixXd X = columns_in_units_apart(design_with_spectrum(n, p, 1.0, 1e3, rng));
  MatrixXd S = X;
  for (Index j = 0; j < p; ++j) S.col(j) /= X.col(j).norm();
  const kincal::identify::detail::ScaledDesign full(X);
  EXPECT_EQ(full.rank(), p);
  const Eigen::JacobiSVD<MatrixXd> check(S);
  const VectorXd sv = check.singularValues();
  EXPECT_NEAR(full.condition_number(), sv(0) / sv(p - 1), 1e-8 * sv(0) / sv(p - 1));
  const MatrixXd inverse_normal = (S.transpose() * S).inverse();
  for (Index j = 0; j < p; ++j) {
    EXPECT_NEAR(full.scaled_variance(j), inverse_normal(j, j), 1e-8 * inverse_normal(j, j)) << "column " << j;
    EXPECT_LT(full.outside_rank(j), 1e-20) << "column " << j;
    EXPECT_NEAR(full.scale()(j), X.col(j).norm(), 1e-12 * X.col(j).norm());
  }
  // Column 5 a combination of 1 and 3 (in their own units): the scaled null
  // vector z has z_5 = −1 and the combination's scaled coefficients.
  MatrixXd Y = X;
  Y.col(5) = 3.0 * X.col(1) - 0.25 * X.col(3);
  const kincal::identify::detail::ScaledDesign deficient(Y);
  EXPECT_EQ(deficient.rank(), p - 1);
  VectorXd z = VectorXd::Zero(p);
  const double d5 = Y.col(5).norm();
  z(1) = 3.0 * X.col(1).norm() / d5;
  z(3) = -0.25 * X.col(3).norm() / d5;
  z(5) = -1.0;
  z.normalize();
  for (Index j = 0; j < p; ++j)
    EXPECT_NEAR(deficient.outside_rank(j), z(j) * z(j), 1e-9) << "column " << j;
  // A zero column: scale 1, not determined, the rank one less.
  MatrixXd Z = X;
  Z.col(2).setZero();
  const kincal::identify::detail::ScaledDesign with_zero(Z);
  EXPECT_EQ(with_zero.scale()(2), 1.0);
  EXPECT_EQ(with_zero.rank(), p - 1);
  EXPECT_NEAR(with_zero.outside_rank(2), 1.0, 1e-12);
  EXPECT_TRUE(std::isinf(with_zero.condition_number()) || with_zero.condition_number() > 1e15);
}

// ScaledPivotedQr (every solve, span and independent-column choice that
// needs no SVD directions) against the same rule read off an SVD: on the
// columns in units far apart, the rank equals ScaledDesign's (full, one
// exact dependency, and a near one at 1e-12 of the column that only the
// rule — not rounding — calls dependent); the fit equals the projection
// onto the left singular vectors of the rank (an SVD, not a QR), also for
// the rank-deficient design, where multiplying out a pivoted QR's basic
// solution lost digits (the planner's confounding read 99.9 % for 99.5 %,
// shares above 1 clamped; #33); the solution of the full-rank design equals
// the unscaled normal equations'; the span's basis is orthonormal and the
// independent columns span it.
TEST(identifyEstimators, ScaledPivotedQrAgreesWithTheRuleReadOffAnSvd) {
  std::mt19937_64 rng(59);
  const Index n = 40, p = 6;
  const MatrixXd X = columns_in_units_apart(design_with_spectrum(n, p, 1.0, 1e4, rng));
  const MatrixXd y = gaussian(n, 2, rng);
  auto svd_fit = [&](const MatrixXd& A, Index rank) {
    MatrixXd S = A;
    for (Index j = 0; j < A.cols(); ++j) S.col(j) /= A.col(j).norm();
    const Eigen::JacobiSVD<MatrixXd> svd(S, Eigen::ComputeThinU);
    const MatrixXd U = svd.matrixU().leftCols(rank);
    return MatrixXd(U * (U.transpose() * y));
  };
  MatrixXd near = X;
  near.col(4) = 2.0 * X.col(0) - 0.5 * X.col(2);
  MatrixXd exact = near;
  near.col(4) += 1e-12 * near.col(4).norm() * gaussian(n, 1, rng).normalized();
  for (const auto& [name, A, rank] : {std::tuple<const char*, MatrixXd, Index>{"full", X, p},
                                      {"exact dependency", exact, p - 1},
                                      {"near dependency (1e-12)", near, p - 1}}) {
    const kincal::identify::detail::ScaledPivotedQr qr(A);
    EXPECT_EQ(qr.rank(), rank) << name;
    EXPECT_EQ(kincal::identify::detail::ScaledDesign(A).rank(), rank) << name;
    const MatrixXd reference = svd_fit(A, rank);
    EXPECT_LT((qr.fitted(y) - reference).norm(), 1e-10 * y.norm()) << name;
    const MatrixXd Q = qr.column_space();
    EXPECT_EQ(Q.cols(), rank) << name;
    EXPECT_LT((Q.transpose() * Q - MatrixXd::Identity(rank, rank)).norm(), 1e-13) << name;
    const std::vector<Index> independent = qr.independent_columns();
    ASSERT_EQ(Index(independent.size()), rank) << name;
    MatrixXd B(n, rank);
    for (Index k = 0; k < rank; ++k) B.col(k) = A.col(independent[std::size_t(k)]);
    EXPECT_LT((B - Q * (Q.transpose() * B)).norm(), 1e-10 * B.norm()) << name;
  }
  const VectorXd coefficients = kincal::identify::detail::ScaledPivotedQr(X).solve(y.col(0));
  const VectorXd normal = (X.transpose() * X).ldlt().solve(X.transpose() * y.col(0));
  for (Index j = 0; j < p; ++j)
    EXPECT_NEAR(coefficients(j), normal(j), 1e-6 * std::abs(normal(j)) + 1e-12 / X.col(j).norm()) << "column " << j;
}

// The damped descent's steps (DescentStep: corrected semi-normal equations)
// against an independent solve of each problem: the SVD of the column-scaled
// design for the undamped least squares (minimum norm), and a column-pivoted
// QR of the augmented [S; √λ·I] for the damped one. A design of scaled
// condition 1e5 (the hybrid's base designs: 1.7e5) with columns in units
// 1e-2 … 1e1 apart, and one with an exact dependency, where the normal
// equations are not used and the minimum-norm step is.
TEST(identifyEstimators, DescentStepsMatchAnIndependentSolveOfEachProblem) {
  std::mt19937_64 rng(43);
  for (int trial = 0; trial < 2; ++trial) {
    const Index n = 300, p = 20;
    MatrixXd X = columns_in_units_apart(design_with_spectrum(n, p, 1.0, 1e5, rng));
    if (trial == 1) X.col(7) = 3.0 * X.col(2) + X.col(11);
    const VectorXd y = X * gaussian(p, rng) + 1e-3 * gaussian(n, rng);
    VectorXd d(p);
    for (Index j = 0; j < p; ++j) d(j) = X.col(j).norm();
    const MatrixXd S = X * d.cwiseInverse().asDiagonal();
    const kincal::identify::detail::DescentStep step(X, y);
    EXPECT_EQ(step.normal_equations(), trial == 0);
    // Undamped: the minimum-norm least squares of S, mapped back by D⁻¹.
    Eigen::JacobiSVD<MatrixXd> svd(S, Eigen::ComputeThinU | Eigen::ComputeThinV);
    svd.setThreshold(1e-10);
    const VectorXd want = svd.solve(y).cwiseQuotient(d);
    EXPECT_LT((step.solve(0.0) - want).norm(), 1e-8 * want.norm()) << "trial " << trial;
    for (const double lambda : {1e-3, 1e-1, 10.0}) {
      MatrixXd A = MatrixXd::Zero(n + p, p);
      A.topRows(n) = S;
      A.bottomRows(p) = std::sqrt(lambda) * MatrixXd::Identity(p, p);
      VectorXd b = VectorXd::Zero(n + p);
      b.head(n) = y;
      const VectorXd damped = A.colPivHouseholderQr().solve(b).cwiseQuotient(d);
      EXPECT_LT((step.solve(lambda) - damped).norm(), 1e-10 * damped.norm()) << "trial " << trial << ", λ " << lambda;
    }
  }
}

// PreparedDesign with the SVD deferred (Options::defer_svd, what an
// iteration of the 6-UPS fit and the outlier screens use) against the same
// design prepared in full: the OLS solution from R alone, the deleted-node
// statistics from Q's thin factor instead of U, then after complete_svd()
// the estimate itself. Columns in units 1e-2 … 1e1 apart, weighted rows, a
// 40σ blunder on one node. Every SVD-only method refuses before
// complete_svd(); a design whose column norms span more than 1/ε is never
// deferred (its unscaled spectrum is what the guard reads).
TEST(identifyEstimators, DeferredSvdGivesTheSameOlsAndOutlierStatistics) {
  std::mt19937_64 rng(47);
  const MatrixXd H = columns_in_units_apart(gaussian(150, 7, rng));
  LinearProblem p = node_problem(rng, gaussian(7, rng), 0.01, H);
  std::uniform_real_distribution<double> w(0.5, 4.0);
  p.weights = VectorXd(p.H.rows());
  for (Index i = 0; i < p.H.rows(); ++i) (*p.weights)(i) = w(rng);
  p.y(3 * 21 + 2) += 40 * 0.01;  // node 121
  const PreparedDesign full(p);
  PreparedDesign::Options o;
  o.defer_svd = true;
  PreparedDesign deferred(p, o);
  ASSERT_FALSE(deferred.svd_complete());
  EXPECT_EQ(deferred.rank(), full.rank());
  EXPECT_EQ(deferred.scaled_condition_number(), full.scaled_condition_number());
  EXPECT_THROW(deferred.V(), std::logic_error);
  EXPECT_THROW(deferred.condition_number(), std::logic_error);
  EXPECT_THROW(estimate(deferred, p, {}), std::logic_error);

  FitWorkspace ws;
  VectorXd x;
  full.ols(p.y, x, ws);
  EXPECT_LT((deferred.ols_solution(p.y) - x).norm(), 1e-10 * x.norm());
  const OutlierReport a = detect_outliers(full, p), b = detect_outliers(deferred, p);
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  EXPECT_EQ(a.outlying_nodes, b.outlying_nodes);
  ASSERT_EQ(b.outlying_nodes, std::vector<Index>{121});
  for (std::size_t k = 0; k < a.nodes.size(); ++k) {
    EXPECT_NEAR(b.nodes[k].f, a.nodes[k].f, 1e-9 * a.nodes[k].f) << "node " << a.nodes[k].node;
    EXPECT_NEAR(b.nodes[k].p_value, a.nodes[k].p_value, 1e-9 * a.nodes[k].p_value + 1e-300) << "node " << a.nodes[k].node;
  }
  deferred.complete_svd();
  const Estimate e_full = estimate(full, p, {}), e_deferred = estimate(deferred, p, {});
  EXPECT_EQ(e_deferred.x, e_full.x);
  EXPECT_EQ(e_deferred.standard_error, e_full.standard_error);

  LinearProblem badly_scaled = p;
  badly_scaled.H.col(3) *= 1e-17;
  PreparedDesign::Options lenient = o;
  lenient.require_full_rank = false;
  const PreparedDesign guarded(badly_scaled, lenient);
  EXPECT_TRUE(guarded.svd_complete());
  EXPECT_NE(guarded.deficiency().find("too badly scaled"), std::string::npos);
}
