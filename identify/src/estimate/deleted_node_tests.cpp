// The deleted-node F tests of outlying nodes, one at a time and sequentially
// (estimators.hpp, "outliers"; docs/estimators.md); the screen that acts on
// them: outliers.cpp.
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

namespace {

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
  const std::vector<Index> independent = detail::ScaledPivotedQr(problem.H).independent_columns();
  const Index rank = Index(independent.size());
  if (rank == problem.H.cols()) return problem;
  LinearProblem out = problem;
  out.H.resize(problem.H.rows(), rank);
  out.names.clear();
  for (Index k = 0; k < rank; ++k) {
    const Index j = independent[std::size_t(k)];
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
