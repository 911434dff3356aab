// Linear estimators for seed 000 Eq. (10) as SVD filters; see estimators.hpp
// and docs/estimators.md.
#include "kincal/identify/estimators.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::string fmt(double v, const char* format = "%.4g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string idx(Index i) { return std::to_string(i); }

// Checks of everything but y.
void validate_design(const LinearProblem& p) {
  const Index n = p.H.rows(), m = p.H.cols();
  if (n == 0 || m == 0) throw InputError("estimation: empty design matrix (" + idx(n) + " x " + idx(m) + ")");
  if (!p.names.empty() && static_cast<Index>(p.names.size()) != m) {
    throw InputError("estimation: " + std::to_string(p.names.size()) + " parameter names for " + idx(m) + " columns");
  }
  for (Index j = 0; j < m; ++j) {
    for (Index i = 0; i < n; ++i) {
      if (!std::isfinite(p.H(i, j))) {
        throw InputError("estimation: design entry at row " + idx(i) + ", column '" + column_name(p, j) +
                         "' is not finite");
      }
    }
  }
  if (p.weights) {
    if (p.weights->size() != n) {
      throw InputError("estimation: " + idx(p.weights->size()) + " weights for " + idx(n) + " rows");
    }
    for (Index i = 0; i < n; ++i) {
      const double w = (*p.weights)(i);
      if (!std::isfinite(w) || !(w > 0)) {
        throw InputError("estimation: weight of row " + idx(i) + " is " + fmt(w) + " (must be finite and > 0)");
      }
    }
  }
  if (!p.row_node.empty() && static_cast<Index>(p.row_node.size()) != n) {
    throw InputError("estimation: row_node has " + std::to_string(p.row_node.size()) + " entries for " + idx(n) +
                     " rows");
  }
  if (n <= m) {
    throw InputError("estimation: too few measurements, " + idx(n) + " rows for " + idx(m) +
                     " parameters (need more rows than parameters to estimate the noise variance)");
  }
}

void validate_y(const LinearProblem& p) {
  if (p.y.size() != p.H.rows()) {
    throw InputError("estimation: y has " + idx(p.y.size()) + " entries for " + idx(p.H.rows()) + " rows");
  }
  for (Index i = 0; i < p.y.size(); ++i) {
    if (!std::isfinite(p.y(i))) throw InputError("estimation: measurement y at row " + idx(i) + " is not finite");
  }
}

// Golden-section search of a unimodal f on [lo, hi].
template <class F>
double golden_min(F f, double lo, double hi) {
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = lo, b = hi;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = f(c), fd = f(d);
  for (int it = 0; it < 200 && (b - a) > 1e-12 * (1.0 + std::abs(a) + std::abs(b)); ++it) {
    if (fc <= fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = f(d);
    }
  }
  return 0.5 * (a + b);
}

// Regularized incomplete beta I_x(a, b) by Lentz's continued fraction.
double beta_cf(double a, double b, double x) {
  const double tiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int k = 1; k <= 500; ++k) {
    const double kk = static_cast<double>(k);
    double num = kk * (b - kk) * x / ((a + 2 * kk - 1) * (a + 2 * kk));
    d = 1.0 + num * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1.0 + num / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    h *= d * c;
    num = -(a + kk) * (a + b + kk) * x / ((a + 2 * kk) * (a + 2 * kk + 1));
    d = 1.0 + num * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1.0 + num / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return h;
}

double incomplete_beta(double a, double b, double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(lbt) * beta_cf(a, b, x) / a;
  return 1.0 - std::exp(lbt) * beta_cf(b, a, 1.0 - x) / b;
}

}  // namespace

std::string column_name(const LinearProblem& problem, Eigen::Index j) {
  if (!problem.names.empty() && j >= 0 && j < static_cast<Index>(problem.names.size())) {
    return problem.names[static_cast<std::size_t>(j)];
  }
  return "x" + std::to_string(j);
}

void validate(const LinearProblem& problem) {
  validate_design(problem);
  validate_y(problem);
}

// ---- weighting ---------------------------------------------------------------

LinearProblem whitened(const LinearProblem& problem) {
  LinearProblem out = problem;
  if (!problem.weights) return out;
  validate_design(problem);
  const VectorXd sw = problem.weights->cwiseSqrt();
  out.H = sw.asDiagonal() * problem.H;
  if (problem.y.size() == problem.H.rows()) out.y = sw.cwiseProduct(problem.y);
  out.weights.reset();
  return out;
}

LinearProblem whitened(const LinearProblem& problem, const std::vector<BlockCovariance>& blocks) {
  const Index n = problem.H.rows();
  // Rows outside every block keep their diagonal weight; rows inside take the
  // block covariance instead (their diagonal weight is ignored).
  LinearProblem out = whitened(problem);
  std::vector<char> used(static_cast<std::size_t>(n), 0);
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const BlockCovariance& blk = blocks[b];
    const Index p = static_cast<Index>(blk.rows.size());
    const std::string where = "covariance block " + std::to_string(b);
    if (blk.covariance.rows() != p || blk.covariance.cols() != p) {
      throw InputError(where + ": covariance is " + idx(blk.covariance.rows()) + " x " + idx(blk.covariance.cols()) +
                       " for " + idx(p) + " rows");
    }
    for (Index i : blk.rows) {
      if (i < 0 || i >= n) throw InputError(where + ": row " + idx(i) + " out of range (" + idx(n) + " rows)");
      if (used[static_cast<std::size_t>(i)]) throw InputError(where + ": row " + idx(i) + " is in more than one block");
      used[static_cast<std::size_t>(i)] = 1;
    }
    if (!blk.covariance.allFinite()) throw InputError(where + ": covariance is not finite");
    const double scale = blk.covariance.cwiseAbs().maxCoeff();
    if (!((blk.covariance - blk.covariance.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * scale)) {
      throw InputError(where + ": covariance is not symmetric");
    }
    Eigen::LLT<MatrixXd> llt(blk.covariance);
    if (llt.info() != Eigen::Success || !(llt.matrixLLT().diagonal().minCoeff() > 0)) {
      throw InputError(where + ": covariance is not positive definite");
    }
    MatrixXd Hb(p, problem.H.cols());
    VectorXd yb(p);
    const bool have_y = problem.y.size() == n;
    for (Index r = 0; r < p; ++r) {
      const Index i = blk.rows[static_cast<std::size_t>(r)];
      Hb.row(r) = problem.H.row(i);
      if (have_y) yb(r) = problem.y(i);
    }
    llt.matrixL().solveInPlace(Hb);
    if (have_y) llt.matrixL().solveInPlace(yb);
    for (Index r = 0; r < p; ++r) {
      const Index i = blk.rows[static_cast<std::size_t>(r)];
      out.H.row(i) = Hb.row(r);
      if (have_y) out.y(i) = yb(r);
    }
  }
  return out;
}

