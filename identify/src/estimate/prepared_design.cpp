// PreparedDesign: one factorisation of a design, every estimator's fit from
// it as an SVD filter (estimators.hpp; docs/estimators.md).
#include "kincal/identify/estimators.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "estimate/estimator_detail.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace detail;  // the shared checks and search (estimator_detail.hpp)

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

}  // namespace kincal::identify
