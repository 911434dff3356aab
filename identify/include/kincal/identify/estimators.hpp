// Linear estimation for the regression model of seed 000 Eq. (10),
//   Δp = H·Δχ + ε,   H: n × m identification Jacobian,
// by ordinary least squares (OLS), ridge (Hoerl–Kennard), principal-components
// regression (PCR) and the Liu estimator (seed 000 Eqs. (11)–(14)); row
// weighting by the measurement covariance; outlier detection by deleted
// residuals. docs/estimators.md gives the formulas, defaults and tolerances.
//
// Every estimator here is a *spectral filter* of the SVD H_w = U·S·Vᵀ of the
// (row-whitened) design: x = V·diag(f_j / s_j)·Uᵀ·y_w with filter factors
//   OLS f_j = 1,   ridge f_j = λ_j/(λ_j + k),   Liu f_j = (λ_j + d)/(λ_j + 1),
//   PCR f_j = 1 for the kept components and 0 otherwise     (λ_j = s_j²),
// so the normal equations HᵀH are never formed, and a Monte Carlo study that
// keeps H fixed factors it once (PreparedDesign) and pays O(n·m) per run.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/rank_tolerance.hpp"

namespace kincal::identify {

struct LinearProblem {
  Eigen::MatrixXd H;                       // n × m, rows are measurements, columns parameters
  Eigen::VectorXd y;                       // n, measured minus nominal (Δp)
  std::optional<Eigen::VectorXd> weights;  // n, 1/σ_i² per row (relative weights are fine)
  std::vector<std::string> names;          // m parameter names, or empty ("x0", "x1", ...)
  // Optional row → node map (a node contributes 3, 6 or 9 rows); used by the
  // outlier test and by without_nodes(). Empty: every row is its own node.
  std::vector<Eigen::Index> row_node;
};

// Sizes, finiteness (NaN/Inf name the row and column), weights > 0, n > m.
// Throws InputError.
void validate(const LinearProblem& problem);

// names[j], or "x<j>" when the problem has no names.
std::string column_name(const LinearProblem& problem, Eigen::Index j);

// ---- weighting (row whitening) -------------------------------------------

// Rows scaled by √w_i (w_i = 1/σ_i²): H_w = W^{1/2} H, y_w = W^{1/2} y. The
// result has no weights. Estimators apply this themselves when weights are set.
LinearProblem whitened(const LinearProblem& problem);

// A full measurement covariance for a group of rows (e.g. one node's 3×3
// target covariance or 9×9 three-target covariance).
struct BlockCovariance {
  std::vector<Eigen::Index> rows;  // row indices of the block, each row in at most one block
  Eigen::MatrixXd covariance;      // rows.size() × rows.size(), symmetric positive definite
};

// Cholesky whitening: for each block Σ = L·Lᵀ, the block's rows become
// L⁻¹·H_B and L⁻¹·y_B. Rows in no block keep their diagonal weight (or 1).
// Throws InputError on a non-SPD covariance, a bad row index or a row listed twice.
LinearProblem whitened(const LinearProblem& problem, const std::vector<BlockCovariance>& blocks);

// Convenience: one covariance per node of problem.row_node, indexed by node id
// (node_covariance[g] has as many rows as node g has rows, in row order).
LinearProblem whitened_by_node(const LinearProblem& problem, const std::vector<Eigen::MatrixXd>& node_covariance);

// ---- estimates -------------------------------------------------------------

enum class LiuRule {
  Eq14,         // seed 000 Eq. (14), clamped to [0, 1]  (the default)
  MinimiseMse,  // numeric minimum of the Eq. (13) MSE over [0, 1] (golden section)
  Fixed,        // the caller's d
};

struct LiuOptions {
  LiuRule rule = LiuRule::Eq14;
  double d = 0.5;  // used by LiuRule::Fixed; must be finite
};

// How ridge's k is chosen (RidgeOptions; the calibrations default to GCV).
enum class RidgeRule {
  Gcv,                  // minimum of generalized cross-validation (Golub, Heath & Wahba 1979)
  HoerlKennardBaldwin,  // k = m·σ̂²_u / ‖x̂_OLS‖² (Hoerl, Kennard & Baldwin 1975); needs full rank
  Fixed,                // the caller's k (≥ 0; 0 is OLS)
};

struct RidgeOptions {
  RidgeRule rule = RidgeRule::Gcv;
  double k = 0;  // used by RidgeRule::Fixed
};

struct PcrOptions {
  // Precedence: components > 0; else variance_fraction in (0, 1]; else
  // by_gcv; else the condition-index cut (keep s_j ≥ s_max / max_condition_index).
  Eigen::Index components = 0;
  double variance_fraction = 0.0;  // fraction of Σ s_j² to retain
  double max_condition_index = 1e3;
  // The number of leading components minimising generalized cross-validation
  // of the truncated SVD, n·RSS_k / (n − k)² (Golub, Heath & Wahba 1979;
  // Hansen, "Rank-Deficient and Discrete Ill-Posed Problems", 1998): uses y,
  // so it adapts to the noise; on noise-free data it keeps every component.
  bool by_gcv = false;
};

struct Estimate {
  std::string method;               // "ols", "ridge", "pcr", "liu"
  std::vector<std::string> names;   // parameter names (column_name of each column)
  Eigen::VectorXd x;                // the estimate Δχ̂
  // Sampling standard deviation of each x_j: √(σ̂²_u · [V diag(f²/s²) Vᵀ]_jj).
  // For OLS the usual σ̂²(HᵀH)⁻¹ diagonal; for ridge / Liu / PCR the spread at
  // the chosen k / d / components taken as fixed (bias not included).
  Eigen::VectorXd standard_error;
  Eigen::VectorXd residual;         // y − H·x in the problem's own units (not whitened)
  double rss = 0;                   // whitened residual sum of squares of this estimate
  // Noise variance from the OLS (minimum-norm LS) fit of the whitened problem:
  //   sigma2          = RSS_OLS / n            seed 000 Eq. (13) as written; used in Eqs. (13)–(14)
  //   sigma2_unbiased = RSS_OLS / (n − rank)   used for standard errors, the
  //                                            Hoerl–Kennard–Baldwin k and outlier tests
  double sigma2 = 0;
  double sigma2_unbiased = 0;
  Eigen::Index rows = 0;
  Eigen::Index rank = 0;
  double condition_number = 0;      // s_max / s_min of the whitened, unscaled H (components used)
  // settings actually used
  double ridge_k = 0;
  bool ridge_k_default = false;     // k chosen by Hoerl–Kennard–Baldwin
  RidgeRule ridge_rule = RidgeRule::Fixed;
  double liu_d = 1;
  double liu_d_unclamped = 1;       // Eq. (14) value before clamping to [0, 1]
  bool liu_d_clamped = false;
  LiuRule liu_rule = LiuRule::Eq14;
  Eigen::Index pcr_components = 0;
};

// OLS by the SVD of the whitened design (rank judged on the column-scaled
// design with effective_rcond(rcond)). A rank-deficient design throws
// InputError naming the columns that are not identifiable and the null-space
// combination(s) (identifiability.hpp null_space_combinations).
Estimate ols(const LinearProblem& problem, double rcond = kDefaultRcond);

// Hoerl–Kennard ridge, x = (HᵀH + k I)⁻¹ Hᵀ y, by SVD filter factors.
// k = nullopt: Hoerl–Kennard–Baldwin k = m·σ̂²_u / ‖x̂_OLS‖² (needs full rank).
// An explicit k > 0 also works on a rank-deficient design; k = 0 is OLS.
Estimate ridge(const LinearProblem& problem, std::optional<double> k = std::nullopt,
               double rcond = kDefaultRcond);

// Principal-components regression on the SVD of the whitened (unscaled) H.
// Works on rank-deficient designs (at most `rank` components are used).
Estimate principal_components(const LinearProblem& problem, const PcrOptions& options = {},
                              double rcond = kDefaultRcond);

// Liu estimator, seed 000 Eq. (11): x_L = (HᵀH + I)⁻¹(Hᵀy + d·x̂_OLS), computed
// as x_L = V·diag((λ_j + d)/(λ_j + 1))·α̂ with α̂ = Vᵀx̂_OLS (Eq. (12)). Needs full rank.
Estimate liu(const LinearProblem& problem, const LiuOptions& options = {}, double rcond = kDefaultRcond);

struct LiuParameter {
  double d = 1;            // value used (clamped to [0, 1] unless LiuRule::Fixed)
  double d_unclamped = 1;  // Eq. (14) value (or the Fixed d)
  bool clamped = false;
};
LiuParameter liu_optimal_d(const LinearProblem& problem, LiuRule rule = LiuRule::Eq14,
                           double rcond = kDefaultRcond);

// The scalar pieces of seed 000 Eqs. (13)–(14) in the eigenbasis of HᵀH
// (λ_j = s_j², α̂_j = (Φᵀx̂)_j, σ̂² of Eq. (13)); exposed for tests and reports.
double liu_mse_eq13(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2, double d);
double liu_d_eq14(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2);
// Golden-section minimum of liu_mse_eq13 over [lo, hi] (to ~1e-10 relative).
double liu_d_minimise_mse(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2,
                          double lo = 0.0, double hi = 1.0);

// Generalized cross-validation of ridge at k (Golub, Heath & Wahba 1979) on
// the whitened problem, from the SVD filter factors f_j = λ_j/(λ_j + k):
//   GCV(k) = n·RSS(k) / (n − Σ_j f_j)²,   RSS(k) = RSS_OLS + Σ_j (1 − f_j)² c_j²,
// the leave-one-out prediction error made rotation-invariant. Works on a
// rank-deficient design (the sums run over the rank).
double ridge_gcv(const LinearProblem& problem, double k, double rcond = kDefaultRcond);

// GCV of a ridge that penalises only the first `penalised` columns of X,
// min ‖z − X·b‖² + k·‖b_head‖², the other columns free (the hybrid's joint
// fit: base parameters shrunk, effect parameters not). In closed form for
// every k from one factorisation: the free columns E are projected out
// (z̃, Ã = (I − P_E)·(z, A)), then with Ã = U·S·Vᵀ and c = Uᵀz̃
//   RSS(k) = ‖z̃‖² − ‖c‖² + Σ_j (k/(s_j² + k))² c_j²,
//   df(k)  = rank(E) + Σ_j s_j²/(s_j² + k),   GCV(k) = n·RSS(k) / (n − df(k))².
// Equal to the augmented least squares [X; √k·(I 0)] solved afresh at each
// k (tested), where that cost a QR of (n + p) × (p + q) per k.
class PartialRidgeGcv {
 public:
  PartialRidgeGcv(const Eigen::MatrixXd& X, const Eigen::VectorXd& z, Eigen::Index penalised);
  double operator()(double k) const;  // +∞ where n − df(k) ≤ 0