LinearProblem whitened_by_node(const LinearProblem& problem, const std::vector<Eigen::MatrixXd>& node_covariance) {
  if (problem.row_node.size() != static_cast<std::size_t>(problem.H.rows())) {
    throw InputError("whitening by node: the problem has no row_node map for its " + idx(problem.H.rows()) + " rows");
  }
  std::map<Index, std::vector<Index>> rows_of;
  for (std::size_t i = 0; i < problem.row_node.size(); ++i) rows_of[problem.row_node[i]].push_back(static_cast<Index>(i));
  std::vector<BlockCovariance> blocks;
  for (auto& [node, rows] : rows_of) {
    if (node < 0 || node >= static_cast<Index>(node_covariance.size())) {
      throw InputError("whitening by node: no covariance for node " + idx(node));
    }
    blocks.push_back({rows, node_covariance[static_cast<std::size_t>(node)]});
  }
  return whitened(problem, blocks);
}

// ---- Liu parameter (seed 000 Eqs. (13), (14)) ------------------------------

double liu_mse_eq13(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2, double d) {
  double var = 0, bias = 0;
  for (Index j = 0; j < lambda.size(); ++j) {
    const double l = lambda(j), l1 = (l + 1) * (l + 1);
    var += (l + d) * (l + d) / (l * l1);
    bias += alpha_hat(j) * alpha_hat(j) / l1;
  }
  return sigma2 * var + (d - 1) * (d - 1) * bias;
}

double liu_d_eq14(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2) {
  double num = 0, den = 0;
  for (Index j = 0; j < lambda.size(); ++j) {
    const double l = lambda(j), l1 = (l + 1) * (l + 1), a2 = alpha_hat(j) * alpha_hat(j);
    num += (a2 - sigma2) / l1;
    den += (sigma2 + l * a2) / (l * l1);
  }
  // den = 0 only with σ̂² = 0 and α̂ = 0: nothing to shrink, d = 1 (OLS).
  return den > 0 ? num / den : 1.0;
}

double liu_d_minimise_mse(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2, double lo,
                          double hi) {
  return golden_min([&](double d) { return liu_mse_eq13(lambda, alpha_hat, sigma2, d); }, lo, hi);
}

namespace {

// d from the projected data without forming vectors (a Monte Carlo run
// stays allocation-free): λ_j = s_j², α̂_j = c_j / s_j (c = Uᵀy_w, α̂ = Vᵀx̂).
struct ProjectedSpectrum {
  const VectorXd& s;
  const VectorXd& c;
  double eq14(double sigma2) const {
    double num = 0, den = 0;
    for (Index j = 0; j < c.size(); ++j) {
      const double l = s(j) * s(j), l1 = (l + 1) * (l + 1), a = c(j) / s(j), a2 = a * a;
      num += (a2 - sigma2) / l1;
      den += (sigma2 + l * a2) / (l * l1);
    }
    return den > 0 ? num / den : 1.0;
  }
  double mse(double sigma2, double d) const {
    double var = 0, bias = 0;
    for (Index j = 0; j < c.size(); ++j) {
      const double l = s(j) * s(j), l1 = (l + 1) * (l + 1), a = c(j) / s(j);
      var += (l + d) * (l + d) / (l * l1);
      bias += a * a / l1;
    }
    return sigma2 * var + (d - 1) * (d - 1) * bias;
  }
};

LiuParameter choose_d(const VectorXd& s, const VectorXd& c, double sigma2, const LiuOptions& opt) {
  LiuParameter p;
  if (opt.rule == LiuRule::Fixed) {
    if (!std::isfinite(opt.d)) throw InputError("Liu: fixed d is not finite");
    p.d = p.d_unclamped = opt.d;
    return p;
  }
  const ProjectedSpectrum spec{s, c};
  p.d_unclamped = spec.eq14(sigma2);
  if (opt.rule == LiuRule::Eq14) {
    p.d = std::clamp(p.d_unclamped, 0.0, 1.0);
    p.clamped = p.d != p.d_unclamped;
  } else {
    // The MSE is a convex quadratic in d, so its minimum on [0, 1] is the
    // clamped Eq. (14) value; the unclamped one is reported for comparison.
    p.d = golden_min([&](double d) { return spec.mse(sigma2, d); }, 0.0, 1.0);
    p.clamped = p.d_unclamped < 0.0 || p.d_unclamped > 1.0;
  }
  return p;
}

}  // namespace

// ---- PreparedDesign ----------------------------------------------------------

