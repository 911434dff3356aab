// Linear estimators for seed 000 Eq. (10) as SVD filters: the one entry point
// (estimate) and the one-shot estimators; see estimators.hpp and
// docs/estimators.md. The rest by job: weighting.cpp, liu.cpp (Eqs. (13),
// (14)), prepared_design.cpp (the factorisation and the filters),
// deleted_node_tests.cpp.
#include "kincal/identify/estimators.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "estimate/estimator_detail.hpp"
#include "estimate/scaled_design.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace detail;  // the shared checks and search (estimator_detail.hpp)

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
    const detail::ScaledPivotedQr qr(X.rightCols(X.cols() - penalised));
    free_rank_ = qr.rank();
    const MatrixXd Q = qr.column_space();
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

}  // namespace kincal::identify