 private:
  double n_ = 0, outside_ = 0;  // rows; ‖z̃‖² − ‖c‖²
  Eigen::Index free_rank_ = 0;
  Eigen::VectorXd s2_, c2_;  // s_j², c_j²
};

// k by options.rule. Gcv: the minimum of ridge_gcv over k ≥ 0 (a log-spaced
// grid over [λ_min·1e-6, λ_max·1e2] refined by golden section, compared with
// k = 0; k = 0 when OLS is at least as good, e.g. on noise-free data).
double ridge_parameter(const LinearProblem& problem, const RidgeOptions& options, double rcond = kDefaultRcond);

// ---- one entry point for the four estimators --------------------------------

enum class EstimatorKind { Ols, Ridge, Pcr, Liu };
const char* to_string(EstimatorKind kind);               // "ols", "ridge", "pcr", "liu"
EstimatorKind parse_estimator(const std::string& name);  // InputError for any other name

// Defaults are the data-driven choices the calibrations use: ridge's k and
// PCR's number of components by GCV, Liu's d by seed 000 Eq. (14).
struct EstimatorOptions {
  EstimatorKind kind = EstimatorKind::Ols;
  RidgeOptions ridge;                                // used by kind Ridge (k by GCV)
  PcrOptions pcr = PcrOptions{0, 0.0, 1e3, true};    // used by kind Pcr (components by GCV)
  LiuOptions liu;                                    // used by kind Liu (d by Eq. (14))
};

// ols / ridge / principal_components / liu by options.kind (ridge's k by
// options.ridge.rule). OLS, Liu and ridge with k = 0 or the HKB rule need a
// full-rank design (InputError naming the null space otherwise).
Estimate estimate(const LinearProblem& problem, const EstimatorOptions& options, double rcond = kDefaultRcond);

// The settings an estimate was made with, as MODEL.json numbers:
//   ridge: ridge_k, and ridge_k_gcv = 1 or ridge_k_hkb = 1 when k was chosen by that rule;
//   pcr:   pcr_components, and pcr_components_gcv = 1, pcr_max_condition_index or
//          pcr_variance_fraction when the number came from that rule;
//   liu:   liu_d, liu_d_unclamped, and liu_d_fixed = 1 / liu_d_min_mse = 1 for those rules;
//   ols:   nothing.
std::map<std::string, double> estimator_settings(const Estimate& estimate, const EstimatorOptions& options);

// ---- factor once, solve many (Monte Carlo) --------------------------------

// Caller-owned scratch for PreparedDesign solves; allocation-free after the
// first solve with a given design size.
struct FitWorkspace {
  Eigen::VectorXd yw, c, r, coef;
};

struct FitInfo {
  double rss = 0;              // whitened RSS of this fit
  double sigma2 = 0;           // RSS_OLS / n          (Eq. (13))
  double sigma2_unbiased = 0;  // RSS_OLS / (n − rank)
  double d = 1, d_unclamped = 1;
  bool d_clamped = false;
  double k = 0;
};

// The SVD H_w = U S Vᵀ of the whitened design, computed once. Each solve
// projects a new y (c = Uᵀ y_w, residual y_w − U c): O(n·m) per run. The
// object is immutable; concurrent solves from several threads are safe with
// one FitWorkspace per thread.
class PreparedDesign {
 public:
  struct Options {
    double rcond = kDefaultRcond;
    bool require_full_rank = true;  // false: allow PCR / ridge (k > 0) on a deficient design
    // Form the n × m U = Q·U_R once (4nm² flops) so that each solve is two
    // matrix–vector products with it, instead of applying Q's reflectors to
    // y (4nm flops, but one reflector at a time: 47 against 9 µs per solve on
    // the hybrid's 882 × 48 fine design). Pays beyond a few hundred solves on
    // one design: Monte Carlo studies.
    bool explicit_u = false;
    // Leave the SVD of R to complete_svd() where nothing in the constructor
    // needs it (a tall design of full rank whose unscaled spectrum is
    // bounded away from rounding by the scaled one's): the rank, the scaled
    // condition number, ols_solution() and the outlier statistics
    // (detect_outliers) come from the QR alone. For an iteration that only
    // steps: the SVD of a 42 × 42 R is 4 M instructions (#13). Every other
    // method needs complete_svd() first (std::logic_error otherwise).
    bool defer_svd = false;
  };
  // Uses problem.H, weights and names (problem.y is not needed and may be empty).
  explicit PreparedDesign(const LinearProblem& problem, Options options);
  explicit PreparedDesign(const LinearProblem& problem) : PreparedDesign(problem, Options{}) {}