PreparedDesign::PreparedDesign(const LinearProblem& problem, Options options) {
  validate_design(problem);
  const Index n = problem.H.rows(), m = problem.H.cols();
  for (Index j = 0; j < m; ++j) names_.push_back(column_name(problem, j));
  MatrixXd Hw;
  if (problem.weights) {
    sqrt_w_ = problem.weights->cwiseSqrt();
    Hw = sqrt_w_.asDiagonal() * problem.H;
  } else {
    Hw = problem.H;
  }
  // One factorisation serves the rank, every estimator and the outlier
  // statistics (issue #13): the Householder QR Hw = Q·R, then the SVD of the
  // m × m factor R = U_R·S·Vᵀ, so Hw = (Q·U_R)·S·Vᵀ. The rank is judged on
  // the unit-norm columns (units differ between columns), i.e. on R·D⁻¹;
  // the estimators use the SVD of the unscaled whitened design, as seed 000
  // Eqs. (11)–(14) are written for it.
  // Q stays implicit (its reflectors): an estimate needs only Qᵀy, which
  // costs 4nm flops, where forming Q·U_R would cost 4nm².
  RankReport rr;
  rows_ = n;
  cols_ = m;
  tall_ = n > m;
  if (tall_) {
    qr_.compute(Hw);
    const MatrixXd R = qr_.matrixQR().topRows(m).triangularView<Eigen::Upper>();
    rr = rank_of_factor(R, n, options.rcond, ColumnScaling::UnitNorm);
    // Deferred only where the guard below cannot fire: full scaled rank, and
    // s_min(R) ≥ s_min(R·D⁻¹)·min D above its floor with s_max(R) ≤
    // s_max(R·D⁻¹)·max D.
    bool defer = options.defer_svd && !options.explicit_u && m > 0 && rr.rank == m;
    if (defer) {
      const double low = rr.singular_values(m - 1) * rr.column_scale.minCoeff();
      const double high = rr.singular_values(0) * rr.column_scale.maxCoeff();
      defer = low > static_cast<double>(n) * std::numeric_limits<double>::epsilon() * high;
    }
    svd_done_ = false;
    if (defer) {
      rank_ = m;
      scaled_condition_number_ = rr.condition_number;
      return;
    }
    complete_svd();
    if (options.explicit_u) U_full_ = U();
  } else {  // as many rows as columns or fewer: rank-deficient or square, small
    rr = rank_by_svd(Hw, options.rcond, ColumnScaling::UnitNorm);
    const Eigen::BDCSVD<MatrixXd> svd(Hw, Eigen::ComputeThinU | Eigen::ComputeThinV);
    U_ = svd.matrixU();
    V_ = svd.matrixV();
    s_ = svd.singularValues();
  }
  rank_ = rr.rank;
  scaled_condition_number_ = rr.condition_number;
  // Guard against a design whose unscaled spectrum is degenerate although the
  // scaled one is not (column norms differing by ~1/ε).
  const double floor = static_cast<double>(std::max(n, m)) * std::numeric_limits<double>::epsilon() * s_(0);
  Index unscaled = 0;
  while (unscaled < s_.size() && s_(unscaled) > floor) ++unscaled;
  if (rank_ == m && unscaled < m) {
    rank_ = unscaled;
    deficiency_ = "design is too badly scaled to solve: column norms span more than 1/eps (rescale the parameters)";
  } else if (rank_ < m) {
    rank_ = std::min(rank_, unscaled);
    std::string cols, combos;
    for (Index j : unidentifiable_columns(Hw, options.rcond)) {
      if (!cols.empty()) cols += ", ";
      cols += names_[static_cast<std::size_t>(j)];
    }
    for (const NullCombination& c : null_space_combinations(Hw, names_, options.rcond)) {
      if (!combos.empty()) combos += "; ";
      combos += "[" + c.text + "]";
    }
    deficiency_ = "rank-deficient design: rank " + idx(rr.rank) + " of " + idx(m) + " parameters (rcond " +
                  fmt(rr.rcond, "%.3g") + " on unit-norm columns); not identifiable: " + cols +
                  "; measurements do not change along " + combos;
  }
  if (options.require_full_rank && !deficiency_.empty()) throw InputError(deficiency_);
}

void PreparedDesign::complete_svd() {
  if (svd_done_) return;
  const MatrixXd R = qr_.matrixQR().topRows(cols_).triangularView<Eigen::Upper>();
  const Eigen::BDCSVD<MatrixXd> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  U_ = svd.matrixU();
  V_ = svd.matrixV();
  s_ = svd.singularValues();
  svd_done_ = true;
}

double PreparedDesign::condition_number() const {
  require_svd();
  if (rank_ == 0) return std::numeric_limits<double>::infinity();
  return s_(0) / s_(rank_ - 1);
}

void PreparedDesign::require_full_rank() const {
  if (!deficiency_.empty()) throw InputError(deficiency_);
}

void PreparedDesign::require_svd() const {
  if (!svd_done_) throw std::logic_error("PreparedDesign: the SVD was deferred (Options::defer_svd): complete_svd() first");
}

Eigen::VectorXd PreparedDesign::whitened(const Eigen::VectorXd& y) const {
  if (y.size() != rows()) {
    throw std::invalid_argument("PreparedDesign: y has " + idx(y.size()) + " entries for " + idx(rows()) + " rows");
  }
  return sqrt_w_.size() > 0 ? VectorXd(sqrt_w_.cwiseProduct(y)) : y;
}

Eigen::VectorXd PreparedDesign::ols_solution(const Eigen::VectorXd& y) const {
  require_full_rank();
  if (!tall_) {
    FitWorkspace ws;
    VectorXd x;
    ols(y, x, ws);
    return x;
  }
  VectorXd z = whitened(y);
  z.applyOnTheLeft(qr_.householderQ().transpose());
  return qr_.matrixQR().topRows(cols_).triangularView<Eigen::Upper>().solve(z.head(cols_));
}

double PreparedDesign::ols_residual(const Eigen::VectorXd& y, Eigen::VectorXd& r_w, Eigen::MatrixXd& basis) const {
  if (svd_done_) {
    FitWorkspace ws;
    VectorXd x;
    const FitInfo info = ols(y, x, ws);
    basis = U().leftCols(rank_);
    r_w = ws.yw - basis * ws.c;
    return info.rss;
  }
  // Deferred: a tall design of full rank, whose Q's thin factor spans the
  // column space (Q₁Q₁ᵀ = U·Uᵀ).
  require_full_rank();
  const VectorXd yw = whitened(y);
  basis = MatrixXd::Identity(rows_, cols_);
  basis.applyOnTheLeft(qr_.householderQ());
  r_w = yw - basis * (basis.transpose() * yw);
  return r_w.squaredNorm();
}

