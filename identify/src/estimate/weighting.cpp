// Weighted and generalised least squares by whitening (estimators.hpp,
// "weighting"; docs/estimators.md).
#include "kincal/identify/estimators.hpp"

#include <cmath>

#include "estimate/estimator_detail.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace detail;  // the shared checks and search (estimator_detail.hpp)

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

}  // namespace kincal::identify