  Eigen::Index rows() const { return rows_; }
  Eigen::Index cols() const { return cols_; }
  Eigen::Index rank() const { return rank_; }
  bool full_rank() const { return rank_ == cols(); }
  // Whether the SVD of R is there (Options::defer_svd), and computing it.
  bool svd_complete() const { return svd_done_; }
  void complete_svd();
  // The n × m thin left singular vectors, formed on request (the estimators
  // never need them: Q stays implicit, see the constructor).
  Eigen::MatrixXd U() const;
  const Eigen::MatrixXd& V() const {  // m × m
    require_svd();
    return V_;
  }
  const Eigen::VectorXd& singular_values() const {  // of the whitened, unscaled H
    require_svd();
    return s_;
  }
  double condition_number() const;
  // The OLS solution from the QR alone, R⁻¹·(Qᵀ·y_w)_top (tall, full-rank
  // designs; ols()'s x to rounding): what an iteration steps by.
  Eigen::VectorXd ols_solution(const Eigen::VectorXd& y) const;
  // The whitened OLS residual r_w, an orthonormal basis of the design's
  // column space (n × rank: U's leading columns, or with the SVD deferred
  // Q's thin factor, the same projector) and the RSS: the outlier statistics.
  double ols_residual(const Eigen::VectorXd& y, Eigen::VectorXd& r_w, Eigen::MatrixXd& basis) const;
  // s_max / s_min of the whitened design on unit-norm columns (inf when
  // rank-deficient): rank_by_svd's condition number, from the same
  // factorisation.
  double scaled_condition_number() const { return scaled_condition_number_; }
  const std::vector<std::string>& names() const { return names_; }
  // "" when full rank; otherwise the rank-deficiency message (columns and
  // null-space combinations), as thrown by ols().
  const std::string& deficiency() const { return deficiency_; }