double PreparedDesign::project(const Eigen::VectorXd& y, FitWorkspace& ws) const {
  require_svd();
  ws.yw = whitened(y);
  ws.c.resize(rank_);
  if (!tall_ || U_full_.size() > 0) {
    const auto Ur = (tall_ ? U_full_ : U_).leftCols(rank_);
    ws.c.noalias() = Ur.transpose() * ws.yw;
    ws.r = ws.yw;
    ws.r.noalias() -= Ur * ws.c;
    return ws.r.squaredNorm();
  }
  const auto Ur = U_.leftCols(rank_);
  // z = Qᵀ y_w: the first m entries are in R's range, the rest is the
  // residual of the full column space; RSS on the rank used adds what of
  // z_top the first `rank_` columns of U_R do not reach.
  ws.r = ws.yw;
  ws.r.applyOnTheLeft(qr_.householderQ().transpose());
  const Index m = cols();
  ws.c.noalias() = Ur.transpose() * ws.r.head(m);
  ws.coef = ws.r.head(m);
  ws.coef.noalias() -= Ur * ws.c;
  return ws.coef.squaredNorm() + ws.r.tail(rows_ - m).squaredNorm();
}

Eigen::MatrixXd PreparedDesign::U() const {
  require_svd();
  if (!tall_) return U_;
  if (U_full_.size() > 0) return U_full_;
  MatrixXd U = MatrixXd::Zero(rows_, cols());
  U.topRows(cols()) = U_;
  U.applyOnTheLeft(qr_.householderQ());
  return U;
}

// x = V_r · coef; ws.coef holds f_j c_j / s_j on entry.
FitInfo PreparedDesign::finish(FitWorkspace& ws, Eigen::VectorXd& x, double rss_ols) const {
  x.resize(cols());
  x.noalias() = V_.leftCols(rank_) * ws.coef;
  FitInfo info;
  const double n = static_cast<double>(rows());
  info.sigma2 = rss_ols / n;
  info.sigma2_unbiased = rss_ols / (n - static_cast<double>(rank_));
  // RSS of a filtered fit: ‖y_w − U(f∘c)‖² = RSS_OLS + Σ (1 − f_j)² c_j²
  // (the OLS residual is orthogonal to the columns of U).
  double extra = 0;
  for (Index j = 0; j < rank_; ++j) {
    const double fitted = ws.coef(j) * s_(j);
    extra += (ws.c(j) - fitted) * (ws.c(j) - fitted);
  }
  info.rss = rss_ols + extra;
  return info;
}

FitInfo PreparedDesign::ols(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws) const {
  require_full_rank();
  const double rss = project(y, ws);
  ws.coef = ws.c.cwiseQuotient(s_.head(rank_));
  return finish(ws, x, rss);
}

FitInfo PreparedDesign::liu(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws,
                            const LiuOptions& options) const {
  require_full_rank();
  const double rss = project(y, ws);
  const double sigma2 = rss / static_cast<double>(rows());  // Eq. (13) σ̂² = RSS/n
  const LiuParameter p = choose_d(s_, ws.c, sigma2, options);
  // Eq. (11) in the eigenbasis (Eq. (12)): α_L,j = (λ_j + d)/(λ_j + 1) · α̂_j, α̂_j = c_j / s_j.
  ws.coef.resize(rank_);
  for (Index j = 0; j < rank_; ++j) {
    const double l = s_(j) * s_(j);
    ws.coef(j) = (l + p.d) / (l + 1.0) * ws.c(j) / s_(j);
  }
  FitInfo info = finish(ws, x, rss);
  info.d = p.d;
  info.d_unclamped = p.d_unclamped;
  info.d_clamped = p.clamped;
  return info;
}

FitInfo PreparedDesign::ridge(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws,
                              std::optional<double> k) const {
  if (k && (!std::isfinite(*k) || *k < 0)) throw InputError("ridge: k = " + fmt(*k) + " (must be finite and >= 0)");
  if (!k || *k == 0) require_full_rank();
  const double rss = project(y, ws);
  double kk = 0;
  if (k) {
    kk = *k;
  } else {
    // Hoerl, Kennard & Baldwin (1975): k = m σ̂²_u / ‖x̂_OLS‖², ‖x̂‖² = Σ (c_j/s_j)².
    double norm2 = 0;
    for (Index j = 0; j < rank_; ++j) norm2 += (ws.c(j) / s_(j)) * (ws.c(j) / s_(j));
    const double s2u = rss / static_cast<double>(rows() - rank_);
    kk = norm2 > 0 ? static_cast<double>(cols()) * s2u / norm2 : 0.0;
  }
  ws.coef.resize(rank_);
  for (Index j = 0; j < rank_; ++j) ws.coef(j) = s_(j) * ws.c(j) / (s_(j) * s_(j) + kk);  // f_j c_j / s_j
  FitInfo info = finish(ws, x, rss);
  info.k = kk;
  return info;
}

FitInfo PreparedDesign::pcr(const Eigen::VectorXd& y, Eigen::VectorXd& x, FitWorkspace& ws,
                            Eigen::Index components) const {
  if (components < 1 || components > rank_) {
    throw InputError("PCR: " + idx(components) + " components requested; the design has rank " + idx(rank_));
  }
  const double rss = project(y, ws);
  ws.coef = VectorXd::Zero(rank_);
  ws.coef.head(components) = ws.c.head(components).cwiseQuotient(s_.head(components));
  return finish(ws, x, rss);
}

Eigen::Index PreparedDesign::pcr_components(const PcrOptions& o) const {
  if (o.components > 0) return o.components;
  require_svd();
  if (o.variance_fraction > 0) {
    if (!(o.variance_fraction <= 1.0)) throw InputError("PCR: variance fraction " + fmt(o.variance_fraction) + " > 1");
    const double total = s_.head(rank_).squaredNorm();
    double acc = 0;
    for (Index j = 0; j < rank_; ++j) {
      acc += s_(j) * s_(j);
      if (acc >= o.variance_fraction * total * (1 - 1e-15)) return j + 1;
    }
    return rank_;
  }
  if (!(o.max_condition_index >= 1)) throw InputError("PCR: max condition index " + fmt(o.max_condition_index) + " < 1");
  Index k = 0;
  while (k < rank_ && s_(k) * o.max_condition_index >= s_(0)) ++k;
  return std::max<Index>(k, 1);
}

Eigen::VectorXd PreparedDesign::standard_errors(const Eigen::VectorXd& filter, double sigma2) const {
  require_svd();
  const VectorXd g = filter.head(rank_).cwiseQuotient(s_.head(rank_)).cwiseAbs2();  // f_j² / s_j²
  VectorXd var = V_.leftCols(rank_).cwiseAbs2() * g;
  return (sigma2 * var).cwiseSqrt();
}

double PreparedDesign::ridge_gcv(const Eigen::VectorXd& y, FitWorkspace& ws, double k) const {
  if (!std::isfinite(k) || k < 0) throw InputError("ridge GCV: k = " + fmt(k) + " (must be finite and >= 0)");
  const double rss_ols = project(y, ws);
  const double n = static_cast<double>(rows());
  double rss = rss_ols, trace = 0;
  for (Index j = 0; j < rank_; ++j) {
    const double l = s_(j) * s_(j), f = k == 0 ? 1.0 : l / (l + k);
    rss += (1 - f) * (1 - f) * ws.c(j) * ws.c(j);
    trace += f;
  }
  return n * rss / ((n - trace) * (n - trace));
}

double PreparedDesign::ridge_k_gcv(const Eigen::VectorXd& y, FitWorkspace& ws) const {
  if (rank_ == 0) return 0.0;
  const double rss_ols = project(y, ws);
  const double n = static_cast<double>(rows());
  // GCV as a function of t = log k, evaluated from the projection c alone.
  auto gcv = [&](double t) {
    const double k = std::exp(t);
    double rss = rss_ols, trace = 0;
    for (Index j = 0; j < rank_; ++j) {
      const double l = s_(j) * s_(j), f = l / (l + k);
      rss += (1 - f) * (1 - f) * ws.c(j) * ws.c(j);
      trace += f;
    }
    return n * rss / ((n - trace) * (n - trace));
  };
  // GCV need not be unimodal: a log grid from far below the smallest to above
  // the largest eigenvalue (where ridge is OLS resp. shrinks everything),
  // then golden section between the best grid point's neighbours.
  const double lmin = s_(rank_ - 1) * s_(rank_ - 1), lmax = s_(0) * s_(0);
  const double t0 = std::log(lmin) - 6 * std::log(10.0), t1 = std::log(lmax) + 2 * std::log(10.0);
  constexpr int kGrid = 200;
  int best = 0;
  double best_value = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= kGrid; ++i) {
    const double v = gcv(t0 + (t1 - t0) * i / kGrid);
    if (v < best_value) {
      best_value = v;
      best = i;
    }
  }
  const double step = (t1 - t0) / kGrid;
  const double lo = t0 + step * std::max(best - 1, 0), hi = t0 + step * std::min(best + 1, kGrid);
  const double t = golden_min(gcv, lo, hi), value = gcv(t);
  double k = std::exp(t0 + step * best);
  if (value <= best_value) {
    k = std::exp(t);
    best_value = value;
  }
  // k = 0 (OLS) when it cross-validates at least as well, e.g. noise-free data
  // (not on a rank-deficient design, where k = 0 has no unique solution).
  if (!full_rank()) return k;
  const double trace0 = static_cast<double>(rank_);
  const double gcv0 = n * rss_ols / ((n - trace0) * (n - trace0));
  return gcv0 <= best_value ? 0.0 : k;
}

Eigen::Index PreparedDesign::pcr_components_gcv(const Eigen::VectorXd& y, FitWorkspace& ws) const {
  if (rank_ == 0) throw InputError("PCR: the design has rank 0");
  const double rss_ols = project(y, ws);
  const double n = static_cast<double>(rows());
  // RSS of the first k components: RSS_OLS + Σ_{j ≥ k} c_j² (dropped components' fit).
  double dropped = ws.c.squaredNorm();
  Index best = 1;
  double best_value = std::numeric_limits<double>::infinity();
  for (Index k = 1; k <= rank_; ++k) {
    dropped -= ws.c(k - 1) * ws.c(k - 1);
    const double rss = rss_ols + std::max(dropped, 0.0);
    const double value = n * rss / ((n - static_cast<double>(k)) * (n - static_cast<double>(k)));
    if (value < best_value) {
      best_value = value;
      best = k;
    }
  }
  return best;
}

// ---- one entry point ------------------------------------------------------------

const char* to_string(EstimatorKind kind) {
  switch (kind) {
    case EstimatorKind::Ols: return "ols";
    case EstimatorKind::Ridge: return "ridge";
    case EstimatorKind::Pcr: return "pcr";
    case EstimatorKind::Liu: return "liu";
  }
  return "?";
}

EstimatorKind parse_estimator(const std::string& name) {
  for (EstimatorKind k : {EstimatorKind::Ols, EstimatorKind::Ridge, EstimatorKind::Pcr, EstimatorKind::Liu}) {
    if (name == to_string(k)) return k;
  }
  throw InputError("unknown estimator '" + name + "' (ols, ridge, pcr, liu)");
}

namespace {

Estimate make_estimate(const PreparedDesign& design, const LinearProblem& problem, std::string method, VectorXd x,
                       const FitInfo& info, const VectorXd& filter) {
  Estimate e;
  e.method = std::move(method);
  e.names = design.names();
  e.residual = problem.y - problem.H * x;
  e.x = std::move(x);
  e.rss = info.rss;
  e.sigma2 = info.sigma2;
  e.sigma2_unbiased = info.sigma2_unbiased;
  e.rows = design.rows();
  e.rank = design.rank();
  e.condition_number = design.condition_number();
  e.standard_error = design.standard_errors(filter, info.sigma2_unbiased);
  return e;
}

bool needs_full_rank(const EstimatorOptions& o) {
  switch (o.kind) {
    case EstimatorKind::Ols:
    case EstimatorKind::Liu: return true;
    case EstimatorKind::Ridge:
      return o.ridge.rule == RidgeRule::HoerlKennardBaldwin || (o.ridge.rule == RidgeRule::Fixed && o.ridge.k == 0);
    case EstimatorKind::Pcr: return false;
  }
  return true;
}

}  // namespace