  // OLS (throws InputError with the deficiency message on a deficient design).
  FitInfo ols(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws) const;
  FitInfo liu(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws, const LiuOptions& options = {}) const;
  FitInfo ridge(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws,
                std::optional<double> k = std::nullopt) const;
  // PCR with the first `components` (≤ rank) principal components.
  FitInfo pcr(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws, Eigen::Index components) const;
  // Number of components PcrOptions selects on this design (by_gcv is
  // ignored here: it needs y, see pcr_components_gcv).
  Eigen::Index pcr_components(const PcrOptions& options) const;
  // The number of leading components minimising n·RSS_k / (n − k)² for data y.
  Eigen::Index pcr_components_gcv(const Eigen::VectorXd& y, FitWorkspace& ws) const;
  // Generalized cross-validation of ridge at k for data y, and its minimiser
  // over k ≥ 0 (see ridge_gcv / ridge_parameter).
  double ridge_gcv(const Eigen::VectorXd& y, FitWorkspace& ws, double k) const;
  double ridge_k_gcv(const Eigen::VectorXd& y, FitWorkspace& ws) const;

  // √(σ² · [V diag(f_j²/s_j²) Vᵀ]_jj) for filter factors f (size ≥ rank; entries
  // beyond rank ignored).
  Eigen::VectorXd standard_errors(const Eigen::VectorXd& filter, double sigma2) const;