Estimate estimate(const PreparedDesign& design, const LinearProblem& problem, const EstimatorOptions& options) {
  validate_y(problem);
  if (problem.H.rows() != design.rows() || problem.H.cols() != design.cols()) {
    throw std::invalid_argument("estimate: the problem is " + idx(problem.H.rows()) + " x " + idx(problem.H.cols()) +
                                ", the prepared design " + idx(design.rows()) + " x " + idx(design.cols()));
  }
  FitWorkspace ws;
  VectorXd x;
  const VectorXd l = design.singular_values().head(design.rank()).array().square();
  switch (options.kind) {
    case EstimatorKind::Ols: {
      const FitInfo info = design.ols(problem.y, x, ws);
      return make_estimate(design, problem, "ols", std::move(x), info, VectorXd::Ones(design.rank()));
    }
    case EstimatorKind::Ridge: {
      std::optional<double> k;
      if (options.ridge.rule == RidgeRule::Fixed) k = options.ridge.k;
      if (options.ridge.rule == RidgeRule::Gcv) k = design.ridge_k_gcv(problem.y, ws);
      const FitInfo info = design.ridge(problem.y, x, ws, k);
      const VectorXd f = l.array() / (l.array() + info.k);
      Estimate e = make_estimate(design, problem, "ridge", std::move(x), info, f);
      e.ridge_k = info.k;
      e.ridge_rule = options.ridge.rule;
      e.ridge_k_default = options.ridge.rule == RidgeRule::HoerlKennardBaldwin;
      return e;
    }
    case EstimatorKind::Pcr: {
      const PcrOptions& po = options.pcr;
      const bool gcv = po.components <= 0 && !(po.variance_fraction > 0) && po.by_gcv;
      const Index comps = gcv ? design.pcr_components_gcv(problem.y, ws) : design.pcr_components(po);
      const FitInfo info = design.pcr(problem.y, x, ws, comps);
      VectorXd f = VectorXd::Zero(design.rank());
      f.head(comps).setOnes();
      Estimate e = make_estimate(design, problem, "pcr", std::move(x), info, f);
      e.pcr_components = comps;
      return e;
    }
    case EstimatorKind::Liu: {
      const FitInfo info = design.liu(problem.y, x, ws, options.liu);
      const VectorXd f = (l.array() + info.d) / (l.array() + 1.0);
      Estimate e = make_estimate(design, problem, "liu", std::move(x), info, f);
      e.liu_d = info.d;
      e.liu_d_unclamped = info.d_unclamped;
      e.liu_d_clamped = info.d_clamped;
      e.liu_rule = options.liu.rule;
      return e;
    }
  }
  throw std::invalid_argument("estimate: unknown estimator kind");
}

Estimate estimate(const LinearProblem& problem, const EstimatorOptions& options, double rcond) {
  validate(problem);
  const PreparedDesign design(problem, {rcond, needs_full_rank(options)});
  return estimate(design, problem, options);
}

std::map<std::string, double> estimator_settings(const Estimate& e, const EstimatorOptions& options) {
  std::map<std::string, double> s;
  switch (options.kind) {
    case EstimatorKind::Ols: break;
    case EstimatorKind::Ridge:
      s["ridge_k"] = e.ridge_k;
      if (options.ridge.rule == RidgeRule::Gcv) s["ridge_k_gcv"] = 1;
      if (options.ridge.rule == RidgeRule::HoerlKennardBaldwin) s["ridge_k_hkb"] = 1;
      break;
    case EstimatorKind::Pcr:
      s["pcr_components"] = static_cast<double>(e.pcr_components);
      if (options.pcr.components <= 0) {
        if (options.pcr.variance_fraction > 0)
          s["pcr_variance_fraction"] = options.pcr.variance_fraction;
        else if (options.pcr.by_gcv)
          s["pcr_components_gcv"] = 1;
        else
          s["pcr_max_condition_index"] = options.pcr.max_condition_index;
      }
      break;
    case EstimatorKind::Liu:
      s["liu_d"] = e.liu_d;
      s["liu_d_unclamped"] = e.liu_d_unclamped;
      if (options.liu.rule == LiuRule::Fixed) s["liu_d_fixed"] = 1;
      if (options.liu.rule == LiuRule::MinimiseMse) s["liu_d_min_mse"] = 1;
      break;
  }
  return s;
}

// ---- one-shot estimators -------------------------------------------------------

Estimate ols(const LinearProblem& problem, double rcond) {
  return estimate(problem, EstimatorOptions{}, rcond);
}

Estimate ridge(const LinearProblem& problem, std::optional<double> k, double rcond) {
  EstimatorOptions o;
  o.kind = EstimatorKind::Ridge;
  o.ridge.rule = k ? RidgeRule::Fixed : RidgeRule::HoerlKennardBaldwin;
  o.ridge.k = k.value_or(0.0);
  if (k && (!std::isfinite(*k) || *k < 0)) throw InputError("ridge: k = " + fmt(*k) + " (must be finite and >= 0)");
  return estimate(problem, o, rcond);
}

Estimate principal_components(const LinearProblem& problem, const PcrOptions& options, double rcond) {
  EstimatorOptions o;
  o.kind = EstimatorKind::Pcr;
  o.pcr = options;
  return estimate(problem, o, rcond);
}

Estimate liu(const LinearProblem& problem, const LiuOptions& options, double rcond) {
  EstimatorOptions o;
  o.kind = EstimatorKind::Liu;
  o.liu = options;
  return estimate(problem, o, rcond);
}

double ridge_gcv(const LinearProblem& problem, double k, double rcond) {
  validate(problem);
  const PreparedDesign design(problem, {rcond, false});
  FitWorkspace ws;
  return design.ridge_gcv(problem.y, ws, k);
}

PartialRidgeGcv::PartialRidgeGcv(const MatrixXd& X, const VectorXd& z, Index penalised) : n_(double(X.rows())) {
  MatrixXd A = X.leftCols(penalised);
  VectorXd zt = z;
  if (X.cols() > penalised) {
    // The free columns' span by a rank-revealing QR (column-scaled, as every
    // design here: effect columns are per unit of their input).
    MatrixXd E = X.rightCols(X.cols() - penalised);
    for (Index j = 0; j < E.cols(); ++j)
      if (E.col(j).norm() > 0) E.col(j) /= E.col(j).norm();
    Eigen::ColPivHouseholderQR<MatrixXd> qr(E);
    qr.setThreshold(1e-10);
    free_rank_ = qr.rank();
    const MatrixXd Q = qr.householderQ() * MatrixXd::Identity(X.rows(), free_rank_);
    A -= Q * (Q.transpose() * A);
    zt -= Q * (Q.transpose() * zt);
  }
  const Eigen::BDCSVD<MatrixXd> svd(A, Eigen::ComputeThinU);
  const VectorXd c = svd.matrixU().transpose() * zt;
  s2_ = svd.singularValues().array().square();
  c2_ = c.array().square();
  outside_ = std::max(0.0, zt.squaredNorm() - c2_.sum());
}

double PartialRidgeGcv::operator()(double k) const {
  double rss = outside_, df = double(free_rank_);
  for (Index j = 0; j < s2_.size(); ++j) {
    const double shrink = s2_(j) + k > 0 ? k / (s2_(j) + k) : 1.0;
    rss += shrink * shrink * c2_(j);
    df += 1.0 - shrink;
  }
  if (!(n_ - df > 0)) return std::numeric_limits<double>::infinity();
  return n_ * rss / ((n_ - df) * (n_ - df));
}

double ridge_parameter(const LinearProblem& problem, const RidgeOptions& options, double rcond) {
  EstimatorOptions o;
  o.kind = EstimatorKind::Ridge;
  o.ridge = options;
  if (options.rule == RidgeRule::Fixed) {
    if (!std::isfinite(options.k) || options.k < 0)
      throw InputError("ridge: k = " + fmt(options.k) + " (must be finite and >= 0)");
    return options.k;
  }
  validate(problem);
  const PreparedDesign design(problem, {rcond, needs_full_rank(o)});
  FitWorkspace ws;
  if (options.rule == RidgeRule::Gcv) return design.ridge_k_gcv(problem.y, ws);
  VectorXd x;
  return design.ridge(problem.y, x, ws, std::nullopt).k;
}

LiuParameter liu_optimal_d(const LinearProblem& problem, LiuRule rule, double rcond) {
  validate(problem);
  const PreparedDesign design(problem, {rcond, true});
  FitWorkspace ws;
  VectorXd x;
  LiuOptions opt;
  opt.rule = rule;
  const FitInfo info = design.liu(problem.y, x, ws, opt);
  return {info.d, info.d_unclamped, info.d_clamped};
}

// ---- outliers ---------------------------------------------------------------