 private:
  // c = Uᵀ y_w for the rank used; returns RSS_OLS. ws.r is not set.
  double project(const Eigen::VectorXd& y, FitWorkspace& ws) const;
  FitInfo finish(FitWorkspace& ws, Eigen::VectorXd& x, double rss_ols) const;
  void require_full_rank() const;
  void require_svd() const;
  // √w ∘ y (y itself when unweighted), y's length checked.
  Eigen::VectorXd whitened(const Eigen::VectorXd& y) const;

  // Tall design (n > m): Hw = Q·R by Householder QR, R = U_R·S·Vᵀ; qr_
  // holds Q's reflectors and U_ is U_R (m × m); U_full_ is Q·U_R when
  // Options::explicit_u asked for it (else empty). Otherwise U_ is the thin U.
  Eigen::HouseholderQR<Eigen::MatrixXd> qr_;
  bool tall_ = false;
  bool svd_done_ = true;
  Eigen::Index rows_ = 0, cols_ = 0;
  Eigen::MatrixXd U_, V_, U_full_;
  Eigen::VectorXd s_;
  Eigen::VectorXd sqrt_w_;  // empty: unweighted
  Eigen::Index rank_ = 0;
  double scaled_condition_number_ = 0;
  std::vector<std::string> names_;
  std::string deficiency_;
};

// The one-shot estimate of `problem` (its y; H, weights and names as the
// design was prepared from) on an existing factorisation: several estimators
// on one design cost one SVD.
Estimate estimate(const PreparedDesign& design, const LinearProblem& problem, const EstimatorOptions& options);

// ---- outliers --------------------------------------------------------------

struct OutlierOptions {
  // Family-wise false-alarm probability on clean data, Bonferroni-corrected
  // over the testable nodes: node g is outlying when its deletion p-value
  // p_g < alpha / N.
  double alpha = 0.01;
};

struct NodeStatistic {
  Eigen::Index node = 0;   // node id from row_node (or the row index)
  Eigen::Index rows = 0;   // rows of the node (3, 6, 9, ...)
  // Deleted-node F statistic (Cook & Weisberg multi-case deletion):
  //   Q = r_Gᵀ (I − P_GG)⁻¹ r_G,  F = (Q / p) / s²_(G),  s²_(G) = (RSS − Q)/(n − m − p),
  // distributed F(p, n − m − p) on clean Gaussian data (P = hat matrix).
  double f = 0;
  double p_value = 1;      // single-test p-value P(F_{p,ν} > f)
  double max_abs_t = 0;    // largest |deleted studentized residual| among the node's rows
  bool testable = true;    // false when deleting the node loses rank (leverage 1) or dof
  bool outlying = false;
};

struct OutlierReport {
  Eigen::VectorXd deleted_t;            // per row: r_i / (s_(i) √(1 − h_ii)), t(n − m − 1) on clean data; NaN if h_ii ≈ 1
  std::vector<NodeStatistic> nodes;     // ascending node id
  std::vector<Eigen::Index> outlying_nodes;
  double alpha = 0;
  double p_threshold = 0;               // alpha / (number of testable nodes)
  Eigen::Index testable_nodes = 0;
};

// Fits OLS on the whitened problem (full rank required) and tests each node.
OutlierReport detect_outliers(const LinearProblem& problem, const OutlierOptions& options = {},
                              double rcond = kDefaultRcond);
// The same on an existing factorisation of problem's design (the one its last
// estimate used): the statistics need no other.
OutlierReport detect_outliers(const PreparedDesign& design, const LinearProblem& problem,
                              const OutlierOptions& options = {});

// A node's test in terms of the measurement file (calibrations report these):
// its id and line, the deleted-node F statistic and p-value.
struct NodeTest {
  std::string id;
  std::size_t line = 0;
  double f = 0, p_value = 1;  // deleted-node F statistic and its p-value
  bool testable = true, outlying = false;
};

// The most significant outlying test (smallest p-value; ties, e.g. p-values
// that underflow to 0, by the larger F), or null when none is outlying.
const NodeTest* most_significant_outlier(const std::vector<NodeTest>& tests);

// The sequential search (issue #11 item 5; one mechanism for identify,
// identify --effects and diagnose: identify/outliers.hpp): test every node
// on the model's linearised design at the solution, set the most significant
// outlying one aside, test the rest again (the linear refit without it: no
// nonlinear refit per node), until none is flagged. One gross error makes its
// neighbours look suspicious too, so they are not all flagged at once. A
// misfit still flagged after max_fraction of the nodes is set aside is
// systematic (an unmodelled effect, or noise-free data where the residual is
// rounding): the search stops and says so. It also stops before fewer than
// min_nodes would remain.
struct SequentialOutlierOptions {
  double alpha = 0.01;
  double max_fraction = 0.1;
  Eigen::Index max_removed = -1;  // ≥ 0: this many at most (instead of max_fraction of the nodes)
  Eigen::Index min_nodes = 0;
};
struct SequentialOutliers {
  std::vector<NodeStatistic> removed;  // in the order found, each with its statistic at that step
  bool systematic = false;
  double p_threshold = 0;              // of the first test (α / testable nodes)
};
// first_round: detect_outliers' report on `problem` itself when the caller
// already has it (a calibration tests its nodes at its solution); the first
// round then reuses it instead of factoring the same design again.
SequentialOutliers sequential_outliers(const LinearProblem& problem, const SequentialOutlierOptions& options = {},
                                       const OutlierReport* first_round = nullptr);

// The problem without the rows of `nodes` (node ids of row_node, or row
// indices when row_node is empty). Weights and row_node are carried along.
LinearProblem without_nodes(const LinearProblem& problem, const std::vector<Eigen::Index>& nodes);

// Upper tail P(F_{d1,d2} > f) of Fisher's F distribution (regularized incomplete beta).
double f_distribution_upper_tail(double f, double d1, double d2);

}  // namespace kincal::identify