double f_distribution_upper_tail(double f, double d1, double d2) {
  if (!(d1 > 0) || !(d2 > 0)) throw std::invalid_argument("F distribution: degrees of freedom must be > 0");
  if (std::isnan(f)) return std::numeric_limits<double>::quiet_NaN();
  if (f <= 0) return 1.0;
  if (std::isinf(f)) return 0.0;
  // P(F > f) = I_{d2/(d2 + d1 f)}(d2/2, d1/2)
  return incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

OutlierReport detect_outliers(const LinearProblem& problem, const OutlierOptions& options, double rcond) {
  validate(problem);
  PreparedDesign::Options o;
  o.rcond = rcond;
  o.defer_svd = true;  // the statistics need only the QR (full rank) and never the SVD
  return detect_outliers(PreparedDesign(problem, o), problem, options);
}

OutlierReport detect_outliers(const PreparedDesign& design, const LinearProblem& problem,
                              const OutlierOptions& options) {
  validate(problem);
  if (!(options.alpha > 0 && options.alpha < 1)) throw InputError("outliers: alpha " + fmt(options.alpha) + " not in (0, 1)");
  const Index n = design.rows(), m = design.rank();
  // Leverages and residuals from the design's factorisation: an orthonormal
  // basis U of its column space (formed once here; Q's thin factor where
  // the SVD is deferred) and r = y_w − U·Uᵀ·y_w, the whitened OLS residuals.
  VectorXd r;
  MatrixXd U;
  const double rss = design.ols_residual(problem.y, r, U);
  const double nu = static_cast<double>(n - m);
  constexpr double kLeverageOne = 1e-10;  // 1 − h below this: the row alone fixes a direction

  OutlierReport rep;
  rep.alpha = options.alpha;
  rep.deleted_t.resize(n);
  for (Index i = 0; i < n; ++i) {
    const double one_minus_h = 1.0 - U.row(i).squaredNorm();
    const double s2 = (rss - r(i) * r(i) / one_minus_h) / (nu - 1.0);
    if (one_minus_h < kLeverageOne || nu - 1.0 <= 0 || !(s2 > 0)) {
      rep.deleted_t(i) = std::numeric_limits<double>::quiet_NaN();
    } else {
      rep.deleted_t(i) = r(i) / std::sqrt(s2 * one_minus_h);
    }
  }

  std::map<Index, std::vector<Index>> rows_of;
  for (Index i = 0; i < n; ++i) {
    rows_of[problem.row_node.empty() ? i : problem.row_node[static_cast<std::size_t>(i)]].push_back(i);
  }
  for (const auto& [node, rows] : rows_of) {
    NodeStatistic st;
    st.node = node;
    const Index p = static_cast<Index>(rows.size());
    st.rows = p;
    MatrixXd UG(p, m);
    VectorXd rG(p);
    for (Index a = 0; a < p; ++a) {
      const Index i = rows[static_cast<std::size_t>(a)];
      UG.row(a) = U.row(i);
      rG(a) = r(i);
      if (std::isfinite(rep.deleted_t(i))) st.max_abs_t = std::max(st.max_abs_t, std::abs(rep.deleted_t(i)));
    }
    // I − P_GG is the covariance (/σ²) of the node's residuals; singular when
    // deleting the node would lose rank.
    const MatrixXd A = MatrixXd::Identity(p, p) - UG * UG.transpose();
    Eigen::LDLT<MatrixXd> ldlt(A);
    const double nu_g = nu - static_cast<double>(p);
    const double min_pivot = ldlt.vectorD().minCoeff();
    if (ldlt.info() != Eigen::Success || !(min_pivot > kLeverageOne) || nu_g <= 0) {
      st.testable = false;
      st.f = std::numeric_limits<double>::quiet_NaN();
      st.p_value = 1.0;
    } else {
      const double q = rG.dot(ldlt.solve(rG));
      const double s2 = (rss - q) / nu_g;
      st.f = s2 > 0 ? (q / static_cast<double>(p)) / s2 : std::numeric_limits<double>::infinity();
      st.p_value = f_distribution_upper_tail(st.f, static_cast<double>(p), nu_g);
      ++rep.testable_nodes;
    }
    rep.nodes.push_back(st);
  }
  rep.p_threshold = rep.testable_nodes > 0 ? options.alpha / static_cast<double>(rep.testable_nodes) : 0.0;
  for (NodeStatistic& st : rep.nodes) {
    st.outlying = st.testable && st.p_value < rep.p_threshold;
    if (st.outlying) rep.outlying_nodes.push_back(st.node);
  }
  return rep;
}

namespace {

// The problem on a set of independent columns spanning the same space (the
// hat matrix, hence every deleted-node test, depends on the span only): a
// model whose effect is nearly collinear with the base (the hybrid's
// compliance, 99.9 % confounded) is tested like any other.
LinearProblem on_independent_columns(const LinearProblem& problem) {
  MatrixXd scaled = problem.H;
  for (Index j = 0; j < scaled.cols(); ++j)
    if (scaled.col(j).norm() > 0) scaled.col(j) /= scaled.col(j).norm();
  Eigen::ColPivHouseholderQR<MatrixXd> qr(scaled);
  qr.setThreshold(1e-10);  // as the diagnosis ranks its designs
  const Index rank = qr.rank();
  if (rank == problem.H.cols()) return problem;
  LinearProblem out = problem;
  out.H.resize(problem.H.rows(), rank);
  out.names.clear();
  for (Index k = 0; k < rank; ++k) {
    const Index j = qr.colsPermutation().indices()(k);
    out.H.col(k) = problem.H.col(j);
    if (std::size_t(j) < problem.names.size()) out.names.push_back(problem.names[std::size_t(j)]);
  }
  if (out.names.size() != std::size_t(rank)) out.names.clear();
  return out;
}

}  // namespace

SequentialOutliers sequential_outliers(const LinearProblem& problem, const SequentialOutlierOptions& options,
                                       const OutlierReport* first_round) {
  SequentialOutliers out;
  LinearProblem rest = on_independent_columns(problem);
  // The caller's report holds for the first round when it tested this very
  // problem: the same columns (none dropped above) and the same α.
  if (first_round != nullptr && (rest.H.cols() != problem.H.cols() || first_round->alpha != options.alpha))
    first_round = nullptr;
  OutlierOptions o;
  o.alpha = options.alpha;
  Index limit = 0, nodes = 0;
  for (;;) {
    const OutlierReport rep = out.removed.empty() && first_round != nullptr ? *first_round : detect_outliers(rest, o);
    if (out.removed.empty()) {
      out.p_threshold = rep.p_threshold;
      nodes = Index(rep.nodes.size());
      limit = options.max_removed >= 0 ? options.max_removed
                                       : std::max<Index>(1, Index(options.max_fraction * double(nodes)));
    }
    const NodeStatistic* worst = nullptr;
    for (const NodeStatistic& st : rep.nodes)
      if (st.outlying && (worst == nullptr || st.p_value < worst->p_value ||
                          (st.p_value == worst->p_value && st.f > worst->f)))
        worst = &st;
    if (worst == nullptr) break;
    if (Index(out.removed.size()) >= limit) {
      out.systematic = true;
      break;
    }
    if (nodes - Index(out.removed.size()) - 1 < options.min_nodes) break;
    out.removed.push_back(*worst);
    rest = without_nodes(rest, {worst->node});
  }
  return out;
}

const NodeTest* most_significant_outlier(const std::vector<NodeTest>& tests) {
  const NodeTest* worst = nullptr;
  for (const NodeTest& t : tests) {
    if (!t.outlying) continue;
    if (worst == nullptr || t.p_value < worst->p_value || (t.p_value == worst->p_value && t.f > worst->f)) worst = &t;
  }
  return worst;
}

LinearProblem without_nodes(const LinearProblem& problem, const std::vector<Eigen::Index>& nodes) {
  const Index n = problem.H.rows();
  const std::set<Index> drop(nodes.begin(), nodes.end());
  std::set<Index> present;
  std::vector<Index> keep;
  for (Index i = 0; i < n; ++i) {
    const Index node = problem.row_node.empty() ? i : problem.row_node[static_cast<std::size_t>(i)];
    present.insert(node);
    if (!drop.count(node)) keep.push_back(i);
  }
  for (Index node : drop) {
    if (!present.count(node)) throw InputError("exclusion: node " + idx(node) + " is not in the problem");
  }
  LinearProblem out;
  out.names = problem.names;
  const Index k = static_cast<Index>(keep.size());
  out.H.resize(k, problem.H.cols());
  if (problem.y.size() == n) out.y.resize(k);
  if (problem.weights) out.weights = VectorXd(k);
  for (Index a = 0; a < k; ++a) {
    const Index i = keep[static_cast<std::size_t>(a)];
    out.H.row(a) = problem.H.row(i);
    if (problem.y.size() == n) out.y(a) = problem.y(i);
    if (problem.weights) (*out.weights)(a) = (*problem.weights)(i);
    if (!problem.row_node.empty()) out.row_node.push_back(problem.row_node[static_cast<std::size_t>(i)]);
  }
  return out;
}

}  // namespace kincal::identify
